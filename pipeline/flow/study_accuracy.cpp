// rockflow study: the time-step and precision studies (docs/accuracy.md), and the slit that the
// resolution study shares (study_accuracy.h).
//
// Accuracy systems (the liquid of the validation cases: A = -40, B = 25, rd = 0.75, gamma = 4.5,
// rho = 7, papers' density kernel): a periodic cube for the temperature and the pressure, the
// reverse Poiseuille box of the `viscosity` case for the viscosity, and a slit between walls of
// frozen liquid with the wall model (as `poiseuille-walls`) for the permeability. Each is built and
// brought to its steady state once at dt = 0.01 in double precision; every (dt, precision) run
// then starts from that same state, equilibrates at its own dt, runs a timed stretch of steps
// without sampling, and samples at a fixed interval of simulated time (0.1).
#include "pipeline/flow/study_accuracy.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/flow/reverse_poiseuille.h"
#include "pipeline/flow/statistics.h"
#include "pipeline/flow/wall_liquid.h"
#include "sim/eos.h"
#include "sim/observables.h"

namespace mesorock::pipeline::study_detail {

using namespace wall_liquid;

namespace {

// Warren 2003's fit of the mDPD equation of state at the study's liquid (sim/eos.h).
double warren_pressure(double rho) {
  return sim::warren_pressure(rho, kA, kB, kRd);
}

// Brings a system to its steady state at dt = 0.01 (double precision) and keeps the particles.
void pre_equilibrate(const Context& c, Prepared& p, const std::string& what) {
  auto s = sim::make_simulation(p.s.model, p.s.box, p.s.particles, 0.01, c.o.sim);
  run_checked(*s, steps_for(c.z.pre_tau, 0.01), what + " (pre-equilibration)", kAnyTemperature);
  p.s.particles = s->particles();
}

Prepared prepare_bulk(const Context& c) {
  Prepared p;
  const double e = c.z.bulk_edge, L[3] = {e, e, e};
  p.s = make_bulk_mdpd(kA, kB, kRd, kGamma, kRho, L, c.o.seed + 11, sim::DensityKernelKind::Warren);
  p.fluid = p.s.particles.size();
  p.fluid_density = static_cast<double>(p.fluid) / p.s.box.volume();
  pre_equilibrate(c, p, "bulk");
  return p;
}

// Reverse Poiseuille (the `viscosity` case): +g x below the mid-plane z = Lz/2, -g x above.
// Started from the Stokes profile of the reference viscosity so that no start-up time is needed.
Prepared prepare_viscosity(const Context& c) {
  Prepared p;
  const double L[3] = {c.z.visc_lxy, c.z.visc_lxy, c.z.visc_lz};
  p.s = make_bulk_mdpd(kA, kB, kRd, kGamma, kRho, L, c.o.seed + 12, sim::DensityKernelKind::Warren);
  // Peak shear rate (at the mid-plane and the periodic face) rho g Lz / (4 eta).
  p.g = c.z.visc_rate * 4 * kBulkViscosity / (kRho * L[2]);
  drive_reverse_poiseuille(p.s.model, p.g);
  const double h = 0.5 * L[2], a = kRho * p.g / (2 * kBulkViscosity);
  for (std::size_t i = 0; i < p.s.particles.size(); ++i) {
    const double z = p.s.particles.z[i];
    p.s.particles.vx[i] += z < h ? a * z * (h - z) : -a * (z - h) * (L[2] - z);
  }
  p.fluid = p.s.particles.size();
  p.fluid_density = static_cast<double>(p.fluid) / p.s.box.volume();
  pre_equilibrate(c, p, "viscosity box");
  return p;
}

}  // namespace

Prepared prepare_slit(const Context& c, double H, double lxy, double rate, std::uint64_t seed) {
  Prepared p;
  p.wall = 1.5;
  p.width = H;
  const double L[3] = {lxy, lxy, H + 2 * p.wall};
  const double w = p.wall;
  p.s = liquid_with_walls(
      L, {true, true, false},
      [&](double, double, double z) { return std::max(w - z, z - (L[2] - w)); }, w,
      c.z.wall_equilibrate, seed, c.vo);
  p.g = rate * 2 * kBulkViscosity / (kRho * H);
  p.s.model.types[0].body_force = {p.g, 0, 0};
  for (std::size_t i = 0; i < p.s.particles.size(); ++i) {
    if (p.s.particles.type[i] != 0) continue;
    ++p.fluid;
    const double z = p.s.particles.z[i] - w;
    p.s.particles.vx[i] += kRho * p.g / (2 * kBulkViscosity) * z * (H - z);
  }
  p.fluid_density = static_cast<double>(p.fluid) / (H * lxy * lxy);
  pre_equilibrate(c, p, "slit H=" + fmt(H, 3));
  return p;
}

namespace {

sim::Model model_at(const Prepared& p, sim::Precision precision, std::uint64_t seed) {
  sim::Model m = p.s.model;
  m.precision = precision;
  m.seed = seed;
  return m;
}

// Shared start of every accuracy run: build, equilibrate at dt, time a pure stretch.
struct RunStart {
  std::unique_ptr<sim::Simulation> sim;
  double mps = 0;
};
RunStart start_run(const Context& c, const Prepared& p, double dt, sim::Precision precision,
                   std::uint64_t seed, double eq_tau, const std::string& what) {
  RunStart r;
  r.sim = sim::make_simulation(model_at(p, precision, seed), p.s.box, p.s.particles, dt, c.o.sim);
  run_checked(*r.sim, steps_for(eq_tau, dt), what);
  r.mps = timed_mps(*r.sim, c.z.timed_steps, what);
  return r;
}

struct BulkResult {
  bool stable = true;
  std::string failure;
  MeanWithError T, p;
  double mps = 0;
};

BulkResult measure_bulk(const Context& c, const Prepared& p, double dt, sim::Precision precision) {
  BulkResult r;
  const std::string what = "bulk dt=" + fmt(dt, 3) + " " + sim::to_string(precision);
  try {
    RunStart st = start_run(c, p, dt, precision, c.o.seed + 21, c.z.bulk_eq_tau, what);
    r.mps = st.mps;
    const std::uint64_t every = sample_every(dt);
    const std::uint64_t samples =
        std::max<std::uint64_t>(2, steps_for(c.z.bulk_sample_tau, dt) / every);
    std::vector<double> T, P;
    for (std::uint64_t k = 0; k < samples; ++k) {
      st.sim->run(every);
      T.push_back(temperature_or_throw(*st.sim, what));
      P.push_back(st.sim->stress().pressure_conservative());
      if (!std::isfinite(P.back())) throw Unstable(what + ": pressure is not finite");
    }
    r.T = block_average(T, 10);
    r.p = block_average(P, 10);
  } catch (const std::exception& e) {
    if (!is_instability(e)) throw;
    r.stable = false;
    r.failure = e.what();
  }
  return r;
}

struct ViscosityResult {
  bool stable = true;
  std::string failure;
  double eta = NAN, eta_error = NAN, chi2 = NAN, temperature = NAN;
  double mps = 0;
};

// eta from the reverse Poiseuille profile (reverse_poiseuille.h) in 0.5 rc bins (the nearest
// count), sampled every 0.1 time units; a kinetic energy that is not finite or too large stops
// the run as unstable.
ViscosityResult measure_viscosity_at(const Context& c, const Prepared& p, double dt,
                                     sim::Precision precision) {
  ViscosityResult r;
  const std::string what = "viscosity dt=" + fmt(dt, 3) + " " + sim::to_string(precision);
  try {
    RunStart st = start_run(c, p, dt, precision, c.o.seed + 22, c.z.visc_eq_tau, what);
    r.mps = st.mps;
    ReversePoiseuilleSampling sampling;
    sampling.bins = static_cast<int>(std::lround(p.s.box.length(2) * 2));
    sampling.every = sample_every(dt);
    const std::uint64_t total =
        std::max<std::uint64_t>(4, steps_for(c.z.visc_sample_tau, dt) / sampling.every);
    // Blocks of at least 2 tau (the profile relaxes in about (Lz/2)^2 / (pi^2 nu)), at most 20.
    sampling.blocks = std::min<std::uint64_t>(
        total, static_cast<std::uint64_t>(std::clamp(c.z.visc_sample_tau / 2, 2.0, 20.0)));
    sampling.samples_per_block = total / sampling.blocks;
    auto check = [&](const std::vector<double>& sums) {
      double n = 0, vv = 0;
      for (int b = 0; b < sampling.bins; ++b) {
        const double* s = &sums[static_cast<size_t>(b) * sim::kBinFields];
        n += s[sim::kBinCount];
        vv += s[sim::kBinVxx] + s[sim::kBinVyy] + s[sim::kBinVzz];
      }
      if (!(std::isfinite(vv) && vv / (3 * n) < kMaxTemperature))
        throw Unstable(what + ": kinetic energy is not finite or too large at step " +
                       std::to_string(st.sim->step()));
    };
    const ReversePoiseuille m =
        sample_reverse_poiseuille(*st.sim, p.s.box, sampling, p.fluid_density, p.g, check);
    r.eta = m.eta;
    r.eta_error = m.eta_error;
    r.chi2 = m.chi2_per_dof;
    r.temperature = m.temperature;
    if (!std::isfinite(r.eta)) throw Unstable(what + ": viscosity is not finite");
  } catch (const std::exception& e) {
    if (!is_instability(e)) throw;
    r.stable = false;
    r.failure = e.what();
  }
  return r;
}

}  // namespace

SlitResult measure_slit(const Context& c, const Prepared& p, double dt, sim::Precision precision,
                        double eq_tau, double sample_tau, const std::string& what) {
  SlitResult r;
  try {
    RunStart st = start_run(c, p, dt, precision, c.o.seed + 23, eq_tau, what);
    r.mps = st.mps;
    r.seconds_per_tau = static_cast<double>(st.sim->size()) / (st.mps * 1e6 * dt);
    const double Lz = p.s.box.length(2);
    const int bins = static_cast<int>(std::lround(Lz * 4));  // 0.25 rc
    sim::BinGrid grid = sim::BinGrid::profile(2, bins, p.s.box.lo, p.s.box.hi);
    grid.type_mask = 1u;  // fluid
    sim::BinnedAverage profile(grid);
    const std::uint64_t every = sample_every(dt);
    const std::uint64_t total = std::max<std::uint64_t>(4, steps_for(sample_tau, dt) / every);
    std::vector<double> means;
    for (std::uint64_t k = 0; k < total; ++k) {
      st.sim->run(every);
      const auto sums = st.sim->bin_sums(grid);
      double n = 0, vx = 0, vv = 0;
      for (int b = 0; b < bins; ++b) {
        const double* s = &sums[static_cast<size_t>(b) * sim::kBinFields];
        n += s[sim::kBinCount];
        vx += s[sim::kBinVx];
        vv += s[sim::kBinVxx] + s[sim::kBinVyy] + s[sim::kBinVzz];
      }
      if (!(std::isfinite(vv) && n > 0 && vv / (3 * n) < kMaxTemperature))
        throw Unstable(what + ": kinetic energy is not finite or too large at step " +
                       std::to_string(st.sim->step()));
      means.push_back(vx / n);
      profile.add(sums);
    }
    // Blocks of at least 2 tau (longer than the flow's relaxation time in the slits studied,
    // about H^2 / (pi^2 nu) <= 6.5), at most 16.
    const auto blocks = static_cast<size_t>(std::clamp(sample_tau / 2, 2.0, 16.0));
    const MeanWithError u = block_average(means, blocks);
    r.u_mean = u.mean;
    r.u_error = u.error;
    const double scale = kBulkViscosity / (p.fluid_density * p.g);
    r.k = scale * u.mean;
    r.k_error = scale * u.error;
    // The profile's parabola away from the first 0.5 rc at each wall (as poiseuille-walls): its
    // zeros give the hydrodynamic width, and the slip length is how far beyond each cut plane the
    // parabola reaches zero (mean of both walls).
    const auto um = profile.velocity(0);
    const auto T = profile.temperature();
    const double width = Lz / bins, zc = 0.5 * Lz;
    std::vector<double> zz, uu;
    double tw = 0, tb = 0;
    int nw = 0, nb = 0;
    for (int b = 0; b < bins; ++b) {
      const double z = (b + 0.5) * width;
      const double from_wall = std::min(z - p.wall, Lz - p.wall - z);
      if (from_wall > 0 && from_wall < 0.5) {
        tw += T.mean[static_cast<size_t>(b)];
        ++nw;
      }
      if (std::abs(z - zc) <= p.width / 6) {
        tb += T.mean[static_cast<size_t>(b)];
        ++nb;
      }
      if (from_wall < 0.5) continue;
      zz.push_back(z);
      uu.push_back(um.mean[static_cast<size_t>(b)]);
    }
    if (nw > 0) r.wall_temperature = tw / nw;
    if (nb > 0) r.bulk_temperature = tb / nb;
    // Only where the fit spans at least 2 rc (H >= 3), and only a parabola that opens downwards
    // and has zeros: otherwise the noise, not the flow, shapes it.
    if (p.width - 1.0 >= 2.0 - 1e-9 && zz.size() >= 4) {
      const ParabolaFit f = fit_parabola(zz, uu, {}, zc);
      const double d2 = f.c1 * f.c1 - 4 * f.c0 * f.c2;
      if (f.c2 < 0 && d2 > 0) {
        r.hydrodynamic_width = std::sqrt(d2) / std::abs(f.c2);
        r.slip = 0.5 * (r.hydrodynamic_width - p.width);
      }
    }
    if (!std::isfinite(r.k)) throw Unstable(what + ": permeability is not finite");
  } catch (const std::exception& e) {
    if (!is_instability(e)) throw;
    r.stable = false;
    r.failure = e.what();
  }
  return r;
}

namespace {

// The bulk cube replicated copies^3 times: an equilibrated large box for the cost column.
BuiltSystem replicate(const BuiltSystem& s, int copies) {
  BuiltSystem big;
  big.model = s.model;
  const double L[3] = {s.box.length(0), s.box.length(1), s.box.length(2)};
  for (int a = 0; a < 3; ++a) {
    big.box.lo[a] = s.box.lo[a];
    big.box.hi[a] = s.box.lo[a] + copies * L[a];
  }
  const auto n = static_cast<std::int64_t>(s.particles.size());
  big.particles.reserve(s.particles.size() * static_cast<size_t>(copies * copies * copies));
  std::int64_t k = 0;
  for (int i = 0; i < copies; ++i)
    for (int j = 0; j < copies; ++j)
      for (int l = 0; l < copies; ++l, ++k)
        for (std::size_t q = 0; q < s.particles.size(); ++q)
          big.particles.add(s.particles.x[q] + i * L[0], s.particles.y[q] + j * L[1],
                            s.particles.z[q] + l * L[2], s.particles.vx[q], s.particles.vy[q],
                            s.particles.vz[q], s.particles.type[q], s.particles.id[q] + k * n);
  return big;
}

// MPS/s of the replicated bulk liquid at each time step, in one precision: one simulation, the
// time steps in increasing order (a new simulation after an unstable one).
struct ScaleTiming {
  std::size_t particles = 0;
  std::vector<double> mps;  // per dt; NaN where unstable
};
ScaleTiming time_at_scale(const Context& c, const BuiltSystem& big, sim::Precision precision,
                          const std::vector<double>& dts) {
  ScaleTiming r;
  r.particles = big.particles.size();
  sim::Model m = big.model;
  m.precision = precision;
  m.seed = c.o.seed + 31;
  std::unique_ptr<sim::Simulation> s;
  for (double dt : dts) {
    const std::string what =
        "scale " + std::string(sim::to_string(precision)) + " dt=" + fmt(dt, 3);
    try {
      if (!s) s = sim::make_simulation(m, big.box, big.particles, dt, c.o.sim);
      s->set_dt(dt);
      s->run(5);
      r.mps.push_back(timed_mps(*s, c.z.scale_steps, what));
      say(c, what + ": " + fmt(r.mps.back(), 4) + " MPS/s (" + std::to_string(r.particles) +
                 " particles)");
    } catch (const std::exception& e) {
      if (!is_instability(e)) throw;
      say(c, std::string("unstable: ") + e.what());
      r.mps.push_back(NAN);
      s.reset();
    }
  }
  return r;
}

// One row of the time-step or precision study.
Json accuracy_row(double dt, sim::Precision precision, const Prepared& slit, const BulkResult& b,
                  const ViscosityResult& v, const SlitResult& k, double scale_mps,
                  const BulkResult* ref_b, const SlitResult* ref_k) {
  const double pw = warren_pressure(kRho);
  const double stokes = slit.width * slit.width / 12;
  Json row;
  row["dt"] = dt;
  row["precision"] = sim::to_string(precision);
  row["stable"] = b.stable && v.stable && k.stable;
  row["temperature"] = number_or_null(b.stable ? b.T.mean : NAN);
  row["temperature_error"] = number_or_null(b.stable ? b.T.error : NAN);
  row["temperature_deviation"] = number_or_null(b.stable ? b.T.mean - 1.0 : NAN);
  row["pressure"] = number_or_null(b.stable ? b.p.mean : NAN);
  row["pressure_error"] = number_or_null(b.stable ? b.p.error : NAN);
  row["pressure_vs_reference_dt"] =
      number_or_null(b.stable && ref_b && ref_b->stable ? b.p.mean - ref_b->p.mean : NAN);
  row["pressure_vs_warren"] = number_or_null(b.stable ? b.p.mean - pw : NAN);
  row["viscosity"] = number_or_null(v.eta);
  row["viscosity_error"] = number_or_null(v.eta_error);
  row["viscosity_vs_reference"] = number_or_null(v.eta / kBulkViscosity - 1);
  row["viscosity_profile_chi2"] = number_or_null(v.chi2);
  row["viscosity_box_temperature"] = number_or_null(v.temperature);
  row["permeability"] = number_or_null(k.k);
  row["permeability_error"] = number_or_null(k.k_error);
  row["permeability_vs_reference_dt"] =
      number_or_null(ref_k && ref_k->stable ? k.k / ref_k->k - 1 : NAN);
  row["permeability_vs_stokes"] = number_or_null(k.k / stokes - 1);
  row["slip_length"] = number_or_null(k.slip);
  row["mps_bulk_box"] = number_or_null(b.mps);
  row["mps_viscosity_box"] = number_or_null(v.mps);
  row["mps_slit"] = number_or_null(k.mps);
  row["mps_at_scale"] = number_or_null(scale_mps);
  row["ns_per_particle_tau"] = number_or_null(ns_per_particle_tau(scale_mps, dt));
  std::string failure;
  for (const std::string* f : {&b.failure, &v.failure, &k.failure})
    if (!f->empty()) failure += (failure.empty() ? "" : "; ") + *f;
  row["failure"] = failure;
  return row;
}

struct AccuracyRun {
  BulkResult bulk;
  ViscosityResult viscosity;
  SlitResult slit;
};

AccuracyRun measure_accuracy(const Context& c, const Prepared& bulk, const Prepared& visc,
                             const Prepared& slit, double dt, sim::Precision precision) {
  const auto t0 = Clock::now();
  AccuracyRun r;
  r.bulk = measure_bulk(c, bulk, dt, precision);
  r.viscosity = measure_viscosity_at(c, visc, dt, precision);
  r.slit = measure_slit(c, slit, dt, precision, c.z.slit_eq_tau, c.z.slit_sample_tau,
                        "slit dt=" + fmt(dt, 3) + " " + sim::to_string(precision));
  std::ostringstream s;
  s << "dt=" << dt << " " << sim::to_string(precision) << ": ";
  if (r.bulk.stable)
    s << "T " << fmt(r.bulk.T.mean, 5) << " +- " << fmt(r.bulk.T.error, 2) << ", p "
      << fmt(r.bulk.p.mean, 5) << " +- " << fmt(r.bulk.p.error, 2);
  else
    s << "bulk unstable";
  s << "; eta "
    << (r.viscosity.stable ? fmt(r.viscosity.eta) + " +- " + fmt(r.viscosity.eta_error, 2)
                           : std::string("unstable"));
  s << "; k "
    << (r.slit.stable ? fmt(r.slit.k) + " +- " + fmt(r.slit.k_error, 2) : std::string("unstable"));
  s << " (" << fmt(seconds_since(t0), 3) << " s)";
  say(c, s.str());
  return r;
}

}  // namespace

// Studies 1 and 2: time step (double precision, every dt) and precision (dt = 0.01, single
// against the double run of the same systems). Both share the prepared systems.
void run_timestep_and_precision(const Context& c, bool want_dt, bool want_precision,
                                StudyResult& dt_study, StudyResult& precision_study) {
  const auto t0 = Clock::now();
  say(c, "preparing the accuracy systems (bulk cube, reverse Poiseuille box, slit) at dt = 0.01");
  const Prepared bulk = prepare_bulk(c);
  const Prepared visc = prepare_viscosity(c);
  const Prepared slit = prepare_slit(c, c.z.slit_width, c.z.slit_lxy, c.z.slit_rate, c.o.seed + 13);
  say(c, "prepared: bulk " + std::to_string(bulk.s.particles.size()) + ", viscosity box " +
             std::to_string(visc.s.particles.size()) + ", slit " +
             std::to_string(slit.s.particles.size()) + " particles (" + fmt(seconds_since(t0), 3) +
             " s)");
  Json system = {{"liquid",
                  {{"A", kA},
                   {"B", kB},
                   {"rd", kRd},
                   {"gamma", kGamma},
                   {"rho", kRho},
                   {"density_kernel", "warren"},
                   {"kBT", 1.0},
                   {"lambda", 0.5}}},
                 {"bulk",
                  {{"edge", c.z.bulk_edge},
                   {"particles", bulk.s.particles.size()},
                   {"equilibrate_tau", c.z.bulk_eq_tau},
                   {"sample_tau", c.z.bulk_sample_tau}}},
                 {"viscosity",
                  {{"box", {c.z.visc_lxy, c.z.visc_lxy, c.z.visc_lz}},
                   {"particles", visc.s.particles.size()},
                   {"g", visc.g},
                   {"peak_shear_rate", c.z.visc_rate},
                   {"equilibrate_tau", c.z.visc_eq_tau},
                   {"sample_tau", c.z.visc_sample_tau},
                   {"reference", kBulkViscosity},
                   {"reference_error", kBulkViscosityError}}},
                 {"slit",
                  {{"width", slit.width},
                   {"lxy", c.z.slit_lxy},
                   {"wall_thickness", slit.wall},
                   {"particles", slit.s.particles.size()},
                   {"fluid_particles", slit.fluid},
                   {"fluid_density", slit.fluid_density},
                   {"g", slit.g},
                   {"peak_shear_rate", c.z.slit_rate},
                   {"equilibrate_tau", c.z.slit_eq_tau},
                   {"sample_tau", c.z.slit_sample_tau},
                   {"stokes_permeability", slit.width * slit.width / 12}}},
                 {"pre_equilibrate_tau_at_dt_0.01", c.z.pre_tau},
                 {"timed_steps", c.z.timed_steps},
                 {"sample_interval_tau", 0.1},
                 {"warren_pressure", warren_pressure(kRho)}};
  const BuiltSystem big = replicate(bulk.s, c.z.scale_copies);
  const std::vector<double> dts = want_dt ? c.z.dts : std::vector<double>{0.01};
  std::vector<AccuracyRun> runs;
  for (double dt : dts)
    runs.push_back(measure_accuracy(c, bulk, visc, slit, dt, sim::Precision::Double));
  const ScaleTiming scale_double = time_at_scale(c, big, sim::Precision::Double, dts);
  // The reference of the time-step study: the smallest dt.
  const AccuracyRun& ref = runs.front();
  const double ref_dt = dts.front();
  if (want_dt) {
    dt_study.parameters = system;
    dt_study.parameters["dts"] = dts;
    dt_study.parameters["precision"] = "double";
    dt_study.parameters["reference_dt"] = ref_dt;
    dt_study.parameters["scale_particles"] = scale_double.particles;
    dt_study.parameters["scale_steps"] = c.z.scale_steps;
    for (size_t i = 0; i < dts.size(); ++i)
      dt_study.rows.push_back(accuracy_row(dts[i], sim::Precision::Double, slit, runs[i].bulk,
                                           runs[i].viscosity, runs[i].slit, scale_double.mps[i],
                                           &ref.bulk, &ref.slit));
    dt_study.seconds = seconds_since(t0);
  }
  if (want_precision) {
    const auto t1 = Clock::now();
    size_t at = 0;
    while (at < dts.size() && std::abs(dts[at] - 0.01) > 1e-12) ++at;
    if (at == dts.size()) throw std::logic_error("study: dt = 0.01 missing");
    const AccuracyRun single = measure_accuracy(c, bulk, visc, slit, 0.01, sim::Precision::Single);
    const ScaleTiming scale_single = time_at_scale(c, big, sim::Precision::Single, {0.01});
    precision_study.parameters = system;
    precision_study.parameters["dt"] = 0.01;
    precision_study.parameters["scale_particles"] = scale_single.particles;
    precision_study.parameters["scale_steps"] = c.z.scale_steps;
    // Deviations of each precision from the double-precision run (the reference).
    precision_study.rows.push_back(
        accuracy_row(0.01, sim::Precision::Double, slit, runs[at].bulk, runs[at].viscosity,
                     runs[at].slit, scale_double.mps[at], &runs[at].bulk, &runs[at].slit));
    precision_study.rows.push_back(accuracy_row(0.01, sim::Precision::Single, slit, single.bulk,
                                                single.viscosity, single.slit, scale_single.mps[0],
                                                &runs[at].bulk, &runs[at].slit));
    precision_study.seconds = want_dt ? seconds_since(t1) : seconds_since(t0);
  }
}

}  // namespace mesorock::pipeline::study_detail
