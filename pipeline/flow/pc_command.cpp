// `rockflow pc FLOODING/scene.toml --pressures ...`: primary-drainage capillary pressure
// (capillary_pressure.h).
#include <algorithm>
#include <iomanip>
#include <iostream>

#include "mesorock/errors.h"
#include "mesorock/output_lock.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/capillary_pressure.h"
#include "pipeline/flow/commands.h"
#include "pipeline/scene.h"

namespace mesorock::pipeline {

namespace {

void print_result(const nlohmann::json& summary, const std::string& out) {
  std::cout << "primary drainage (P_back = " << summary["back_pressure"].get<double>()
            << "; S_w in the block):\n";
  std::cout << "  branch       Pc applied   S_w                Pc measured          steady\n";
  const auto pm = [](const nlohmann::json& v) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(4) << v["value"].get<double>() << " +- "
      << std::setprecision(4) << v["error"].get<double>();
    return s.str();
  };
  for (const auto& l : summary["levels"])
    std::cout << "  " << std::setw(11) << std::left << l["branch"].get<std::string>() << std::right
              << std::setw(10) << std::fixed << std::setprecision(4) << l["Pc"].get<double>()
              << "   " << std::setw(17) << std::left << pm(l["S_w"]) << "  " << std::setw(19)
              << pm(l["Pc_measured"]) << "  " << std::right
              << (l["steady"].get<bool>() ? "yes" : "NO") << "\n";
  const auto& e = summary["entry"];
  if (e["found"].get<bool>())
    std::cout << "N enters the block between Pc = " << e["lower"].get<double>() << " and "
              << e["upper"].get<double>() << "\n";
  else
    std::cout << "N did not enter the block (S_w >= 0.95 at every level)\n";
  std::size_t behind = 0, unsteady = 0;
  for (const auto& l : summary["levels"]) {
    behind = std::max(behind, l["fluid_behind_slabs"].get<std::size_t>());
    unsteady += l["steady"].get<bool>() ? 0 : 1;
  }
  if (behind > 0)
    std::cout << "warning: up to " << behind
              << " fluid particles got behind a slab, which then does not apply its pressure "
                 "(rockprep run's default lattice slabs 2 rc thick hold the fluid)\n";
  if (unsteady > 0)
    std::cout << "warning: " << unsteady
              << " level(s) not steady within --max-level-steps (measured on their last "
                 "blocks)\n";
  if (summary["inlet_used_up"].get<bool>())
    std::cout << "stopped early: the N reservoir is used up (rockprep run --inlet-rc longer)\n";
  if (summary["room_used_up"].get<bool>())
    std::cout << "stopped early: no room left behind the back slab\n";
  std::cout << "outputs: " << out << "/pc.csv, pc.json, pc.png\n";
}

}  // namespace

FlowCommand add_pc_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    PcCommand pc;
    std::string scene, out = "out", pressures, imbibition;
    double nonwetting_wall_A = 0;
    bool no_states = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = rockflow.add_subcommand(
      "pc", "primary drainage capillary pressure Pc(S_w) of a flooding set-up, stepped pressure");
  PcCommand& pc = a->pc;
  DrainageOptions& run = pc.run;
  sub->add_option("scene", a->scene,
                  "the flooding set-up (scene file of rockprep run --layout flooding)")
      ->required();
  sub->add_option("--out", a->out, "output folder")->capture_default_str();
  sub->add_option("--pressures", a->pressures,
                  "capillary pressures P_push - P_back of the levels, rising, comma-separated "
                  "(kBT / rc^3)")
      ->required();
  sub->add_option("--imbibition", a->imbibition,
                  "after the drainage, capillary pressures of imbibition levels, falling, "
                  "comma-separated (the second branch of the hysteresis loop)");
  sub->add_option("--wetting", pc.wetting, "the wetting (defending) fluid's type")
      ->capture_default_str();
  sub->add_option("--nonwetting", pc.nonwetting, "the non-wetting (invading) fluid's type")
      ->capture_default_str();
  sub->add_option("--cross-A", pc.cross_A,
                  "A between the two liquids (less attractive than the fluid's own)")
      ->capture_default_str();
  sub->add_option("--nonwetting-wall-A", a->nonwetting_wall_A,
                  "A between the non-wetting liquid and the walls (default: the wetting "
                  "fluid's, neutral wetting; docs/calibration/contact_angle_WN_A_SN.csv)");
  sub->add_option("--ramp-steps", run.ramp_steps,
                  "steps over which the pressures move from one level to the next")
      ->capture_default_str();
  sub->add_option("--ramp-parts", run.ramp_parts, "equal pressure steps of each ramp")
      ->capture_default_str();
  sub->add_option("--block-steps", run.block_steps, "steps per averaging block")
      ->capture_default_str();
  sub->add_option("--sample-every", run.sample_every, "steps between samples")
      ->capture_default_str();
  sub->add_option("--window", run.window, "blocks per half of the steady-state test")
      ->capture_default_str();
  sub->add_option("--tolerance", run.tolerance, "steady-state tolerance on S_w (relative)")
      ->capture_default_str();
  sub->add_option("--measure-blocks", run.measure_blocks, "blocks measured once steady")
      ->capture_default_str();
  sub->add_option("--max-level-steps", run.max_level_steps, "most steps per level")
      ->capture_default_str();
  sub->add_flag("--no-states", a->no_states, "do not write states/ (the phases at each level)");
  add_solver_flags(*sub, a->flags);
  return {sub, [a, sub](std::shared_ptr<sim::Communicator> world) {
            const sim::SimulationOptions so = solver_options(a->flags, std::move(world));
            if (so.comm && so.comm->size() > 1)
              throw ConfigError("pc runs on one rank: not under mpirun");
            const Scene scene = load_scene(a->scene);
            check_memory_for(scene, so);
            PcCommand pc = a->pc;
            pc.run.pressures = parse_number_list(a->pressures, "pc: --pressures");
            if (!a->imbibition.empty())
              pc.imbibition = parse_number_list(a->imbibition, "pc: --imbibition");
            pc.run.sim = so;
            const OutputLock lock(a->out);          // one owner per folder, before any work
            lock.remove_earlier_record("pc.json");  // a failure must not leave the old one
            pc.out_dir = a->out;
            pc.write_states = !a->no_states;
            if (sub->count("--nonwetting-wall-A")) pc.nonwetting_wall_A = a->nonwetting_wall_A;
            print_result(run_pc_command(scene, pc), a->out);
            return static_cast<int>(kExitOk);
          }};
}

}  // namespace mesorock::pipeline
