// `rockflow run SCENE`: a scene file's stages, with outputs, checkpoints and --resume.
#include <optional>

#include "mesorock/output_lock.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "pipeline/flow/interrupt.h"
#include "pipeline/flow/run_scene.h"
#include "pipeline/scene.h"

namespace mesorock::pipeline {

FlowCommand add_run_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    std::string scene, out = "out";
    bool resume = false;
    std::int64_t checkpoint_every = -1;
    bool profile = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* run = rockflow.add_subcommand("run", "run a scene file");
  run->add_option("scene", a->scene, "scene file (TOML, see docs/scene.md)")->required();
  run->add_option("--out", a->out, "output folder")->capture_default_str();
  run->add_option("--backend", a->flags.backend, "cpu or cuda")->capture_default_str();
  add_solver_flags(*run, a->flags, false);
  add_watchdog_flag(*run, a->flags);
  run->add_option("--runaway-displacement", a->flags.runaway_displacement,
                  "watchdog: a particle moving more rc than this in one step is a runaway")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  run->add_flag("--resume", a->resume, "continue from OUT/checkpoint.h5 (same scene)");
  run->add_option("--checkpoint-every", a->checkpoint_every,
                  "write OUT/checkpoint.h5 every N steps (default: the scene's "
                  "[output] checkpoint_every; 0 = none)")
      ->check(CLI::NonNegativeNumber);
  run->add_flag("--profile", a->profile,
                "CUDA: time each pass (kick-drift, sort, density and walls, force, kick) and print "
                "the per-step times at the end (synchronises every step: slower)");
  return {run, [a](std::shared_ptr<sim::Communicator> world) {
            const sim::SimulationOptions so = solver_options(a->flags, std::move(world));
            const Scene scene = load_scene(a->scene);
            check_memory_for(scene, so);  // before any particle: host and (CUDA) device memory
            // One owner per folder (rank 0 writes the files of a decomposed run).
            std::optional<OutputLock> lock;
            if (!so.comm || so.comm->rank() == 0) lock.emplace(a->out);
            RunOptions ro;
            ro.out_dir = a->out;
            ro.sim = so;
            ro.sim.profile = a->profile;
            ro.sim.decomposition = scene.decomposition;
            ro.resume = a->resume;
            if (a->checkpoint_every >= 0)
              ro.checkpoint_every = static_cast<std::uint64_t>(a->checkpoint_every);
            install_interrupt_handlers();  // Ctrl-C: checkpoint, then exit 130
            // Ctrl-C during the solver's set-up stops it between passes (nothing written yet).
            ro.sim.interrupt_check = [] {
              throw_if_interrupted("during set-up, before any step: nothing was written");
            };
            run_scene(scene, ro);
            return static_cast<int>(kExitOk);
          }};
}

}  // namespace mesorock::pipeline
