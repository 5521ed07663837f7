#pragma once
// Systems built in code for validation cases and benchmarks (no scene file needed).
#include <cstdint>

#include "sim/model.h"

namespace mesorock::pipeline {

struct BuiltSystem {
  sim::Model model;
  sim::BoxSpec box;
  sim::ParticleSet particles;
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

}  // namespace mesorock::pipeline
