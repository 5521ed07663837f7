#pragma once
// Checkpoints of `rockflow run` (docs/scene.md, "Checkpoints and resume"): the solver state
// (sim/checkpoint.h) plus the run-level record the outputs need to continue seamlessly: the rows
// of thermo.csv and the other growing CSV files so far, the time, the averaged series and the
// binned accumulators. One file, OUT/checkpoint.h5, replaced atomically at every checkpoint.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "pipeline/scene.h"
#include "sim/checkpoint.h"
#include "sim/observables.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

struct RunRecord {
  std::map<std::string, std::string> texts;            // e.g. "thermo.csv": its text so far
  std::map<std::string, std::vector<double>> numbers;  // e.g. "time", "series.pressure"

  void put_binned(const std::string& name, const sim::BinnedAverage& average);
  // Restores an average saved under `name` into one of the same grid (IoError when absent or of
  // another size).
  void get_binned(const std::string& name, sim::BinnedAverage& average) const;
  // A saved number or series; IoError naming the entry when absent.
  double number(const std::string& name) const;
  const std::vector<double>& series(const std::string& name) const;
  const std::string& text(const std::string& name) const;
  bool has_text(const std::string& name) const { return texts.count(name) > 0; }

  std::string file;  // the checkpoint it came from (for messages)
  // The files the scene names with their checksums (named_files_record), saved with the state.
  std::string input_files;
};

// "HEX PATH" a line for each file the scene names (Scene::named_files), HEX its contents'
// checksum (mesorock/checksum.h): a solid grid or particle file replaced between an interrupt
// and the resume is found although the scene's text is the same.
std::string named_files_record(const Scene& scene);

inline std::filesystem::path checkpoint_path(const std::filesystem::path& out_dir) {
  return out_dir / "checkpoint.h5";
}

// Writes a state of the run (sim::Simulation::state(), collective on several ranks: call it on
// every rank, write on rank 0) and the record to `path` atomically; provenance records the scene
// (path and text), the version and `parameters_json`.
void write_run_checkpoint(const std::filesystem::path& path, sim::SimulationState state,
                          const Scene& scene, const std::string& parameters_json,
                          const RunRecord& record);

struct ResumePoint {
  sim::SimulationState state;
  RunRecord record;
};

// Reads a checkpoint of `scene`. ConfigError when it was written for another scene text (the
// file names the scene it belongs to), when a file the scene names has changed since, or when its
// step lies past the scene's stages or disagrees with its saved thermo rows; IoError when it is
// missing or damaged (a checksum that does not match names the dataset).
ResumePoint read_run_checkpoint(const std::filesystem::path& path, const Scene& scene);

}  // namespace mesorock::pipeline
