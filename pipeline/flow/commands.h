#pragma once
// rockflow's subcommands, one file each (pipeline/flow/*_command.cpp), built the way rockprep's
// are (pipeline/prep/common.h): add_X_command registers the subcommand and its options on the
// app and returns what runs it once the command line is parsed. rockflow_main.cpp lists them.
#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/domain/communicator.h"
#include "sim/simulation.h"
#include "sim/watchdog.h"

namespace mesorock::pipeline {

// The solver options several commands take: --backend, --threads, --watchdog.
struct SolverFlags {
  std::string backend = "cpu";
  int threads = 0;
  std::string watchdog = "on";  // sim/watchdog.h; bench also takes "compare"
  double runaway_displacement = sim::WatchdogOptions{}.runaway_displacement;
};

// Adds --backend (when `backend`) and --threads to `sub`, bound to `flags`.
void add_solver_flags(CLI::App& sub, SolverFlags& flags, bool backend = true);
// Adds --watchdog on|off to `sub`.
void add_watchdog_flag(CLI::App& sub, SolverFlags& flags);

// The solver options the flags ask for (`world`: the MPI ranks under mpirun, else null). With
// `require_device_now`, fails with one line when CUDA is asked for but absent (never a silent
// fall-back to the CPU).
sim::SimulationOptions solver_options(const SolverFlags& flags,
                                      std::shared_ptr<sim::Communicator> world,
                                      bool require_device_now = true);
// Fails with one line when `so` asks for CUDA and none is usable.
void require_device(const sim::SimulationOptions& so);

// "0.1,0.2" -> {0.1, 0.2}; an empty item or a word is a ConfigError naming `what` (e.g.
// "sweep: --forces").
std::vector<double> parse_number_list(const std::string& text, const std::string& what);

struct FlowCommand {
  CLI::App* app = nullptr;
  // Runs the parsed command; returns the exit code (errors are thrown, pipeline/exit_codes.h).
  std::function<int(std::shared_ptr<sim::Communicator> world)> run;
};

FlowCommand add_run_command(CLI::App& rockflow);         // run_command.cpp
FlowCommand add_validate_command(CLI::App& rockflow);    // validate_command.cpp
FlowCommand add_sweep_command(CLI::App& rockflow);       // sweep_command.cpp
FlowCommand add_bench_command(CLI::App& rockflow);       // bench_command.cpp
FlowCommand add_lbm_command(CLI::App& rockflow);         // lbm_command.cpp
FlowCommand add_relperm_command(CLI::App& rockflow);     // relperm_command.cpp
FlowCommand add_pc_command(CLI::App& rockflow);          // pc_command.cpp
FlowCommand add_study_flow_command(CLI::App& rockflow);  // study.cpp's command, with the flags

}  // namespace mesorock::pipeline
