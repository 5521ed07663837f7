#pragma once
// The geometry of the wall model (sim/wall_model.h, docs/walls.md) on curved walls: where its
// phi = 1/2 surface lies next to a solid ball and inside a tube. The permeability validation cases
// (pipeline/flow/validation_permeability.cpp) put their reference radii there.

namespace mesorock::sim {

// Where the wall model puts a curved wall's surface. The model reflects fluid particles whose
// boundary volume fraction phi (sim/wall_model.h: the Lucy kernel of support rc summed over wall
// particles, over the wall density) exceeds phi_c = 1/2, and tunes its no-slip dissipation by
// phi; at a flat wall thicker than rc phi = 1/2 exactly on the cut surface. On a curved wall of
// uniform density it is not: these give phi for a point at distance D from the centre of a solid
// ball of radius a (outside it: D > a), and at distance rho from the axis of a circular tube of
// radius R in solid (inside it: rho < R), as quadratures of the kernel over the solid.
double ball_boundary_fraction(double a, double D);
double tube_boundary_fraction(double R, double rho);
// The offset of the phi = phi_c surface from the cut surface, along the outward normal of the
// solid (> 0: the model's surface lies in the fluid, beyond the cut), found by bisection within
// +-0.5 rc. For a flat wall: 0.
double ball_surface_offset(double a, double phi_c = 0.5);
double tube_surface_offset(double R, double phi_c = 0.5);

}  // namespace mesorock::sim
