#pragma once
#include <cstdint>
#include <string>

#include "sim/model.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

struct BenchOptions {
  std::string case_name = "bulk";  // bulk | porous | rock
  std::string solid_file;          // rock: the segmented image (rockprep's solid.h5)
  std::int64_t particles = 200000;
  std::uint64_t steps = 200;
  sim::Precision precision = sim::Precision::Single;
  sim::SimulationOptions sim;
  // Times the same case with the watchdog off and on, in alternating rounds (its cost).
  bool compare_watchdog = false;
  // Independent copies of the case (seeds seed, seed + 1, ...) stepped side by side
  // (sim/ensemble.h); MPS/s counts all of them.
  int ensemble = 1;
};

struct BenchResult {
  std::string case_name, backend, precision, pass_name;
  std::int64_t particles = 0;
  std::uint64_t steps = 0;
  int threads = 0;
  int cells_per_rc = 1;
  int reorder_every = 1;  // steps between cell sorts (with a skin)
  double skin = 0;
  int ranks = 1;            // MPI ranks (mpirun), 1 otherwise
  bool decomposed = false;  // the decomposed solver (sim/domain), even on one rank
  double seconds = 0;
  double mps = 0;  // million particle-steps per second
  // The particles that move (not frozen), and million of their particle-steps per second: the
  // figure to set against a bulk liquid of that many particles.
  std::int64_t mobile_particles = 0;
  double mobile_mps = 0;
  double setup_seconds = 0;
  double device_bytes_per_particle = 0;  // 0 on the CPU
  std::string profile;                   // per-pass GPU times with --profile
  bool watchdog = true;
  // compare_watchdog only: MPS/s with the watchdog off and on, and its cost in % of a step.
  double mps_watchdog_off = 0, mps_watchdog_on = 0, watchdog_cost_percent = 0;
  int ensemble = 1;  // members; particles is per member, mps over all of them
  // The share of the first member's steps that ran through CUDA graphs (0 without).
  double graph_step_fraction = 0;
  std::int64_t buried_particles = 0;  // frozen particles kept out of the steps (CPU)
};

// Builds the case, runs steps/10 (at least 5) warm-up steps, then times `steps` steps.
BenchResult run_bench(const BenchOptions& o);
std::string format_bench_json(const BenchResult& r);
std::string format_bench_text(const BenchResult& r);

}  // namespace mesorock::pipeline
