#pragma once
// Running a stability scene through the library: the scene text is parsed and its particles
// built exactly as `rockflow run` does, then the stages are stepped here with a sample callback,
// so a case can check its numbers during the run (leaks, temperature, momentum).
#include <memory>
#include <string>

#include "pipeline/scene.h"
#include "stability_support.h"

namespace mesorock::stability {

struct SceneRun {
  pipeline::Scene scene;
  ms::ParticleSet initial;
  std::unique_ptr<ms::Simulation> sim;
  std::string failure;  // the watchdog's message, "" when the stages ran through
};

// `as`: the path the scene is parsed as (relative [[init]] files resolve against its folder).
inline SceneRun load_scene_run(const std::string& name,
                               const std::vector<std::pair<std::string, std::string>>& subs,
                               const fs::path& as = {},
                               const ms::SimulationOptions& options = cpu_options()) {
  SceneRun r;
  r.scene = pipeline::parse_scene(scene_text(name, subs), as.empty() ? stability_scene(name) : as);
  r.initial = pipeline::build_initial_particles(r.scene);
  r.sim = ms::make_simulation(r.scene.model, r.scene.box, r.initial, r.scene.stages.front().dt,
                              options);
  return r;
}

// Runs every stage, calling sample(stage index) every `every` steps; stops at the first
// NumericalError and keeps its message.
inline void run_stages(SceneRun& r, std::uint64_t every,
                       const std::function<void(size_t stage)>& sample = {}) {
  for (size_t k = 0; k < r.scene.stages.size(); ++k) {
    const pipeline::StageSpec& stage = r.scene.stages[k];
    r.sim->set_dt(stage.dt);
    r.failure = run_sampled(*r.sim, stage.steps, every, [&] {
      if (sample) sample(k);
    });
    if (!r.failure.empty()) return;
  }
}

}  // namespace mesorock::stability
