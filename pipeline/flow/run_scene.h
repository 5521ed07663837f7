#pragma once
#include <filesystem>

#include "pipeline/scene.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

struct RunOptions {
  std::filesystem::path out_dir = "out";
  sim::SimulationOptions sim;
  bool progress = true;
};

// Runs every stage of a scene. Writes into out_dir: thermo.csv (step, time, T, p, momentum),
// final.h5 + final.xmf (particles), summary.json (version, commit, backend, counts, wall time,
// MPS/s, the scene text). Files are written under temporary names and renamed when complete.
void run_scene(const Scene& scene, const RunOptions& options);

}  // namespace mesorock::pipeline
