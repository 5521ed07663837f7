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

// Slip length of the frozen-liquid wall (poiseuille-walls, full size): the no-slip surface lies
// |b| inside the fluid.
constexpr double kSlipLength = -0.069, kSlipLengthError = 0.010;
constexpr double kWallThickness = 1.5;  // as in poiseuille-walls: more than rc of frozen liquid

// The two-liquid cases' cross repulsion (relperm-slit, laplace-cylinder, capillary-slit): W and N
// immiscible, gamma_WN = 6.79 at coexistence with vacuum (interfacial-tension) and 10.0 at the
// liquid's density 7 (laplace-cylinder). relperm-slit says why not the stronger -20.
constexpr double kAWN = -30;

// Adds N, a second liquid that differs from type 0 (W) only by the cross repulsion A_WN, and, when
// wall_type >= 0, meets that wall with A_SN; returns N's type.
int add_second_liquid(sim::Model& model, double A_WN, int wall_type = -1, double A_SN = 0);

// Depth below the pore surface (> 0 inside the solid, <= 0 in the pore) of a point.
using SolidDepth = std::function<double(double x, double y, double z)>;

// Equilibrates the liquid in a periodic box, then keeps particles in the pore (depth <= 0) as
// fluid and those with 0 < depth <= thickness as frozen wall; deeper ones are dropped. Types:
// 0 fluid, 1 wall; every pair has the liquid's parameters; the wall model is on.
BuiltSystem liquid_with_walls(const double L[3], const std::array<bool, 3>& periodic,
                              const SolidDepth& depth, double thickness, std::uint64_t equilibrate,
                              std::uint64_t seed, const ValidateOptions& o);

// The slit of the permeability and two-phase cases: a gap of cut width h between the faces of
// one periodic slab of frozen liquid (z periodic; the wall kWallThickness thick: z < w/2 and
// z > h + w/2), Lxy wide along x and y (liquid_with_walls, 500 steps of equilibration).
struct Slit {
  BuiltSystem system;
  double L[3] = {0, 0, 0};
  double z0 = 0, z1 = 0;    // the cut surfaces
  double h = 0, h_eff = 0;  // cut and hydrodynamic widths (h + 2 kSlipLength)
  // The body force of a peak shear rate n g h_eff / (2 mu) = 0.2 at the walls (Newtonian:
  // docs/validation.md).
  double newtonian_force() const { return 0.2 * 2 * kBulkViscosity / (kRho * h_eff); }
  // Adds the no-slip plane Poiseuille profile of force g to the fluid (type 0), so that no viscous
  // start-up time (h^2 / nu) is needed.
  void start_on_profile(double g);
};
Slit make_slit(double h, double Lxy, std::uint64_t seed, const ValidateOptions& o);

// The pistons of the flooding cases (flooding-mini, drainage-slit): a pushing slab in
// [-slab, 0) and a back-pressure slab in [Lliq, Lliq + slab) along x, both of density 8 (the
// papers' wall density), about the liquid filling [0, Lliq); the box becomes reflective along x
// with `room` free behind the back slab (and 0.5 rc behind the pushing one). Each slab type meets
// every other type as the liquid does and exerts nothing on itself (a rigid body). P > 0 pushes
// towards +x: the pushing slab at push_pressure, the back slab at -back_pressure.
struct Pistons {
  int push = -1, back = -1;  // types; Model::rigid_slabs 0 and 1
};
Pistons add_pistons(BuiltSystem& s, double Lliq, double slab, double room, double push_pressure,
                    double back_pressure);

}  // namespace mesorock::pipeline::wall_liquid
