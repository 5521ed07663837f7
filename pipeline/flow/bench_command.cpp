// `rockflow bench`: million particle-steps per second of a bulk, porous or rock case.
#include <algorithm>
#include <iostream>

#include "pipeline/exit_codes.h"
#include "pipeline/flow/bench.h"
#include "pipeline/flow/commands.h"

namespace mesorock::pipeline {

namespace {

// A CUDA switch that exists only to measure what it saves: "--name on|off", default on.
void add_measuring_switch(CLI::App* app, const std::string& name, std::string& value,
                          const std::string& help) {
  app->add_option(name, value, help)->check(CLI::IsMember({"on", "off"}))->capture_default_str();
}

}  // namespace

FlowCommand add_bench_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    BenchOptions bo;
    std::string precision = "single";
    bool json = false, compare_cpu = false, profile = false, decompose = false;
    int reorder_every = 1, lanes = 0;
    double skin = 0;
    std::string frozen_part = "on", buried_part = "on", graphs = "on", penetration_mask = "on",
                frozen_density_list = "on";
    int cells_per_rc = sim::SimulationOptions{}.cells_per_cutoff;
  };
  auto a = std::make_shared<Args>();
  CLI::App* bench = rockflow.add_subcommand("bench", "measure million particle-steps per second");
  bench->add_option("--case", a->bo.case_name, "bulk, porous or rock (needs --solid)")
      ->check(CLI::IsMember({"bulk", "porous", "rock"}))
      ->capture_default_str();
  bench->add_option("--solid", a->bo.solid_file,
                    "rock: a segmented image (rockprep's solid.h5), extended by mirror copies "
                    "to --particles (for timing runs of up to about 300 steps: the scene can run "
                    "away over longer runs, docs/benchmarks.md)");
  bench->add_option("--particles", a->bo.particles, "particle count")->capture_default_str();
  bench->add_option("--steps", a->bo.steps, "timed steps")->capture_default_str();
  add_solver_flags(*bench, a->flags);
  bench->add_option("--precision", a->precision, "single or double")
      ->check(CLI::IsMember({"single", "double"}));
  bench->add_flag("--compare-cpu", a->compare_cpu, "also run the CPU backend on the same case");
  bench->add_flag("--json", a->json, "print JSON");
  bench
      ->add_option("--watchdog", a->flags.watchdog,
                   "on, off, or compare: time both in alternating rounds and print its cost")
      ->check(CLI::IsMember({"on", "off", "compare"}))
      ->capture_default_str();
  bench
      ->add_option("--reorder-every", a->reorder_every,
                   "steps between cell sorts (needs --skin; default 1: every step)")
      ->check(CLI::Range(1, 1000));
  bench->add_option("--skin", a->skin, "cell-list skin in rc for --reorder-every")
      ->check(CLI::Range(0.0, 1.0));
  bench->add_flag("--decompose", a->decompose,
                  "run the decomposed (MPI) solver even on one rank, to measure its cost");
  add_measuring_switch(bench, "--frozen-part", a->frozen_part,
                       "store frozen particles apart, sorted once, with their sums over frozen "
                       "neighbours kept (on), or mixed with the mobile ones (off: only to measure "
                       "what it saves)");
  add_measuring_switch(bench, "--buried-part", a->buried_part,
                       "keep frozen particles farther than rc from every pore voxel out of the "
                       "steps (on; needs the frozen part and a solid grid with its bounce), or "
                       "not (off: only to measure what it saves)");
  add_measuring_switch(bench, "--penetration-mask", a->penetration_mask,
                       "CUDA, wall model: compute phi before the sort only where the frozen "
                       "walls may put it past phi_c (on), or for every mobile particle (off: only "
                       "to measure what it saves; the results are the same)");
  add_measuring_switch(bench, "--frozen-density-list", a->frozen_density_list,
                       "CUDA, with the buried part: sum the density of only the frozen particles "
                       "within rd of a pore voxel (on), or of every frozen one a step visits (off: "
                       "only to measure what it saves; the results are the same)");
  add_measuring_switch(bench, "--graphs", a->graphs,
                       "CUDA: replay runs of steps captured as CUDA graphs (on) or launch every "
                       "kernel (off: only to measure what graphs save; the results are the same)");
  bench
      ->add_option("--ensemble", a->bo.ensemble,
                   "run this many copies of the case side by side (seeds seed, seed+1, ...); "
                   "MPS/s counts them all")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  bench
      ->add_option("--lanes", a->lanes,
                   "CUDA: threads per particle in the density and force passes (1, 2, 4, 8; 0: "
                   "by the particle count)")
      ->check(CLI::IsMember({0, 1, 2, 4, 8}))
      ->capture_default_str();
  bench->add_flag("--profile", a->profile,
                  "CUDA: also time each pass (kick, sort, density, force)");
  bench->add_option("--cells-per-rc", a->cells_per_rc, "cell-list cells per cutoff (1-4)")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  return {
      bench, [a](std::shared_ptr<sim::Communicator> world) {
        BenchOptions bo = a->bo;
        bo.precision = a->precision == "double" ? sim::Precision::Double : sim::Precision::Single;
        bo.sim = solver_options(a->flags, std::move(world));
        const bool root = !bo.sim.comm || bo.sim.comm->rank() == 0;  // rank 0 alone prints
        bo.sim.profile = a->profile;
        bo.sim.frozen_part = a->frozen_part == "on";
        bo.sim.buried_part = a->buried_part == "on";
        bo.sim.graphs = a->graphs == "on";
        bo.sim.penetration_mask = a->penetration_mask == "on";
        bo.sim.frozen_density_list = a->frozen_density_list == "on";
        bo.sim.lanes_per_particle = a->lanes;
        bo.sim.cells_per_cutoff = a->cells_per_rc;
        bo.sim.reorder_every = a->reorder_every;
        bo.sim.skin = a->skin;
        if (a->decompose) {
          bo.sim.decomposition.force = true;
          if (!bo.sim.comm) bo.sim.comm = sim::make_self_communicator();
        }
        bo.compare_watchdog = a->flags.watchdog == "compare";
        const BenchResult r = run_bench(bo);
        BenchResult cpu;
        if (a->compare_cpu) {
          BenchOptions co = bo;
          co.sim.backend = sim::BackendKind::CPU;
          co.sim.profile = false;
          co.steps = std::max<std::uint64_t>(5, bo.steps / 20);
          cpu = run_bench(co);
        }
        if (!root) return static_cast<int>(kExitOk);
        if (a->json) {
          std::string out = format_bench_json(r);
          if (a->compare_cpu) {
            out.pop_back();
            out += ",\"cpu\":" + format_bench_json(cpu) +
                   ",\"speedup_vs_cpu\":" + std::to_string(r.mps / cpu.mps) + "}";
          }
          std::cout << out << "\n";
        } else {
          std::cout << format_bench_text(r);
          if (a->compare_cpu)
            std::cout << format_bench_text(cpu) << "speed-up vs CPU: " << r.mps / cpu.mps << "x\n";
        }
        return static_cast<int>(kExitOk);
      }};
}

}  // namespace mesorock::pipeline
