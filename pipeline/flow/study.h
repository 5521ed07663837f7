#pragma once
// `rockflow study`: what accuracy costs. Measures the error of the solver's physics (temperature,
// pressure, viscosity, permeability) against what it costs in time, for the time step, the
// precision and the resolution of a pore, and the speed of the cell-list settings and of every
// effect switched on alone. Every comparison runs in one process on one backend, so ratios are
// fair. Writes DIR/study.json (provenance + every row) and one CSV per study; the report
// generator scripts/accuracy_report.py turns them into docs/accuracy.md (scripts/accuracy.sh runs
// both).
#include <CLI/CLI.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/simulation.h"

namespace mesorock::pipeline {

// tiny: a smoke test (seconds, CI); small: minutes on a 2-core CPU; full: the GPU study.
enum class StudySize { Tiny, Small, Full };

struct StudyOptions {
  StudySize size = StudySize::Small;
  sim::SimulationOptions sim;  // backend, threads, device
  std::filesystem::path out_dir = "study";
  std::vector<std::string> only;  // studies to run (empty: all of study_names())
  std::uint64_t seed = 1;
  bool verbose = true;       // progress on stderr
  std::string command_line;  // recorded in study.json
};

// The studies, in the order they run: timestep, precision, resolution, reorder, effects.
const std::vector<std::string>& study_names();

// Runs the studies and writes DIR/study.json and DIR/<study>.csv (each under a temporary name,
// renamed when complete). Returns the JSON written.
nlohmann::ordered_json run_study(const StudyOptions& o);

// The `study` subcommand of rockflow: its options live here; run() executes it after parsing with
// the backend options main() built.
struct StudyCommand {
  CLI::App* app = nullptr;
  std::function<int(const sim::SimulationOptions&)> run;
};
StudyCommand add_study_command(CLI::App& rockflow, std::string& backend, int& threads);

}  // namespace mesorock::pipeline
