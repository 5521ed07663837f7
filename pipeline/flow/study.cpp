// rockflow study: the accuracy-versus-time study (docs/accuracy.md). See study.h.
//
// Accuracy systems (the liquid of the validation cases: A = -40, B = 25, rd = 0.75, gamma = 4.5,
// rho = 7, papers' density kernel): a periodic cube for the temperature and the pressure, the
// reverse Poiseuille box of the `viscosity` case for the viscosity, and a slit between walls of
// frozen liquid with the wall model (as `poiseuille-walls`) for the permeability. Each is built and
// brought to its steady state once at dt = 0.01 in double precision; every (dt, precision) run
// then starts from that same state, equilibrates at its own dt, runs a timed stretch of steps
// without sampling, and samples at a fixed interval of simulated time (0.1).
#include "pipeline/flow/study.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#if defined(MESOROCK_HAVE_CUDA)
#include <cuda_runtime_api.h>
#endif

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/reverse_poiseuille.h"
#include "pipeline/flow/statistics.h"
#include "pipeline/flow/systems.h"
#include "pipeline/flow/validation.h"
#include "pipeline/flow/wall_liquid.h"
#include "sim/domain/communicator.h"
#include "sim/eos.h"
#include "sim/init.h"
#include "sim/observables.h"

namespace mesorock::pipeline {

namespace {

using namespace wall_liquid;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::ordered_json;

// Warren 2003's fit of the mDPD equation of state at the study's liquid (sim/eos.h).
double warren_pressure(double rho) {
  return sim::warren_pressure(rho, kA, kB, kRd);
}

// A run is called unstable when its kinetic temperature leaves (0, kMaxTemperature) or a sampled
// value is not finite; the row then says so and the study goes on.
constexpr double kMaxTemperature = 3.0;
class Unstable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// A run that blew up: the study's own checks (Unstable) or the solver's watchdog
// (NumericalError: NaN, infinity or a runaway particle). Either makes the row "unstable".
bool is_instability(const std::exception& e) {
  return dynamic_cast<const Unstable*>(&e) != nullptr ||
         dynamic_cast<const NumericalError*>(&e) != nullptr;
}

// Sizes of every study at one size (tiny / small / full).
struct Sizes {
  // Time step and precision.
  std::vector<double> dts{0.005, 0.01, 0.02, 0.03, 0.04};
  double pre_tau = 2;  // at dt = 0.01, once per system, before the per-dt runs
  double bulk_edge = 5, bulk_eq_tau = 1, bulk_sample_tau = 5;
  double visc_lxy = 5, visc_lz = 10, visc_rate = 0.2, visc_eq_tau = 1, visc_sample_tau = 8;
  double slit_width = 4, slit_lxy = 5, slit_rate = 0.2, slit_eq_tau = 1, slit_sample_tau = 8;
  std::uint64_t wall_equilibrate = 300;  // steps of the bulk liquid before the walls are cut
  std::uint64_t timed_steps = 50;        // pure stepping stretch on each accuracy system
  int scale_copies = 2;                  // the cost column: the bulk cube replicated n^3 times
  std::uint64_t scale_steps = 30;
  // Resolution.
  std::vector<double> widths{2, 3, 4, 6, 8};
  double res_pore_volume = 100;  // H * Lx * Ly per slit (Lx = Ly = sqrt(V / H), at least 3)
  double res_rate = 0.2, res_eq_tau = 1, res_sample_tau = 6;
  // Reorder interval, skin and cells per rc.
  std::vector<int> reorders{1, 2, 5, 10, 20};
  std::vector<double> skins{0.2, 0.5};
  std::vector<int> cells{2, 3};
  std::int64_t grid_particles = 4000;
  std::uint64_t grid_equilibrate = 60, grid_warm = 5, grid_steps = 30;
  double check_edge = 5;  // round-off check: a double-precision cube of the liquid
  std::uint64_t check_steps = 30;
  // Effects.
  int effect_cells = 2;  // porous benchmark, effect_cells x effect_cells cells of 16 x 2 x 16
  std::uint64_t effect_equilibrate = 60, effect_warm = 5, effect_steps = 30;
  int bare_repeats = 6;
};

Sizes sizes_for(StudySize size) {
  Sizes z;
  if (size == StudySize::Tiny) {
    z.pre_tau = 0.5;
    z.bulk_edge = 4;
    z.bulk_eq_tau = 0.2;
    z.bulk_sample_tau = 0.5;
    z.visc_lxy = 4;
    z.visc_lz = 8;
    z.visc_rate = 0.2;
    z.visc_eq_tau = 0.2;
    z.visc_sample_tau = 0.5;
    z.slit_width = 3;
    z.slit_lxy = 4;
    z.slit_eq_tau = 0.2;
    z.slit_sample_tau = 0.5;
    z.wall_equilibrate = 30;
    z.timed_steps = 10;
    z.scale_copies = 2;
    z.scale_steps = 5;
    z.res_pore_volume = 72;
    z.res_eq_tau = 0.1;
    z.res_sample_tau = 0.3;
    z.reorders = {1, 5};
    z.skins = {0.3};
    z.cells = {2};
    z.grid_particles = 2000;
    z.grid_equilibrate = 60;
    z.grid_warm = 2;
    z.grid_steps = 10;
    z.check_edge = 4;
    z.check_steps = 10;
    z.effect_cells = 1;
    z.effect_equilibrate = 30;
    z.effect_warm = 2;
    z.effect_steps = 10;
    z.bare_repeats = 5;
  } else if (size == StudySize::Full) {
    // Planned for one H200 (about 700 MPS/s at 1-2 M particles, and 10-20 k steps/s for boxes
    // of 10-40 k particles): a few minutes in all.
    z.pre_tau = 5;
    z.bulk_edge = 12;
    z.bulk_eq_tau = 5;
    z.bulk_sample_tau = 50;
    z.visc_lxy = 10;
    z.visc_lz = 24;
    z.visc_rate = 0.1;
    z.visc_eq_tau = 15;
    z.visc_sample_tau = 250;
    z.slit_width = 6;
    z.slit_lxy = 12;
    z.slit_eq_tau = 10;
    z.slit_sample_tau = 150;
    z.wall_equilibrate = 500;
    z.timed_steps = 500;
    z.scale_copies = 4;  // 64 x 12,096 = 774,144 particles
    z.scale_steps = 100;
    z.res_pore_volume = 2048;
    z.res_eq_tau = 10;
    z.res_sample_tau = 250;
    z.skins = {0.1, 0.2, 0.3, 0.5};
    z.grid_particles = 1000000;
    z.grid_equilibrate = 100;
    z.grid_warm = 10;
    z.grid_steps = 100;
    z.check_edge = 8;
    z.check_steps = 50;
    z.effect_cells = 23;  // 23 x 23 cells: about 1.0 M particles
    z.effect_equilibrate = 100;
    z.effect_warm = 10;
    z.effect_steps = 150;
    z.bare_repeats = 6;
  }
  return z;
}

const char* size_name(StudySize s) {
  return s == StudySize::Tiny ? "tiny" : (s == StudySize::Small ? "small" : "full");
}

struct Context {
  StudyOptions o;
  Sizes z;
  ValidateOptions vo;  // for liquid_with_walls
};

void say(const Context& c, const std::string& line) {
  if (c.o.verbose) std::cerr << "study: " << line << std::endl;
}

std::uint64_t steps_for(double tau, double dt) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(tau / dt)));
}
// Samples every 0.1 time units (to the nearest step), whatever the time step.
std::uint64_t sample_every(double dt) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(0.1 / dt)));
}

// The kinetic temperature; Unstable when it is not finite or not below max_T.
double temperature_or_throw(sim::Simulation& s, const std::string& what,
                            double max_T = kMaxTemperature) {
  const double T = s.kinetic_temperature();
  if (!(std::isfinite(T) && T > 0 && T < max_T))
    throw Unstable(what + ": kinetic temperature " + fmt(T, 4) + " at step " +
                   std::to_string(s.step()));
  return T;
}

// Runs `steps` in chunks of about one time unit, checking the temperature after each. A system
// started from random positions is hot for its first steps: `max_T` infinite then checks only that
// the temperature stays finite.
void run_checked(sim::Simulation& s, std::uint64_t steps, const std::string& what,
                 double max_T = kMaxTemperature) {
  const std::uint64_t chunk = steps_for(1.0, s.dt());
  for (std::uint64_t done = 0; done < steps;) {
    const std::uint64_t k = std::min(chunk, steps - done);
    s.run(k);
    done += k;
    temperature_or_throw(s, what, max_T);
  }
}

constexpr double kAnyTemperature = std::numeric_limits<double>::infinity();
// The speed studies only guard against a runaway: scenes without the thermostat drift in
// temperature.
constexpr double kRunawayTemperature = 10.0;

// Waits for the queued steps: a one-bin count that matches no type (a tiny kernel and a copy of
// 7 numbers on a device, where reading the temperature would copy every particle back).
void synchronise(sim::Simulation& s) {
  sim::BinGrid none;
  none.lo = s.box().lo;
  none.hi = s.box().hi;
  none.type_mask = 0;
  (void)s.bin_sums(none);
}

// A pure stretch of steps, timed from a synchronised start to a synchronised end; the temperature
// is checked afterwards. Returns million particle-steps per second.
double timed_mps(sim::Simulation& s, std::uint64_t steps, const std::string& what,
                 double max_T = kMaxTemperature) {
  synchronise(s);
  const auto t0 = Clock::now();
  s.run(steps);
  synchronise(s);
  const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
  temperature_or_throw(s, what, max_T);
  return static_cast<double>(s.size()) * static_cast<double>(steps) / sec / 1e6;
}

// Nanoseconds of wall time per particle per simulated time unit at `mps` MPS/s and time step dt.
double ns_per_particle_tau(double mps, double dt) {
  return mps > 0 ? 1e3 / (mps * dt) : NAN;
}

Json number_or_null(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

// --------------------------------------------------------------------------------------------
// Accuracy systems.

struct Prepared {
  BuiltSystem s;
  std::size_t fluid = 0;  // mobile particles
  double g = 0;           // body force per particle (viscosity, slit)
  double width = 0;       // slit: distance between the cut planes
  double wall = 0;        // slit: wall thickness (cut plane at z = wall and Lz - wall)
  double fluid_density = 0;
};

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

// A slit of width H between walls of frozen liquid 1.5 rc thick (liquid_with_walls, wall model
// on), periodic in x and y, driven along x by a body force for a peak shear rate `rate` at the
// walls, started from the no-slip Stokes profile.
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

// Permeability of a slit. k = eta u_mean / (n g): u_mean the mean velocity of the fluid particles
// along the force, n = N_fluid / (H Lx Ly) their number density over the pore between the cut
// planes, g the force per particle, eta the reference viscosity (kBulkViscosity). Darcy's law
// for a pore of porosity 1 (superficial = mean velocity); Stokes flow with no slip at the cut
// planes gives k = H^2 / 12.
struct SlitResult {
  bool stable = true;
  std::string failure;
  double u_mean = NAN, u_error = NAN;
  double k = NAN, k_error = NAN;
  double hydrodynamic_width = NAN, slip = NAN;  // from a parabola fit of the profile
  double wall_temperature = NAN, bulk_temperature = NAN;
  double mps = 0;
  double seconds_per_tau = NAN;  // the timed stretch, for this box
};

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

struct StudyResult {
  Json parameters = Json::object();
  Json rows = Json::array();
  Json summary = Json::object();
  double seconds = 0;
};

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

// Study 4: slit width in rc (resolution) against the permeability's error from H^2 / 12.
StudyResult run_resolution(const Context& c) {
  StudyResult out;
  const auto t0 = Clock::now();
  out.parameters = {
      {"widths", c.z.widths},
      {"pore_volume_per_slit", c.z.res_pore_volume},
      {"wall_thickness", 1.5},
      {"peak_shear_rate", c.z.res_rate},
      {"dt", 0.01},
      {"precision", "double"},
      {"equilibrate_tau", c.z.res_eq_tau},
      {"sample_tau", c.z.res_sample_tau},
      {"viscosity", kBulkViscosity},
      {"hydrodynamic_wall", "the cut plane: where the frozen liquid ends and the fluid begins"}};
  std::uint64_t seed = c.o.seed + 40;
  for (double H : c.z.widths) {
    const double lxy = std::max(3.0, std::sqrt(c.z.res_pore_volume / H));
    const std::string what = "resolution H=" + fmt(H, 3);
    const auto t1 = Clock::now();
    const Prepared p = prepare_slit(c, H, lxy, c.z.res_rate, seed++);
    const SlitResult r =
        measure_slit(c, p, 0.01, sim::Precision::Double, c.z.res_eq_tau, c.z.res_sample_tau, what);
    const double stokes = H * H / 12;
    Json row;
    row["width"] = H;
    row["lxy"] = lxy;
    row["particles"] = p.s.particles.size();
    row["fluid_particles"] = p.fluid;
    row["fluid_density"] = p.fluid_density;
    row["g"] = p.g;
    row["stable"] = r.stable;
    row["mean_velocity"] = number_or_null(r.u_mean);
    row["mean_velocity_error"] = number_or_null(r.u_error);
    row["permeability"] = number_or_null(r.k);
    row["permeability_error"] = number_or_null(r.k_error);
    row["stokes_permeability"] = stokes;
    row["permeability_vs_stokes"] = number_or_null(r.k / stokes - 1);
    row["permeability_vs_stokes_error"] = number_or_null(r.k_error / stokes);
    row["hydrodynamic_width"] = number_or_null(r.hydrodynamic_width);
    row["slip_length"] = number_or_null(r.slip);
    row["wall_temperature"] = number_or_null(r.wall_temperature);
    row["bulk_temperature"] = number_or_null(r.bulk_temperature);
    row["mps"] = number_or_null(r.mps);
    row["seconds_per_tau"] = number_or_null(r.seconds_per_tau);
    // What a unit area of slit wall costs per time unit at this resolution (walls included).
    row["seconds_per_tau_per_area"] = number_or_null(r.seconds_per_tau / (lxy * lxy));
    row["ns_per_particle_tau"] = number_or_null(ns_per_particle_tau(r.mps, 0.01));
    row["failure"] = r.failure;
    out.rows.push_back(row);
    say(c, what + ": " + std::to_string(p.s.particles.size()) + " particles, k = " + fmt(r.k) +
               " +- " + fmt(r.k_error, 2) + " (H^2/12 = " + fmt(stokes) + "), slip " +
               fmt(r.slip, 3) + ", " + fmt(r.mps, 3) + " MPS/s (" + fmt(seconds_since(t1), 3) +
               " s)");
  }
  out.seconds = seconds_since(t0);
  return out;
}

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

BuiltSystem equilibrated(const Context& c, BuiltSystem s, std::uint64_t steps,
                         const std::string& what) {
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, c.o.sim);
  run_checked(*sim, steps, what, kAnyTemperature);
  s.particles = sim->particles();
  return s;
}

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

// --------------------------------------------------------------------------------------------
// Study 6: the cost of each effect switched on alone over the bare conservative pass.

// The scene's effects. The bare pass: standard DPD conservative force (a = 25) only.
struct Scene {
  std::string name, effect;
  bool active = true;         // false: the effect is declared in a form that never acts
  std::string base = "bare";  // what its cost is compared with
  bool mdpd = false, thermostat = false, body_force = false, wall_model = false;
  int virtual_wall = 0;  // 0 none, 1 active, 2 passed (until_step = 1)
  bool slab = false;
  int injection = 0;  // 0 none, 1 every 5 steps, 2 never due
  // Observables, each sampled every `every` steps (0: not declared); `chunked` runs in chunks of
  // `every` steps even when nothing is due (an observable never sampled).
  bool stress = false, profile = false, region_counts = false, region_pressure = false;
  bool never_sampled = false;
};

std::vector<Scene> effect_scenes(int bare_repeats) {
  std::vector<Scene> effects;
  auto add = [&](Scene s) { effects.push_back(s); };
  Scene s;
  s = {};
  s.name = "mdpd";
  s.effect = "many-body density (mDPD: density pass, A = -40, B = 25)";
  s.mdpd = true;
  add(s);
  s = {};
  s.name = "thermostat";
  s.effect = "DPD thermostat (gamma = 4.5, pair random numbers)";
  s.thermostat = true;
  add(s);
  s = {};
  s.name = "body_force";
  s.effect = "body force (g_z = 0.02 on the fluid)";
  s.body_force = true;
  add(s);
  s = {};
  s.name = "wall_model";
  s.effect = "wall model (Li et al. 2018) on the frozen walls; needs the thermostat";
  s.thermostat = s.wall_model = true;
  s.base = "thermostat";
  add(s);
  s = {};
  s.name = "virtual_wall";
  s.effect = "virtual wall at x = Lx/2 (active)";
  s.virtual_wall = 1;
  add(s);
  s = {};
  s.name = "rigid_slab";
  s.effect = "rigid slab (a layer of fluid moving as one body along z, P = 0)";
  s.slab = true;
  add(s);
  s = {};
  s.name = "injection";
  s.effect = "injection/ejection, one particle every 5 steps";
  s.injection = 1;
  add(s);
  s = {};
  s.name = "stress";
  s.effect = "stress tensor every 10 steps";
  s.stress = true;
  add(s);
  s = {};
  s.name = "profile";
  s.effect = "binned profile along z (0.5 rc bins) every 10 steps";
  s.profile = true;
  add(s);
  s = {};
  s.name = "region_counts";
  s.effect = "region counts (2 types in a box) every 10 steps";
  s.region_counts = true;
  add(s);
  s = {};
  s.name = "region_pressure";
  s.effect = "region pressure (per-particle virial over a box) every 10 steps";
  s.region_pressure = true;
  add(s);
  s = {};
  s.name = "virtual_wall_passed";
  s.effect = "virtual wall whose until_step (1) has passed";
  s.active = false;
  s.virtual_wall = 2;
  add(s);
  s = {};
  s.name = "injection_never_due";
  s.effect = "injection boundary whose start step is never reached";
  s.active = false;
  s.injection = 2;
  add(s);
  s = {};
  s.name = "observables_never_sampled";
  s.effect =
      "stress, profile, region counts and pressure declared, never due (run in chunks of "
      "10 steps)";
  s.active = false;
  s.never_sampled = true;
  add(s);
  s = {};
  s.name = "all_inactive";
  s.effect = "all three inactive forms together";
  s.active = false;
  s.virtual_wall = 2;
  s.injection = 2;
  s.never_sampled = true;
  add(s);
  // The bare pass repeated, spread evenly over the list, so its spread includes any drift.
  Scene bare;
  bare.name = "bare";
  bare.effect = "bare conservative pass (standard DPD, a = 25; nothing else)";
  bare.active = false;
  std::vector<Scene> out{bare};
  const size_t n = effects.size();
  const size_t gaps = static_cast<size_t>(std::max(2, bare_repeats) - 1);
  size_t next = 0;
  for (size_t r = 1; r <= gaps; ++r) {
    while (next < n * r / gaps) out.push_back(effects[next++]);
    out.push_back(bare);
  }
  while (next < n) out.push_back(effects[next++]);
  return out;
}

// The effects system: the porous benchmark's particles (equilibrated), fluid split into types
// by place so that every scene has the same types: 0 fluid left of x = Lx/2, 1 wall (frozen),
// 2 a layer of fluid at z in [15.1, 15.9) (the slab candidate, above the first row of rings),
// 3 fluid right of x = Lx/2. All pairs have the same parameters in every scene.
struct EffectsSystem {
  sim::BoxSpec box;
  sim::ParticleSet particles;
  double Lx = 0, Ly = 0, Lz = 0;
};

EffectsSystem make_effects_system(const Context& c) {
  BuiltSystem s = make_porous_benchmark(c.z.effect_cells, c.z.effect_cells, c.o.seed + 61);
  s.model.precision = sim::Precision::Single;
  s = equilibrated(c, s, c.z.effect_equilibrate, "effects system");
  EffectsSystem e;
  e.box = s.box;
  e.Lx = s.box.length(0);
  e.Ly = s.box.length(1);
  e.Lz = s.box.length(2);
  e.particles = s.particles;
  for (size_t i = 0; i < e.particles.size(); ++i) {
    if (e.particles.type[i] != 0) continue;  // wall stays 1
    const double z = e.particles.z[i] - e.box.lo[2];
    if (z >= 15.1 && z < 15.9)
      e.particles.type[i] = 2;
    else if (e.particles.x[i] - e.box.lo[0] >= 0.5 * e.Lx)
      e.particles.type[i] = 3;
  }
  return e;
}

sim::Model scene_model(const EffectsSystem& e, const Scene& sc, std::uint64_t seed) {
  sim::Model m;
  m.precision = sim::Precision::Single;
  m.seed = seed;
  m.rd = kRd;
  m.add_type({"left", false, {0, 0, 0}});
  m.add_type({"wall", true, {0, 0, 0}});
  m.add_type({"layer", false, {0, 0, 0}});
  m.add_type({"right", false, {0, 0, 0}});
  m.conservative = sc.mdpd ? sim::ConservativeKind::MDPD : sim::ConservativeKind::DPD;
  m.thermostat = sc.thermostat;
  const sim::PairSpec pair =
      sc.mdpd ? sim::PairSpec{-40, 25, kGamma} : sim::PairSpec{25, 0, kGamma};
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) m.set_pair(a, b, pair);
  if (sc.body_force)
    for (int t : {0, 2, 3}) m.types[static_cast<size_t>(t)].body_force = {0, 0, 0.02};
  if (sc.wall_model) {
    m.wall_model.enabled = true;
    m.wall_model.wall_types = 1u << 1;
    m.wall_model.wall_density = 8;
  }
  if (sc.virtual_wall > 0) {
    sim::VirtualWallSpec w;
    w.axis = 0;
    w.position = e.box.lo[0] + 0.5 * e.Lx;
    w.types = 1u << 0;
    w.keep_below = true;
    w.until_step = sc.virtual_wall == 1 ? std::numeric_limits<std::uint64_t>::max() : 1;
    m.virtual_walls.push_back(w);
  }
  if (sc.slab) m.rigid_slabs.push_back({2, 2, 0.0});
  if (sc.injection > 0) {
    sim::InjectionSpec q;
    q.inject_type = 0;
    q.eject_types = 1u << 3;
    // Across the box's top gap between rows of rings (z in [Lz - 1, Lz)): inlet left, outlet
    // right of the mid-plane.
    q.inlet_lo = {e.box.lo[0], e.box.lo[1], e.box.hi[2] - 1};
    q.inlet_hi = {e.box.lo[0] + 0.5 * e.Lx, e.box.hi[1], e.box.hi[2]};
    q.outlet_lo = {e.box.lo[0] + 0.5 * e.Lx, e.box.lo[1], e.box.hi[2] - 1};
    q.outlet_hi = {e.box.hi[0], e.box.hi[1], e.box.hi[2]};
    q.every = 5;
    q.per_event = 1;
    if (sc.injection == 2) q.start_step = std::uint64_t(1) << 50;
    m.injections.push_back(q);
  }
  return m;
}

// Runs `steps` of a scene the way a scene run samples its observables: chunks of 10 steps with
// the due observables after each; a scene without observables runs in one call.
void run_scene_steps(sim::Simulation& s, const Scene& sc, const EffectsSystem& e,
                     std::uint64_t steps) {
  const bool observed = sc.stress || sc.profile || sc.region_counts || sc.region_pressure;
  if (!observed && !sc.never_sampled) {
    s.run(steps);
    return;
  }
  constexpr std::uint64_t kEvery = 10;
  const sim::BinGrid profile = sim::BinGrid::profile(
      2, std::max(1, static_cast<int>(std::lround(2 * e.Lz))), e.box.lo, e.box.hi);
  sim::BinGrid region;
  region.lo = e.box.lo;
  region.hi = {e.box.lo[0] + 0.5 * e.Lx, e.box.hi[1], e.box.lo[2] + 0.5 * e.Lz};
  sim::RegionSelection selection;
  selection.lo = region.lo;
  selection.hi = region.hi;
  selection.type_mask = (1u << 0) | (1u << 3);
  double sink = 0;  // keeps the observables' results alive
  for (std::uint64_t done = 0; done < steps; done += kEvery) {
    s.run(std::min(kEvery, steps - done));
    if (sc.never_sampled) continue;
    if (sc.stress) sink += s.stress().pressure();
    if (sc.profile) sink += s.bin_sums(profile)[0];
    if (sc.region_counts)
      for (int t : {0, 3}) {
        region.type_mask = 1u << t;
        sink += s.bin_sums(region)[sim::kBinCount];
      }
    if (sc.region_pressure) sink += s.region_stress(selection).pressure();
  }
  if (!std::isfinite(sink)) throw Unstable("an observable is not finite");
}

constexpr int kEffectStretches = 3;

StudyResult run_effects(const Context& c) {
  StudyResult out;
  const auto t0 = Clock::now();
  const EffectsSystem e = make_effects_system(c);
  const std::vector<Scene> scenes = effect_scenes(c.z.bare_repeats);
  say(c, "effects on the porous benchmark (" + std::to_string(e.particles.size()) +
             " particles), " + std::to_string(scenes.size()) + " scenes");
  // Stretches of whole observable intervals (10 steps).
  const std::uint64_t stretch =
      std::max<std::uint64_t>(10, ((c.z.effect_steps / kEffectStretches + 9) / 10) * 10);
  out.parameters = {{"system", "porous benchmark, " + std::to_string(c.z.effect_cells) + " x " +
                                   std::to_string(c.z.effect_cells) + " cells"},
                    {"particles", e.particles.size()},
                    {"precision", "single"},
                    {"dt", 0.01},
                    {"equilibrate_steps", c.z.effect_equilibrate},
                    {"warm_steps", c.z.effect_warm},
                    {"timed_stretches", kEffectStretches},
                    {"steps_per_stretch", stretch},
                    {"bare_repeats", c.z.bare_repeats},
                    {"observable_interval", 10},
                    {"noise_criterion",
                     "within noise: ms/step <= bare mean + 2 standard deviations "
                     "of the repeated bare pass"}};
  struct Measured {
    const Scene* scene = nullptr;
    double ms = NAN, T = NAN;
    std::string pass;
    bool stable = true;
  };
  std::vector<Measured> measured;
  for (const Scene& sc : scenes) {
    Measured m;
    m.scene = &sc;
    try {
      auto s = sim::make_simulation(scene_model(e, sc, c.o.seed + 62), e.box, e.particles, 0.01,
                                    c.o.sim);
      m.pass = s->pass_name();
      run_scene_steps(*s, sc, e, c.z.effect_warm);
      // The fastest of a few timed stretches of the same run: a load spike on a shared machine
      // only ever adds time.
      for (int k = 0; k < kEffectStretches; ++k) {
        synchronise(*s);
        const auto t1 = Clock::now();
        run_scene_steps(*s, sc, e, stretch);
        synchronise(*s);
        const double ms = 1e3 * std::chrono::duration<double>(Clock::now() - t1).count() /
                          static_cast<double>(stretch);
        m.ms = k == 0 ? ms : std::min(m.ms, ms);
      }
      m.T = temperature_or_throw(*s, sc.name, kRunawayTemperature);
    } catch (const std::exception& u) {
      if (!is_instability(u)) throw;
      m.stable = false;
      say(c, std::string("unstable: ") + u.what());
    }
    say(c, sc.name + ": " + fmt(m.ms, 4) + " ms/step, T " + fmt(m.T, 4));
    measured.push_back(m);
  }
  // The noise of the bare pass.
  std::vector<double> bare;
  for (const auto& m : measured)
    if (m.scene->name == "bare" && std::isfinite(m.ms)) bare.push_back(m.ms);
  double mean = 0, ss = 0;
  for (double v : bare) mean += v;
  mean /= static_cast<double>(bare.size());
  for (double v : bare) ss += (v - mean) * (v - mean);
  const double sd = bare.size() > 1 ? std::sqrt(ss / static_cast<double>(bare.size() - 1)) : 0.0;
  double thermo = NAN;
  for (const auto& m : measured)
    if (m.scene->name == "thermostat") thermo = m.ms;
  const double n = static_cast<double>(e.particles.size());
  bool inactive_ok = true;
  int bare_index = 0;
  for (const auto& m : measured) {
    const Scene& sc = *m.scene;
    const double base = sc.base == "thermostat" ? thermo : mean;
    Json row;
    row["scene"] = sc.name;
    if (sc.name == "bare") row["scene"] = "bare#" + std::to_string(++bare_index);
    row["effect"] = sc.effect;
    row["active"] = sc.active;
    row["base"] = sc.base;
    row["pass"] = m.pass;
    row["stable"] = m.stable;
    row["ms_per_step"] = number_or_null(m.ms);
    row["mps"] = number_or_null(n / (m.ms * 1e-3) / 1e6);
    row["cost_vs_base"] = number_or_null(m.ms / base - 1);
    row["cost_vs_bare"] = number_or_null(m.ms / mean - 1);
    row["excess_in_bare_sd"] = number_or_null(sd > 0 ? (m.ms - mean) / sd : NAN);
    const bool within = std::isfinite(m.ms) && m.ms <= mean + 2 * sd;
    row["within_bare_noise"] = within;
    row["temperature_end"] = number_or_null(m.T);
    if (!sc.active && sc.name != "bare") inactive_ok = inactive_ok && within;
    out.rows.push_back(row);
  }
  out.summary = {{"bare_ms_per_step_mean", mean},
                 {"bare_ms_per_step_sd", sd},
                 {"bare_ms_per_step_min", *std::min_element(bare.begin(), bare.end())},
                 {"bare_ms_per_step_max", *std::max_element(bare.begin(), bare.end())},
                 {"bare_noise_relative", mean > 0 ? sd / mean : NAN},
                 {"bare_repeats", bare.size()},
                 {"inactive_scenes_within_noise", inactive_ok}};
  say(c, "bare pass " + fmt(mean, 4) + " +- " + fmt(sd, 2) + " ms/step over " +
             std::to_string(bare.size()) +
             " repeats; inactive scenes within noise: " + (inactive_ok ? "yes" : "no"));
  out.seconds = seconds_since(t0);
  return out;
}

// --------------------------------------------------------------------------------------------
// Provenance and output.

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        std::string v = line.substr(colon + 1);
        v.erase(0, v.find_first_not_of(' '));
        return v;
      }
    }
  return "unknown";
}

std::string device_description(const sim::SimulationOptions& so) {
  if (so.backend == sim::BackendKind::CPU) {
    const int threads = so.threads > 0 ? so.threads : omp_get_max_threads();
    return cpu_model() + " (" + std::to_string(std::thread::hardware_concurrency()) +
           " hardware threads), OpenMP threads: " + std::to_string(threads);
  }
#if defined(MESOROCK_HAVE_CUDA)
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, so.device) == cudaSuccess) {
    int driver = 0, runtime = 0;
    cudaDriverGetVersion(&driver);
    cudaRuntimeGetVersion(&runtime);
    std::ostringstream s;
    s << prop.name << " (" << std::setprecision(3)
      << static_cast<double>(prop.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0) << " GiB, compute "
      << prop.major << "." << prop.minor << ", CUDA driver " << driver / 1000 << "."
      << (driver % 1000) / 10 << ", runtime " << runtime / 1000 << "." << (runtime % 1000) / 10
      << "), host " << cpu_model();
    return s.str();
  }
#endif
  return "cuda device " + std::to_string(so.device);
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string csv_cell(const Json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return q + "\"";
  }
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_float()) {
    std::ostringstream s;
    s << std::setprecision(10) << v.get<double>();
    return s.str();
  }
  return v.dump();
}

std::string rows_to_csv(const Json& rows, const std::string& header) {
  std::ostringstream s;
  s << header;
  if (rows.empty()) return s.str();
  std::vector<std::string> keys;
  for (auto it = rows[0].begin(); it != rows[0].end(); ++it) keys.push_back(it.key());
  for (size_t k = 0; k < keys.size(); ++k) s << (k ? "," : "") << keys[k];
  s << "\n";
  for (const auto& row : rows) {
    for (size_t k = 0; k < keys.size(); ++k)
      s << (k ? "," : "") << (row.contains(keys[k]) ? csv_cell(row[keys[k]]) : "");
    s << "\n";
  }
  return s.str();
}

const char* describe(const std::string& study) {
  if (study == "timestep")
    return "time step vs error in temperature, pressure, viscosity and permeability, and cost";
  if (study == "precision") return "single vs double precision at dt = 0.01";
  if (study == "resolution")
    return "slit width in rc vs the permeability's error from H^2/12, and cost";
  if (study == "reorder") return "cell-list reorder interval, skin and cells per rc vs MPS/s";
  return "the cost of each effect alone over the bare conservative pass";
}

}  // namespace

const std::vector<std::string>& study_names() {
  static const std::vector<std::string> names{"timestep", "precision", "resolution", "reorder",
                                              "effects"};
  return names;
}

nlohmann::ordered_json run_study(const StudyOptions& o) {
  if (o.sim.comm && o.sim.comm->size() > 1)
    throw ConfigError("study: runs on one rank (start it without mpirun)");
  for (const auto& name : o.only)
    if (std::find(study_names().begin(), study_names().end(), name) == study_names().end())
      throw ConfigError("study: unknown study '" + name +
                        "' (timestep, precision, resolution, reorder, effects)");
  auto wanted = [&](const std::string& name) {
    return o.only.empty() || std::find(o.only.begin(), o.only.end(), name) != o.only.end();
  };
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec || !std::filesystem::is_directory(o.out_dir))
    throw IoError(o.out_dir.string() + ": cannot create the output folder");

  Context c;
  c.o = o;
  c.o.sim.comm.reset();
  c.z = sizes_for(o.size);
  c.vo.sim = c.o.sim;
  c.vo.verbose = false;
  c.vo.size = o.size == StudySize::Full ? CaseSize::Full : CaseSize::Small;
  const auto t0 = Clock::now();
  const std::string started = utc_now();

  Json doc;
  doc["tool"] = "rockflow study";
  doc["mesorock_version"] = kVersion;
  doc["git_commit"] = kGitCommit;
  doc["date"] = started;
  doc["host"] = host_name();
  doc["backend"] = sim::to_string(c.o.sim.backend);
  doc["threads"] = c.o.sim.backend == sim::BackendKind::CPU
                       ? (c.o.sim.threads > 0 ? c.o.sim.threads : omp_get_max_threads())
                       : 0;
  doc["device"] = device_description(c.o.sim);
  doc["size"] = size_name(o.size);
  doc["seed"] = o.seed;
  doc["command"] = o.command_line;
  doc["units"] = "reduced: rc = m = kBT = 1, time unit tau = rc sqrt(m / kBT)";
  doc["studies"] = Json::object();

  std::map<std::string, StudyResult> results;
  if (wanted("timestep") || wanted("precision"))
    run_timestep_and_precision(c, wanted("timestep"), wanted("precision"), results["timestep"],
                               results["precision"]);
  if (!wanted("timestep")) results.erase("timestep");
  if (!wanted("precision")) results.erase("precision");
  if (wanted("resolution")) results["resolution"] = run_resolution(c);
  if (wanted("reorder")) results["reorder"] = run_reorder(c);
  if (wanted("effects")) results["effects"] = run_effects(c);

  // CSVs first, study.json last: a folder with study.json is complete.
  const std::string header = "# mesorock " + std::string(kVersion) + " (" + kGitCommit +
                             "), rockflow study, " + started + ", " +
                             doc["device"].get<std::string>() + "\n";
  for (const auto& name : study_names()) {
    auto it = results.find(name);
    if (it == results.end()) continue;
    const std::string csv = name + ".csv";
    write_text_atomically(o.out_dir / csv,
                          rows_to_csv(it->second.rows, header + "# " + describe(name) + "\n"));
    Json j;
    j["description"] = describe(name);
    j["seconds"] = it->second.seconds;
    j["csv"] = csv;
    j["parameters"] = it->second.parameters;
    if (!it->second.summary.empty()) j["summary"] = it->second.summary;
    j["rows"] = it->second.rows;
    doc["studies"][name] = j;
  }
  doc["seconds"] = seconds_since(t0);
  write_text_atomically(o.out_dir / "study.json", doc.dump(1) + "\n");
  say(c, "wrote " + (o.out_dir / "study.json").string() + " (" + fmt(seconds_since(t0), 4) +
             " s in all)");
  return doc;
}

StudyCommand add_study_command(CLI::App& rockflow, std::string& backend, int& threads) {
  struct Args {
    std::string size = "small", out, only;
    std::uint64_t seed = 1;
    std::string command;
  };
  auto a = std::make_shared<Args>();
  CLI::App* app = rockflow.add_subcommand(
      "study",
      "what accuracy costs: error against time for the time step, precision, resolution, "
      "cell-list settings and each effect (docs/accuracy.md)");
  app->add_option("--size", a->size, "tiny (smoke test), small (CPU minutes) or full (GPU)")
      ->check(CLI::IsMember({"tiny", "small", "full"}))
      ->capture_default_str();
  app->add_option("--out", a->out, "output folder (study.json and one CSV per study)")->required();
  app->add_option("--only", a->only,
                  "comma-separated studies: timestep,precision,resolution,reorder,effects");
  app->add_option("--seed", a->seed, "seed of every random choice")->capture_default_str();
  app->add_option("--backend", backend, "cpu or cuda");
  app->add_option("--threads", threads, "CPU threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  StudyCommand cmd;
  cmd.app = app;
  cmd.run = [a](const sim::SimulationOptions& so) {
    StudyOptions o;
    o.size = a->size == "tiny" ? StudySize::Tiny
                               : (a->size == "full" ? StudySize::Full : StudySize::Small);
    o.sim = so;
    o.out_dir = a->out;
    o.seed = a->seed;
    std::stringstream list(a->only);
    for (std::string item; std::getline(list, item, ',');)
      if (!item.empty()) o.only.push_back(item);
    o.command_line = "rockflow study --size " + a->size + " --out " + a->out + " --backend " +
                     sim::to_string(so.backend) +
                     (so.threads > 0 ? " --threads " + std::to_string(so.threads) : "") +
                     (a->only.empty() ? "" : " --only " + a->only) + " --seed " +
                     std::to_string(a->seed);
    run_study(o);
    return static_cast<int>(kExitOk);
  };
  return cmd;
}

}  // namespace mesorock::pipeline
