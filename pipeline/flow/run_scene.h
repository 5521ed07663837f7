#pragma once
#include <cstdint>
#include <filesystem>
#include <optional>

#include "pipeline/scene.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

struct RunOptions {
  std::filesystem::path out_dir = "out";
  sim::SimulationOptions sim;
  bool progress = true;
  // Continue from out_dir/checkpoint.h5 (written by a run of the same scene).
  bool resume = false;
  // Checkpoint every N steps; unset: the scene's [output] checkpoint_every.
  std::optional<std::uint64_t> checkpoint_every;
};

// Runs every stage of a scene. Writes into out_dir:
//   thermo.csv            step, time, stage, T, p, stress tensor, momentum (every thermo_every)
//   snapshots/step_N.h5   + .xmf, every snapshot_every steps (when asked)
//   final.h5 + final.xmf  the particles at the end
//   PROFILE.h5 / .csv     time-averaged profiles ([[output.profiles]])
//   fields.h5 + .xmf      time-averaged 3-D fields ([output.fields])
//   summary.json          version, commit, backend, counts, wall time, MPS/s, time averages with
//                         error bars, unit conversions when [units] is given, the scene text
//   checkpoint.h5         every checkpoint_every steps and on Ctrl-C (removed when the run
//                         completes); resume continues it bit for bit (checkpoint_io.h)
// Each file is written under a temporary name and renamed when complete.
void run_scene(const Scene& scene, const RunOptions& options);

}  // namespace mesorock::pipeline
