#include "pipeline/flow/bench.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/flow/systems.h"
#include "sim/domain/communicator.h"
#include "sim/ensemble.h"
#include "sim/memory_budget.h"

namespace mesorock::pipeline {

namespace {

using Clock = std::chrono::steady_clock;

// The watchdog's cost: the same system with the watchdog off and on, each warmed up, then timed
// in alternating rounds (off-on, on-off, ...) so that a drift of the machine's speed hits both
// alike. Every round ends with the same synchronising read (the temperature) in both.
void time_watchdog_rounds(const BenchOptions& o, const BuiltSystem& s, BenchResult& r) {
  constexpr int kRounds = 10;
  sim::SimulationOptions opt[2] = {o.sim, o.sim};
  opt[0].profile = opt[1].profile = false;
  opt[0].watchdog.enabled = false;
  opt[1].watchdog.enabled = true;
  std::unique_ptr<sim::Simulation> sims[2];
  const std::uint64_t warm = std::max<std::uint64_t>(5, o.steps / 10);
  const std::uint64_t per_round = std::max<std::uint64_t>(1, o.steps / kRounds);
  for (int k = 0; k < 2; ++k) {
    sims[k] = sim::make_simulation(s.model, s.box, s.particles, 0.01, opt[k]);
    sims[k]->run(warm);
    (void)sims[k]->kinetic_temperature();
  }
  double seconds[2] = {0, 0};
  for (int round = 0; round < kRounds; ++round)
    for (int q = 0; q < 2; ++q) {
      const int k = round % 2 == 0 ? q : 1 - q;
      const auto t0 = Clock::now();
      sims[k]->run(per_round);
      const double T = sims[k]->kinetic_temperature();
      seconds[k] += std::chrono::duration<double>(Clock::now() - t0).count();
      if (!std::isfinite(T)) throw NumericalError("bench: temperature is not finite after the run");
    }
  const double work =
      static_cast<double>(sims[1]->size()) * static_cast<double>(per_round) * kRounds / 1e6;
  r.mps_watchdog_off = work / seconds[0];
  r.mps_watchdog_on = work / seconds[1];
  r.watchdog_cost_percent = 100.0 * (seconds[1] - seconds[0]) / seconds[0];
  r.steps = per_round * kRounds;
  r.seconds = seconds[1];
  r.mps = r.mps_watchdog_on;
  r.backend = sims[1]->backend_name();
  r.pass_name = sims[1]->pass_name();
  r.device_bytes_per_particle =
      static_cast<double>(sims[1]->device_bytes()) / static_cast<double>(sims[1]->size());
}

// Refuses, before the case is built, a particle count beyond one run (2^31 - 1) or beyond the
// memory available (sim/memory_budget.h); --particles 2e9 used to grow until the kernel killed it.
// Both cases fill a box at about 6.9 particles per rc^3 (one cell of rc per 6.9 particles); the
// watchdog comparison holds two simulations.
void check_bench_memory(const BenchOptions& o) {
  const double n = static_cast<double>(o.particles);
  if (n > 2147483647.0)
    throw LimitError("--particles " + std::to_string(o.particles) +
                     ": more than the limit of 2147483647 for one run (it would need about " +
                     sim::bytes_text(n * sim::host_bytes_per_particle(o.precision)) +
                     " of host memory)");
  const double cpc = std::max(1, o.sim.cells_per_cutoff);
  const double cells = n / 6.9 * cpc * cpc * cpc;
  const double sims = o.compare_watchdog ? 2 : std::max(1, o.ensemble);
  auto refuse_if_short = [&](double per_particle, double per_cell, const sim::MemoryAvailable& have,
                             const char* what) {
    const std::string why =
        sim::memory_shortfall(sims * (n * per_particle + cells * per_cell), have, what);
    if (!why.empty())
      throw LimitError("--particles " + std::to_string(o.particles) + " (" +
                       std::to_string(static_cast<int>(per_particle)) + " bytes each): the run " +
                       why);
  };
  refuse_if_short(sim::host_bytes_per_particle(o.precision), sim::kHostBytesPerCell,
                  sim::host_memory_available(), "host");
  if (o.sim.backend == sim::BackendKind::CUDA)
    refuse_if_short(sim::device_bytes_per_particle(o.precision), sim::kDeviceBytesPerCell,
                    sim::device_memory_available(o.sim.device), "device");
}

}  // namespace

BenchResult run_bench(const BenchOptions& o) {
  if (o.particles < 1000) throw ConfigError("--particles must be at least 1000");
  if (o.steps < 1) throw ConfigError("--steps must be at least 1");
  if (o.ensemble > 1 &&
      (o.compare_watchdog || o.sim.decomposition.force || (o.sim.comm && o.sim.comm->size() > 1)))
    throw ConfigError(
        "--ensemble runs single-rank systems side by side: not with --watchdog "
        "compare, --decompose or mpirun");
  check_bench_memory(o);
  const auto t0 = Clock::now();
  BuiltSystem s;
  if (o.case_name == "bulk") {
    // Homogeneous mDPD liquid, A = -40, B = 25, rd = 0.75, gamma = 4.5, rho = 6.9.
    const double L = std::cbrt(static_cast<double>(o.particles) / 6.9);
    const double box[3] = {L, L, L};
    s = make_bulk_mdpd(-40, 25, 0.75, 4.5, 6.9, box, 7, sim::DensityKernelKind::Warren);
  } else if (o.case_name == "porous") {
    // About 1916 particles per 16 x 2 x 16 cell; N x N cells.
    const int n = std::max(1, static_cast<int>(std::lround(std::sqrt(o.particles / 1916.0))));
    s = make_porous_benchmark(n, n, 7);
  } else if (o.case_name == "rock") {
    if (o.solid_file.empty())
      throw ConfigError("--case rock needs --solid FILE (a segmented image: rockprep's solid.h5)");
    try {
      s = make_rock_benchmark(sim::read_solid_file(o.solid_file), o.particles, 7);
    } catch (const ConfigError& e) {  // "the rock image holds no pore voxels" named no file
      throw ConfigError(o.solid_file + ": " + e.what());
    }
  } else {
    throw ConfigError("--case must be bulk, porous or rock (got " + o.case_name + ")");
  }
  s.model.precision = o.precision;
  if (o.compare_watchdog) {
    BenchResult r;
    r.case_name = o.case_name;
    r.backend = sim::to_string(o.sim.backend);
    r.precision = sim::to_string(o.precision);
    r.particles = static_cast<std::int64_t>(s.particles.size());
    r.cells_per_rc = o.sim.cells_per_cutoff;
    r.threads = o.sim.backend == sim::BackendKind::CPU
                    ? (o.sim.threads > 0 ? o.sim.threads : omp_get_max_threads())
                    : 0;
    time_watchdog_rounds(o, s, r);
    r.setup_seconds = std::chrono::duration<double>(Clock::now() - t0).count() - r.seconds;
    return r;
  }
  const int members = std::max(1, o.ensemble);
  sim::SimulationOptions timed =
      sim::ensemble_member_options(o.sim, members, static_cast<double>(s.particles.size()));
  timed.profile = false;  // the timed run never synchronises per step
  // Member k: the case with seed + k. One member runs on this thread alone.
  std::vector<std::unique_ptr<sim::Simulation>> sims(static_cast<size_t>(members));
  sim::run_ensemble(members, [&](int k) {
    sim::Model model = s.model;
    model.seed += static_cast<std::uint64_t>(k);
    auto sim = sim::make_simulation(model, s.box, s.particles, 0.01, timed);
    if (s.relax_steps > 0) {
      sim->set_dt(s.relax_dt);
      sim->run(s.relax_steps);
      sim->set_dt(0.01);
    }
    sim->run(std::max<std::uint64_t>(5, o.steps / 10));
    (void)sim->kinetic_temperature();  // forces completion of queued device work
    sims[static_cast<size_t>(k)] = std::move(sim);
  });
  std::vector<double> temperatures(static_cast<size_t>(members));
  const auto t1 = Clock::now();
  sim::run_ensemble(members, [&](int k) {
    sims[static_cast<size_t>(k)]->run(o.steps);
    // Synchronises, and checks the run stayed sane.
    temperatures[static_cast<size_t>(k)] = sims[static_cast<size_t>(k)]->kinetic_temperature();
  });
  const auto t2 = Clock::now();
  for (double T : temperatures)
    if (!std::isfinite(T)) throw NumericalError("bench: temperature is not finite after the run");
  std::unique_ptr<sim::Simulation>& sim = sims[0];
  BenchResult r;
  r.ensemble = members;
  r.graph_step_fraction = static_cast<double>(sim->graph_steps()) /
                          static_cast<double>(std::max<std::uint64_t>(1, sim->step()));
  r.buried_particles = static_cast<std::int64_t>(sim->buried_particles());
  r.case_name = o.case_name;
  r.backend = sim->backend_name();
  r.precision = sim::to_string(o.precision);
  r.pass_name = sim->pass_name();
  r.particles = static_cast<std::int64_t>(sim->size());
  r.steps = o.steps;
  r.watchdog = o.sim.watchdog.enabled;
  r.cells_per_rc = o.sim.cells_per_cutoff;
  r.ranks = sim->ranks();
  r.reorder_every = o.sim.reorder_every;
  r.skin = o.sim.skin;
  r.decomposed = o.sim.comm && (o.sim.comm->size() > 1 || o.sim.decomposition.force);
  r.threads = timed.backend == sim::BackendKind::CPU
                  ? (timed.threads > 0 ? timed.threads : omp_get_max_threads())
                  : 0;
  r.setup_seconds = std::chrono::duration<double>(t1 - t0).count();
  // The final temperature read copies velocities back: a small, honest part of the timing.
  r.seconds = std::chrono::duration<double>(t2 - t1).count();
  r.mps =
      static_cast<double>(r.particles) * members * static_cast<double>(r.steps) / r.seconds / 1e6;
  const std::uint32_t frozen = s.model.frozen_mask();
  r.mobile_particles = std::count_if(s.particles.type.begin(), s.particles.type.end(),
                                     [&](std::int32_t t) { return !((frozen >> t) & 1u); });
  r.mobile_mps = r.mps * static_cast<double>(r.mobile_particles) / static_cast<double>(r.particles);
  r.device_bytes_per_particle =
      static_cast<double>(sim->device_bytes()) / static_cast<double>(r.particles);
  if (o.sim.profile) {
    // A separate, synchronising run for the per-pass breakdown.
    sims.clear();
    auto profiled = sim::make_simulation(s.model, s.box, s.particles, 0.01, o.sim);
    profiled->run(std::max<std::uint64_t>(5, o.steps / 4));
    r.profile = profiled->profile_report();
  }
  return r;
}

std::string format_bench_json(const BenchResult& r) {
  nlohmann::json j = {{"case", r.case_name},
                      {"backend", r.backend},
                      {"precision", r.precision},
                      {"pass", r.pass_name},
                      {"particles", r.particles},
                      {"steps", r.steps},
                      {"threads", r.threads},
                      {"seconds", r.seconds},
                      {"mps", r.mps},
                      {"mobile_particles", r.mobile_particles},
                      {"mobile_mps", r.mobile_mps},
                      {"setup_seconds", r.setup_seconds},
                      {"gpu_bytes_per_particle", r.device_bytes_per_particle},
                      {"cells_per_rc", r.cells_per_rc},
                      {"reorder_every", r.reorder_every},
                      {"skin", r.skin},
                      {"ranks", r.ranks},
                      {"decomposed", r.decomposed},
                      {"ensemble", r.ensemble},
                      {"graph_step_fraction", r.graph_step_fraction},
                      {"buried_particles", r.buried_particles}};
  if (!r.profile.empty()) j["profile"] = r.profile;
  if (r.mps_watchdog_off > 0) {
    j["mps_watchdog_off"] = r.mps_watchdog_off;
    j["mps_watchdog_on"] = r.mps_watchdog_on;
    j["watchdog_cost_percent"] = r.watchdog_cost_percent;
  } else {
    j["watchdog"] = r.watchdog;
  }
  return j.dump();
}

std::string format_bench_text(const BenchResult& r) {
  std::ostringstream s;
  s << std::setprecision(4) << "bench " << r.case_name << ": ";
  if (r.ensemble > 1) s << r.ensemble << " systems side by side, each of ";
  s << r.particles << " particles x " << r.steps << " steps on " << r.backend;
  if (r.threads > 0) s << " (" << r.threads << (r.ensemble > 1 ? " threads each)" : " threads)");
  if (r.decomposed) s << ", decomposed over " << r.ranks << " rank(s)";
  if (r.reorder_every > 1)
    s << ", sorted every " << r.reorder_every << " steps (skin " << r.skin << ")";
  s << ", " << r.precision << " precision, " << r.cells_per_rc << " cells per rc: " << r.seconds
    << " s, " << r.mps << " MPS/s";
  if (r.mobile_particles > 0 && r.mobile_particles < r.particles)
    s << " (" << r.mobile_mps << " million mobile-particle-steps/s, " << r.mobile_particles
      << " mobile"
      << (r.buried_particles > 0 ? ", " + std::to_string(r.buried_particles) + " buried"
                                 : std::string())
      << ")";
  if (r.device_bytes_per_particle > 0)
    s << ", " << r.device_bytes_per_particle << " GPU bytes/particle";
  if (r.graph_step_fraction > 0)
    s << ", " << std::setprecision(3) << 100 * r.graph_step_fraction
      << "% of steps through CUDA graphs" << std::setprecision(4);
  s << "\n";
  if (!r.profile.empty()) s << "  " << r.profile << "\n";
  if (r.mps_watchdog_off > 0)
    s << "  watchdog off " << r.mps_watchdog_off << " MPS/s, on " << r.mps_watchdog_on
      << " MPS/s: the watchdog costs " << std::setprecision(2) << r.watchdog_cost_percent
      << "% of a step\n";
  else if (!r.watchdog)
    s << "  (watchdog off)\n";
  return s.str();
}

}  // namespace mesorock::pipeline
