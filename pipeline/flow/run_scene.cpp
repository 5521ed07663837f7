#include "pipeline/flow/run_scene.h"

#include <chrono>

#include "mesorock/errors.h"
#include "pipeline/flow/checkpoint_io.h"
#include "pipeline/flow/run_outputs.h"
#include "pipeline/flow/runner.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

void run_scene(const Scene& scene, const RunOptions& o) {
  const auto started = std::chrono::steady_clock::now();
  const fs::path checkpoint_file = checkpoint_path(o.out_dir);
  std::optional<ResumePoint> resume;
  std::unique_ptr<sim::Simulation> sim;
  if (o.resume) {
    if (scene.stages.empty()) throw ConfigError(scene.path.string() + ": run: no stages");
    resume = read_run_checkpoint(checkpoint_file, scene);
    try {
      sim = sim::resume_simulation(scene.model, scene.box, resume->state, o.sim);
    } catch (const ConfigError& e) {  // "particle 2118 has type 65536 ..." named no file
      throw ConfigError(checkpoint_file.string() + " (of " + scene.path.string() +
                        "): " + e.what());
    }
  } else {
    if (fs::exists(checkpoint_file))
      throw ConfigError(checkpoint_file.string() +
                        ": an interrupted run's checkpoint is here: continue it with --resume, or "
                        "remove it (or choose another --out) to start afresh");
    sim::ParticleSet initial = build_initial_particles(scene);
    if (scene.stages.empty()) throw ConfigError(scene.path.string() + ": run: no stages");
    try {
      sim = sim::make_simulation(scene.model, scene.box, initial, scene.stages.front().dt, o.sim);
    } catch (const ConfigError& e) {  // "particle 3 ... starts inside a solid voxel" named no file
      throw ConfigError(scene.path.string() + ": " + e.what());
    }
  }
  // Every output of the run is staged by the runner: the CSV series grow under temporary names,
  // the end-of-run files are written under temporary names, and all take their final names
  // together once everything is written (summary.json last). A failure anywhere leaves none of
  // them behind; a checkpoint already written stays.
  Runner runner(scene, *sim, o, resume ? &*resume : nullptr, started);
  for (auto& output : make_scene_outputs(runner.context())) runner.add(std::move(output));
  runner.run();
  runner.finish();
}

}  // namespace mesorock::pipeline
