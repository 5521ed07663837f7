// `rockflow relperm SAMPLE --saturations ...`: steady-state relative permeability (relperm.h).
#include <iomanip>
#include <iostream>

#include "mesorock/errors.h"
#include "mesorock/output_lock.h"
#include "pipeline/cli_checks.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "pipeline/flow/relperm.h"
#include "pipeline/scene.h"

namespace mesorock::pipeline {

namespace {

void print_result(const nlohmann::json& summary, const std::string& out) {
  std::cout << "relative permeability (" << summary["placement"].get<std::string>()
            << " placement, g = " << summary["force_g"].get<double>() << "; kr = J_phase / J_1):\n";
  std::cout << "  S_w      kr_W               kr_N               kr_W + kr_N   steady  spans "
               "(W, N)\n";
  for (const auto& r : summary["runs"]) {
    const auto pm = [](const nlohmann::json& v) {
      std::ostringstream s;
      s << std::fixed << std::setprecision(4) << v["value"].get<double>() << " +- "
        << std::setprecision(4) << v["error"].get<double>();
      return s.str();
    };
    std::cout << "  " << std::fixed << std::setprecision(4) << r["saturation"].get<double>()
              << "   " << std::setw(17) << std::left << pm(r["kr_W"]) << "  " << std::setw(17)
              << pm(r["kr_N"]) << "  " << std::setw(12) << std::setprecision(4)
              << r["kr_sum"]["value"].get<double>() << "  " << std::setw(6)
              << (r["steady"].get<bool>() ? "yes" : "NO") << "  "
              << (r["connectivity"]["W"]["spans"].get<bool>() ? "W" : "-")
              << (r["connectivity"]["N"]["spans"].get<bool>() ? "N" : "-") << std::right << "\n";
  }
  const auto& c = summary["checks"];
  std::cout << "checks: kr_W + kr_N < 1: " << (c["kr_sum_below_one"].get<bool>() ? "yes" : "no")
            << "; kr_W rises and kr_N falls with S_w (2 sigma): "
            << (c["kr_w_rises_within_2_sigma"].get<bool>() &&
                        c["kr_n_falls_within_2_sigma"].get<bool>()
                    ? "yes"
                    : "no");
  if (c.contains("end_point"))
    std::cout << "; single-phase k / sweep k_abs = " << std::setprecision(4)
              << c["end_point"]["ratio"]["value"].get<double>() << " +- "
              << c["end_point"]["ratio"]["error"].get<double>();
  std::cout << "\noutputs: " << out << "/relperm.csv, relperm.json, relperm.png\n";
}

}  // namespace

FlowCommand add_relperm_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    RelpermCommand rc;
    std::string scene, out = "out", saturations, placement = "drainage", types, sweep_json;
    double fluid_density = 0, viscosity = 0, viscosity_error = 0, force = 0;
    double nonwetting_wall_A = 0;
    bool no_states = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = rockflow.add_subcommand(
      "relperm", "relative permeability: steady co-flow of two liquids at several saturations");
  RelpermCommand& rc = a->rc;
  SweepOptions& run = rc.sweep.run;
  sub->add_option("scene", a->scene, "the prepared periodic sample (scene file)")->required();
  sub->add_option("--out", a->out, "output folder")->capture_default_str();
  sub->add_option("--saturations", a->saturations,
                  "wetting saturations, comma-separated, each in (0, 1)")
      ->required();
  sub->add_option("--placement", a->placement,
                  "where the phases start: drainage (the non-wetting phase in the largest pores) "
                  "or random")
      ->check(CLI::IsMember({"drainage", "random"}))
      ->capture_default_str();
  sub->add_option("--force", a->force,
                  "body force per particle on both phases (default: the scene's)");
  sub->add_option("--cross-A", rc.cross_A,
                  "A between the two liquids (less attractive than the fluid's own)")
      ->capture_default_str();
  sub->add_option("--nonwetting-wall-A", a->nonwetting_wall_A,
                  "A between the non-wetting liquid and the walls (default: the fluid's, "
                  "neutral wetting)");
  sub->add_option("--sweep", a->sweep_json,
                  "sweep.json of `rockflow sweep` on the same sample: k_abs and the viscosity");
  sub->add_option("--axis", rc.sweep.axis, "flow axis x|y|z (default: the scene's body force)");
  sub->add_option("--types", a->types, "the wetting fluid's type (default: the driven type)");
  sub->add_option("--fluid-density", a->fluid_density,
                  "the fluid's number density (default: the scene's)")
      ->check(positive_value());
  sub->add_option("--viscosity", a->viscosity, "the fluid's viscosity (for k in rc^2 and mD)")
      ->check(positive_value());
  sub->add_option("--viscosity-error", a->viscosity_error, "its standard error")
      ->check(non_negative_value());
  sub->add_option("--warmup", run.warmup_steps,
                  "steps before blocks start, per run (default: from the sample's median pore "
                  "when rockprep recorded it and the viscosity is known, at least 2000)");
  sub->add_option("--block-steps", run.block_steps, "steps per averaging block")
      ->capture_default_str();
  sub->add_option("--window", run.window, "blocks per half of the steady-state test")
      ->capture_default_str();
  sub->add_option("--tolerance", run.tolerance, "steady-state tolerance (relative)")
      ->capture_default_str();
  sub->add_option("--measure-blocks", run.measure_blocks, "blocks measured once steady")
      ->capture_default_str();
  sub->add_option("--max-steps", run.max_steps,
                  "most steps per run (default: 100000, longer by what the pores' warm-up adds)");
  sub->add_flag("--side-by-side", run.side_by_side,
                "run every saturation at once (on the GPU the runs overlap)");
  sub->add_flag("--no-states", a->no_states, "do not write states/ (the phases at the end)");
  add_solver_flags(*sub, a->flags);
  return {sub, [a, sub](std::shared_ptr<sim::Communicator> world) {
            const sim::SimulationOptions so = solver_options(a->flags, std::move(world));
            if (so.comm && so.comm->size() > 1)
              throw ConfigError("relperm runs on one rank: not under mpirun");
            const Scene scene = load_scene(a->scene);
            RelpermCommand rc = a->rc;
            rc.sweep.warmup_from_pores = sub->count("--warmup") == 0;
            rc.sweep.max_steps_from_warmup = sub->count("--max-steps") == 0;
            rc.saturations = parse_number_list(a->saturations, "relperm: --saturations");
            check_memory_for(
                scene, so,
                rc.sweep.run.side_by_side ? static_cast<int>(rc.saturations.size() + 1) : 1);
            const OutputLock lock(a->out);               // one owner per folder, before any work
            lock.remove_earlier_record("relperm.json");  // a failure must not leave the old one
            rc.sweep.out_dir = a->out;
            rc.sweep.run.sim = so;
            rc.placement = parse_placement(a->placement);
            rc.sweep_json = a->sweep_json;
            rc.write_states = !a->no_states;
            if (!a->types.empty()) rc.sweep.types = {a->types};
            if (sub->count("--force")) rc.force = a->force;
            if (sub->count("--nonwetting-wall-A")) rc.nonwetting_wall_A = a->nonwetting_wall_A;
            if (a->fluid_density != 0) rc.sweep.fluid_density = a->fluid_density;
            if (a->viscosity != 0) rc.sweep.viscosity = a->viscosity;
            if (a->viscosity_error != 0) rc.sweep.viscosity_error = a->viscosity_error;
            print_result(run_relperm_command(scene, rc), a->out);
            return static_cast<int>(kExitOk);
          }};
}

}  // namespace mesorock::pipeline
