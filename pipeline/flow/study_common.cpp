#include "pipeline/flow/study_common.h"

#include <algorithm>
#include <cmath>
#include <iostream>

#include "mesorock/errors.h"
#include "pipeline/flow/statistics.h"
#include "sim/observables.h"

namespace mesorock::pipeline::study_detail {

bool is_instability(const std::exception& e) {
  return dynamic_cast<const Unstable*>(&e) != nullptr ||
         dynamic_cast<const NumericalError*>(&e) != nullptr;
}

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

void say(const Context& c, const std::string& line) {
  if (c.o.verbose) std::cerr << "study: " << line << std::endl;
}

std::uint64_t steps_for(double tau, double dt) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(tau / dt)));
}

std::uint64_t sample_every(double dt) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(0.1 / dt)));
}

double temperature_or_throw(sim::Simulation& s, const std::string& what, double max_T) {
  const double T = s.kinetic_temperature();
  if (!(std::isfinite(T) && T > 0 && T < max_T))
    throw Unstable(what + ": kinetic temperature " + fmt(T, 4) + " at step " +
                   std::to_string(s.step()));
  return T;
}

void run_checked(sim::Simulation& s, std::uint64_t steps, const std::string& what, double max_T) {
  const std::uint64_t chunk = steps_for(1.0, s.dt());
  for (std::uint64_t done = 0; done < steps;) {
    const std::uint64_t k = std::min(chunk, steps - done);
    s.run(k);
    done += k;
    temperature_or_throw(s, what, max_T);
  }
}

void synchronise(sim::Simulation& s) {
  sim::BinGrid none;
  none.lo = s.box().lo;
  none.hi = s.box().hi;
  none.type_mask = 0;
  (void)s.bin_sums(none);
}

double timed_mps(sim::Simulation& s, std::uint64_t steps, const std::string& what, double max_T) {
  synchronise(s);
  const auto t0 = Clock::now();
  s.run(steps);
  synchronise(s);
  const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
  temperature_or_throw(s, what, max_T);
  return static_cast<double>(s.size()) * static_cast<double>(steps) / sec / 1e6;
}

double ns_per_particle_tau(double mps, double dt) {
  return mps > 0 ? 1e3 / (mps * dt) : NAN;
}

Json number_or_null(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

BuiltSystem equilibrated(const Context& c, BuiltSystem s, std::uint64_t steps,
                         const std::string& what) {
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, c.o.sim);
  run_checked(*sim, steps, what, kAnyTemperature);
  s.particles = sim->particles();
  return s;
}

}  // namespace mesorock::pipeline::study_detail
