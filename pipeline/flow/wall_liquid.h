#pragma once
// The frozen-liquid walls of the wall validation cases (validation_walls.cpp) and the
// permeability cases (validation_permeability.cpp): the A = -40, B = 25, rd = 0.75, gamma = 4.5,
// rho = 7 liquid, and a builder that freezes it inside a solid of any shape.
#include <array>
#include <cstdint>
#include <functional>

#include "pipeline/flow/systems.h"
#include "pipeline/flow/validation.h"

namespace mesorock::pipeline::wall_liquid {

// The liquid: A = -40, B = 25, rd = 0.75, gamma = 4.5, number density 7.
constexpr double kA = -40, kB = 25, kRd = 0.75, kGamma = 4.5, kRho = 7.0;

// Its shear viscosity from the `viscosity` case at full size (H100, 2026-11-23,
// docs/validation.md): pooled over three forcings, 6.97 +- 0.057.
constexpr double kBulkViscosity = 6.97, kBulkViscosityError = 0.057;

// Depth below the pore surface (> 0 inside the solid, <= 0 in the pore) of a point.
using SolidDepth = std::function<double(double x, double y, double z)>;

// Equilibrates the liquid in a periodic box, then keeps particles in the pore (depth <= 0) as
// fluid and those with 0 < depth <= thickness as frozen wall; deeper ones are dropped. Types:
// 0 fluid, 1 wall; every pair has the liquid's parameters; the wall model is on.
BuiltSystem liquid_with_walls(const double L[3], const std::array<bool, 3>& periodic,
                              const SolidDepth& depth, double thickness, std::uint64_t equilibrate,
                              std::uint64_t seed, const ValidateOptions& o);

}  // namespace mesorock::pipeline::wall_liquid
