#pragma once
// The accuracy systems of `rockflow study` that the resolution study shares: a system brought to
// its steady state, and the slit's permeability (study_accuracy.cpp).
#include <cmath>
#include <cstdint>
#include <string>

#include "pipeline/flow/study_common.h"

namespace mesorock::pipeline::study_detail {

struct Prepared {
  BuiltSystem s;
  std::size_t fluid = 0;  // mobile particles
  double g = 0;           // body force per particle (viscosity, slit)
  double width = 0;       // slit: distance between the cut planes
  double wall = 0;        // slit: wall thickness (cut plane at z = wall and Lz - wall)
  double fluid_density = 0;
};

// A slit of width H between walls of frozen liquid 1.5 rc thick (liquid_with_walls, wall model
// on), periodic in x and y, driven along x by a body force for a peak shear rate `rate` at the
// walls, started from the no-slip Stokes profile.
Prepared prepare_slit(const Context& c, double H, double lxy, double rate, std::uint64_t seed);

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
                        double eq_tau, double sample_tau, const std::string& what);

}  // namespace mesorock::pipeline::study_detail
