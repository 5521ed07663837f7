// rockflow study, the reorder study (docs/accuracy.md): the cell list's settings against speed.
#include <algorithm>
#include <cmath>

#include "pipeline/flow/statistics.h"
#include "pipeline/flow/study_common.h"
#include "pipeline/flow/wall_liquid.h"

namespace mesorock::pipeline::study_detail {

using namespace wall_liquid;

namespace {

// Study 5: reorder interval and skin (and cells per rc) against MPS/s, on the bulk and porous
// benchmark systems, plus a round-off check in double precision.
struct GridConfig {
  int reorder = 1;
  double skin = 0;
  int cells = 1;
};

std::vector<GridConfig> grid_configs(const Sizes& z) {
  std::vector<GridConfig> g{{1, 0, 1}};
  for (int m : z.cells) g.push_back({1, 0, m});
  for (int r : z.reorders)
    for (double s : z.skins) g.push_back({r, s, 1});
  return g;
}

sim::SimulationOptions with_grid(sim::SimulationOptions o, const GridConfig& g) {
  o.reorder_every = g.reorder;
  o.skin = g.skin;
  o.cells_per_cutoff = g.cells;
  return o;
}

}  // namespace

StudyResult run_reorder(const Context& c) {
  StudyResult out;
  const auto t0 = Clock::now();
  const std::vector<GridConfig> configs = grid_configs(c.z);
  // Round-off check: every configuration from the same double-precision state for check_steps;
  // positions and temperature against the default's.
  std::vector<double> max_dx(configs.size(), 0.0), dT(configs.size(), 0.0);
  {
    const double e = c.z.check_edge, L[3] = {e, e, e};
    BuiltSystem s =
        make_bulk_mdpd(kA, kB, kRd, kGamma, kRho, L, c.o.seed + 51, sim::DensityKernelKind::Warren);
    s.model.precision = sim::Precision::Double;
    s = equilibrated(c, s, 50, "round-off check system");
    sim::ParticleSet ref;
    double ref_T = 0;
    for (size_t k = 0; k < configs.size(); ++k) {
      auto sim =
          sim::make_simulation(s.model, s.box, s.particles, 0.01, with_grid(c.o.sim, configs[k]));
      sim->run(c.z.check_steps);
      const sim::ParticleSet p = sim->particles();
      const double T = sim->kinetic_temperature();
      if (k == 0) {
        ref = p;
        ref_T = T;
        continue;
      }
      for (size_t i = 0; i < p.size(); ++i) {
        const double d[3] = {p.x[i] - ref.x[i], p.y[i] - ref.y[i], p.z[i] - ref.z[i]};
        double d2 = 0;
        for (int a = 0; a < 3; ++a) {
          const double m = d[a] - L[a] * std::round(d[a] / L[a]);
          d2 += m * m;
        }
        max_dx[k] = std::max(max_dx[k], std::sqrt(d2));
      }
      dT[k] = std::abs(T - ref_T);
    }
    say(c, "round-off check (" + std::to_string(s.particles.size()) + " particles, double, " +
               std::to_string(c.z.check_steps) + " steps): largest position difference " +
               fmt(*std::max_element(max_dx.begin(), max_dx.end()), 3) + " rc");
  }
  out.parameters = {{"reorders", c.z.reorders},
                    {"skins", c.z.skins},
                    {"cells_per_rc", c.z.cells},
                    {"precision", "single"},
                    {"dt", 0.01},
                    {"equilibrate_steps", c.z.grid_equilibrate},
                    {"warm_steps", c.z.grid_warm},
                    {"timed_steps", c.z.grid_steps},
                    {"check_particles",
                     static_cast<std::int64_t>(std::llround(kRho * std::pow(c.z.check_edge, 3)))},
                    {"check_steps", c.z.check_steps},
                    {"check_precision", "double"}};
  for (const std::string system : {"bulk", "porous"}) {
    BuiltSystem s;
    if (system == "bulk") {
      // The benchmark's liquid (rockflow bench --case bulk): rho = 6.9.
      const double L = std::cbrt(static_cast<double>(c.z.grid_particles) / 6.9);
      const double box[3] = {L, L, L};
      s = make_bulk_mdpd(-40, 25, 0.75, 4.5, 6.9, box, c.o.seed + 52,
                         sim::DensityKernelKind::Warren);
    } else {
      const int n = std::max(1, static_cast<int>(std::lround(
                                    std::sqrt(static_cast<double>(c.z.grid_particles) / 1916.0))));
      s = make_porous_benchmark(n, n, c.o.seed + 53);
    }
    s.model.precision = sim::Precision::Single;
    s = equilibrated(c, s, c.z.grid_equilibrate, system + " grid system");
    say(c, "reorder grid on " + system + " (" + std::to_string(s.particles.size()) +
               " particles), " + std::to_string(configs.size() + 1) + " configurations");
    // The default first and again last: the spread shows the drift of the machine.
    std::vector<size_t> order;
    for (size_t k = 0; k < configs.size(); ++k) order.push_back(k);
    order.push_back(0);
    double base_mps = 0;
    for (size_t q = 0; q < order.size(); ++q) {
      const GridConfig& g = configs[order[q]];
      const std::string what = system + " reorder " + std::to_string(g.reorder) + " skin " +
                               fmt(g.skin, 2) + " cells " + std::to_string(g.cells);
      Json row;
      row["system"] = system;
      row["particles"] = s.particles.size();
      row["reorder_every"] = g.reorder;
      row["skin"] = g.skin;
      row["cells_per_rc"] = g.cells;
      row["repeat"] = q == order.size() - 1 ? 2 : 1;
      try {
        auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, with_grid(c.o.sim, g));
        sim->run(c.z.grid_warm);
        const double mps = timed_mps(*sim, c.z.grid_steps, what, kRunawayTemperature);
        if (q == 0) base_mps = mps;
        row["mps"] = mps;
        row["speedup_vs_default"] = base_mps > 0 ? mps / base_mps : NAN;
        row["temperature_end"] = sim->kinetic_temperature();
        row["pressure_end"] = sim->stress().pressure_conservative();
        row["stable"] = true;
        say(c, what + ": " + fmt(mps, 4) + " MPS/s");
      } catch (const std::exception& e) {
        if (!is_instability(e)) throw;
        row["mps"] = nullptr;
        row["speedup_vs_default"] = nullptr;
        row["temperature_end"] = nullptr;
        row["pressure_end"] = nullptr;
        row["stable"] = false;
        say(c, std::string("unstable: ") + e.what());
      }
      row["check_max_position_difference"] = max_dx[order[q]];
      row["check_temperature_difference"] = dT[order[q]];
      out.rows.push_back(row);
    }
  }
  out.summary["check_max_position_difference"] = *std::max_element(max_dx.begin(), max_dx.end());
  out.summary["check_max_temperature_difference"] = *std::max_element(dT.begin(), dT.end());
  out.seconds = seconds_since(t0);
  return out;
}

}  // namespace mesorock::pipeline::study_detail
