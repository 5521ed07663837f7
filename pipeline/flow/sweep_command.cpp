// `rockflow sweep SCENE --forces ...`: the permeability sweep (pipeline/flow/sweep.h).
#include <iostream>
#include <stdexcept>

#include "mesorock/errors.h"
#include "mesorock/output_lock.h"
#include "pipeline/cli_checks.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "pipeline/flow/interrupt.h"
#include "pipeline/flow/sweep.h"
#include "pipeline/scene.h"

namespace mesorock::pipeline {

namespace {

// Every item, empty ones too: "0.01,,0.02" is a typo, not two forces.
std::vector<std::string> split_items(const std::string& text) {
  std::vector<std::string> out;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    out.push_back(text.substr(start, comma - start));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

}  // namespace

std::vector<double> parse_number_list(const std::string& text, const std::string& what) {
  std::vector<double> values;
  for (const auto& f : split_items(text)) {
    if (f.find_first_not_of(" \t") == std::string::npos)
      throw ConfigError(what + " '" + text + "': an empty item (comma-separated numbers)");
    try {
      size_t used = 0;
      values.push_back(std::stod(f, &used));
      if (used != f.size()) throw std::invalid_argument(f);
    } catch (const std::exception&) {
      throw ConfigError(what + ": '" + f + "' is not a number");
    }
  }
  return values;
}

namespace {

std::vector<double> parse_forces(const std::string& text) {
  return parse_number_list(text, "sweep: --forces");
}

void print_result(const nlohmann::json& summary, const std::string& out) {
  const auto& darcy = summary["fits"]["darcy"]["permeability"];
  std::cout << "permeability (Darcy fit): " << darcy["rc2"].get<double>() << " +- "
            << darcy["rc2_error"].get<double>() << " rc^2";
  if (darcy.contains("mD"))
    std::cout << " = " << darcy["nm2"].get<double>() << " nm^2 = " << darcy["mD"].get<double>()
              << " mD";
  std::cout << "\n";
  if (summary["fits"].contains("quadratic")) {
    const auto& q = summary["fits"]["quadratic"];
    std::cout << "deviation from Darcy at the largest gradient: "
              << 100 * q["deviation_at_largest_gradient"].get<double>() << " +- "
              << 100 * q["deviation_error"].get<double>() << " %"
              << (q["deviation_significant"].get<bool>() ? " (significant)" : "") << "\n";
  }
  std::cout << "outputs: " << out << "/sweep.csv, sweep.json, sweep.png\n";
}

}  // namespace

FlowCommand add_sweep_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    SweepCommand sc;
    std::string scene, out = "out", forces, viscosity_cache, types;
    double fluid_density = 0, viscosity = 0, viscosity_error = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sweep = rockflow.add_subcommand(
      "sweep", "permeability sweep: flow rate vs driving force, Darcy and Forchheimer fits");
  SweepCommand& sc = a->sc;
  sweep->add_option("scene", a->scene, "the prepared sample (scene file)")->required();
  sweep->add_option("--out", a->out, "output folder")->capture_default_str();
  sweep
      ->add_option("--forces", a->forces,
                   "body forces per fluid particle, comma-separated (reduced units)")
      ->required();
  sweep->add_option("--axis", sc.axis, "flow axis x|y|z (default: the scene's body force)");
  sweep->add_option("--types", a->types,
                    "driven types, comma-separated (default: the scene's body-force types)");
  sweep
      ->add_option("--fluid-density", a->fluid_density,
                   "the fluid's number density n_f (default: the scene's [[init]] density)")
      ->check(positive_value());
  sweep->add_option("--viscosity", a->viscosity, "the fluid's viscosity (skips the calibration)")
      ->check(positive_value());
  sweep->add_option("--viscosity-error", a->viscosity_error, "its standard error")
      ->check(non_negative_value());
  sweep->add_option("--calibration", sc.calibration, "calibration size tiny|small|full")
      ->check(CLI::IsMember({"tiny", "small", "full"}))
      ->capture_default_str();
  sweep->add_option("--viscosity-cache", a->viscosity_cache,
                    "folder of cached calibrations (default: ~/.cache/mesorock/viscosity)");
  CLI::Option* warmup =
      sweep->add_option("--warmup", sc.run.warmup_steps,
                        "steps before blocks start, per point (default: from the sample's median "
                        "pore when rockprep recorded it, at least 2000)");
  sweep->add_option("--block-steps", sc.run.block_steps, "steps per averaging block")
      ->capture_default_str();
  sweep->add_option("--window", sc.run.window, "blocks per half of the steady-state test")
      ->capture_default_str();
  sweep->add_option("--tolerance", sc.run.tolerance, "steady-state tolerance (relative)")
      ->capture_default_str();
  sweep->add_option("--measure-blocks", sc.run.measure_blocks, "blocks measured once steady")
      ->capture_default_str();
  CLI::Option* max_steps = sweep->add_option(
      "--max-steps", sc.run.max_steps,
      "most steps per point (default: 100000, longer by what the pores' warm-up adds)");
  sweep->add_flag("--side-by-side", sc.run.side_by_side,
                  "run every point from the prepared sample at once, not each from the last "
                  "point's state (on the GPU the points overlap: faster for small samples)");
  add_solver_flags(*sweep, a->flags);
  return {sweep, [a, warmup, max_steps](std::shared_ptr<sim::Communicator> world) {
            const sim::SimulationOptions so = solver_options(a->flags, std::move(world));
            const Scene scene = load_scene(a->scene);
            SweepCommand sc = a->sc;
            sc.warmup_from_pores = warmup->count() == 0;
            sc.max_steps_from_warmup = max_steps->count() == 0;
            if (sc.run.side_by_side && so.comm && so.comm->size() > 1)
              throw ConfigError("--side-by-side runs each point on one rank: not under mpirun");
            check_memory_for(
                scene, so,
                sc.run.side_by_side ? static_cast<int>(parse_forces(a->forces).size()) : 1);
            const OutputLock lock(a->out);             // one owner per folder, before any work
            lock.remove_earlier_record("sweep.json");  // a failure must not leave the old one
            exit_on_interrupt("rockflow",
                              "nothing was written to " + a->out +
                                  " (the outputs appear when the sweep completes; a finished "
                                  "viscosity calibration stays cached): run the sweep again");
            sc.out_dir = a->out;
            sc.run.sim = so;
            sc.forces = parse_forces(a->forces);
            if (!a->types.empty()) sc.types = split_items(a->types);
            if (a->fluid_density != 0) sc.fluid_density = a->fluid_density;
            if (a->viscosity != 0) sc.viscosity = a->viscosity;
            if (a->viscosity_error != 0) sc.viscosity_error = a->viscosity_error;
            if (!a->viscosity_cache.empty()) sc.viscosity_cache = a->viscosity_cache;
            print_result(run_sweep_command(scene, sc), a->out);
            return static_cast<int>(kExitOk);
          }};
}

}  // namespace mesorock::pipeline
