#pragma once
// Systems built in code for validation cases and benchmarks (no scene file needed).
#include <cstdint>

#include "sim/model.h"

namespace mesorock::pipeline {

struct BuiltSystem {
  sim::Model model;
  sim::BoxSpec box;
  sim::ParticleSet particles;
  // Steps to run at relax_dt before the system is used at its own time step (0: none), as
  // rockprep's scenes relax their packing first.
  std::uint64_t relax_steps = 0;
  double relax_dt = 0.002;
};

// One mobile type in a periodic cube of edge L at number density rho, random positions,
// Maxwell velocities at kBT = 1.
// mDPD: F = A (1 - r) + B (rho_i + rho_j) (1 - r/rd); DPD: F = a (1 - r), a = A.
BuiltSystem make_bulk_mdpd(double A, double B, double rd, double gamma, double rho,
                           const double L[3], std::uint64_t seed, sim::DensityKernelKind kernel);
BuiltSystem make_bulk_dpd(double a, double gamma, double rho, const double L[3],
                          std::uint64_t seed);

// The 2020 paper's homogeneous porous benchmark (docs/physics.md): cells of 16 x 2 x 16 rc, each
// with a cylinder along y whose solid core (radius 7) is represented by a ring of frozen wall
// particles (6 < r < 7, density 8) and fluid (density 6.2) outside the cylinder; cells tiled nx x
// nz in x-z, odd rows (in z) shifted by Lx/2; A = -40 for all pairs, B = 25, rd = 0.75, gamma
// = 4.5, g_z = 0.02 on the fluid, periodic. Returns about 1962 particles per cell.
BuiltSystem make_porous_benchmark(int nx, int nz, std::uint64_t seed);

// A real-rock scene for the benchmarks, from a segmented image (rockprep's solid.h5) at its
// voxel size: the image is extended by mirror copies to a periodic cube of about `particles`
// particles, as rockprep's permeability layout packs a sample: fluid (density 6.5, random) in
// the pore voxels, frozen wall particles (density 8, a simple cubic lattice) in the solid voxels
// within 1 rc of the pore (whole voxels along each axis, as rockprep's wall sweep), the grain
// interiors empty and kept out of by the solid grid; the wall model of Li et al. 2018 on; B = 25,
// rd = 0.75, gamma = 4.5, A = -40 within each type and -18 between fluid and wall (rockprep's
// defaults), g_x = 0.02 on the fluid; Maxwell velocities at kBT = 1. relax_steps = 100 at dt =
// 0.002 (rockprep's scenes relax so): the random fluid next to the wall runs away at dt = 0.01.
// Even so the scene ran away after 115-1,227 steps in 8 of 12 runs of 1,500-3,000 steps
// (docs/benchmarks.md; cause not found): a scene for short timing runs.
BuiltSystem make_rock_benchmark(const sim::SolidMask& image, std::int64_t particles,
                                std::uint64_t seed);

}  // namespace mesorock::pipeline
