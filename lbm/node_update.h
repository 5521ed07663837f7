#pragma once
// The one lattice-node body of the lattice Boltzmann reference, run by the CPU loop (solver.cpp)
// and the CUDA kernel (cuda/steps_cuda.cu) alike.
//
// One fused pull-stream-collide update of node n (lattice units: dt = 1, rho0 = 1,
// c_s^2 = 1/3), D3Q19 TRT with the Stokes (linear) equilibrium:
//   pull:    f_q(x) = f_q(x - c_q) from the link table, or f_qbar(x) where that node is solid
//            (halfway bounce-back);
//   moments: drho = sum_q g_q, j = sum_q g_q c_q + F / 2 (Guo; j is the fluid velocity);
//   f+- = (f_q +- f_qbar) / 2, e+ = w_q rho, e- = 3 w_q c_q . j;
//   f+* = f+ - omega+ (f+ - e+), f-* = f- - omega- (f- - e-) + (1 - omega-/2) 3 w_q c_q . F.
// Populations are stored as deviations from rest, g_q = f_q - w_q (so e+ becomes w_q drho): in
// single precision the flow's small deviations then keep their digits instead of sitting
// beside a rest value of order 1. The update is linear in g, so the steady state does not depend
// on the force's size except through rounding.
#include <cstdint>

#include "lbm/d3q19.h"
#include "sim/hd.h"

namespace mesorock::lbm {

// What a step needs besides the arrays (filled on the host, passed by value to the kernel).
template <class Real>
struct StepParams {
  std::uint64_t nodes = 0;      // N: populations are stored [q * N + n]
  Real omega_plus = 1;          // 1 / tau+
  Real omega_minus = 1;         // 1 / tau-
  Real half_force[3] = {};      // F / 2 along the flow axis, 0 on the others
  Real source[kHalf + 1] = {};  // (1 - omega-/2) 3 w_q c_q . F for q = 1..9 (q + 9 takes minus)
};

// The moments of one node at the time of its pulled populations.
template <class Real>
struct NodeMoments {
  Real drho = 0;
  Real j[3] = {};  // fluid velocity (rho0 = 1), the force's half included
};

// The moments of a node's populations f (deviations from rest), and the pair differences
// d_q = f_q - f_{q+9} (c_{q+9} = -c_q) the collision reuses, written out for the velocities of
// kC (d3q19.h checks the order): loops over kC are not folded by the compiler and ran at half
// the speed.
template <class Real>
MESO_HD MESO_INLINE NodeMoments<Real> moments_of(const Real (&f)[kQ], const StepParams<Real>& p,
                                                 Real (&d)[kHalf + 1]) {
  NodeMoments<Real> m;
  m.drho = f[0];
  d[0] = 0;
  MESO_UNROLL
  for (int q = 1; q <= kHalf; ++q) {
    d[q] = f[q] - f[q + kHalf];
    m.drho += f[q] + f[q + kHalf];
  }
  m.j[0] = d[1] + d[4] + d[5] + d[6] + d[7] + p.half_force[0];
  m.j[1] = d[2] + d[4] - d[5] + d[8] + d[9] + p.half_force[1];
  m.j[2] = d[3] + d[6] - d[7] + d[8] - d[9] + p.half_force[2];
  return m;
}

template <class Real>
MESO_HD MESO_INLINE NodeMoments<Real> update_node(std::uint64_t n, const std::uint32_t* src,
                                                  const Real* from, Real* to,
                                                  const StepParams<Real>& p) {
  const std::uint64_t N = p.nodes;
  Real f[kQ];
  f[0] = from[n];
  MESO_UNROLL
  for (int q = 1; q < kQ; ++q) {
    const std::uint32_t m = src[static_cast<std::uint64_t>(q - 1) * N + n];
    f[q] = m != kWall ? from[static_cast<std::uint64_t>(q) * N + m]
                      : from[static_cast<std::uint64_t>(opposite(q)) * N + n];
  }
  Real d[kHalf + 1];
  const NodeMoments<Real> m = moments_of(f, p, d);
  const Real w0 = Real(weight(0));
  to[n] = f[0] - p.omega_plus * (f[0] - w0 * m.drho);
  const Real cj[kHalf + 1] = {Real(0),         m.j[0],          m.j[1],          m.j[2],
                              m.j[0] + m.j[1], m.j[0] - m.j[1], m.j[0] + m.j[2], m.j[0] - m.j[2],
                              m.j[1] + m.j[2], m.j[1] - m.j[2]};  // c_q . j
  MESO_UNROLL
  for (int q = 1; q <= kHalf; ++q) {
    const Real w = Real(weight(q));
    const Real plus = Real(0.5) * (f[q] + f[q + kHalf]), minus = Real(0.5) * d[q];
    const Real new_plus = plus - p.omega_plus * (plus - w * m.drho);
    const Real new_minus = minus - p.omega_minus * (minus - 3 * w * cj[q]) + p.source[q];
    to[static_cast<std::uint64_t>(q) * N + n] = new_plus + new_minus;
    to[static_cast<std::uint64_t>(q + kHalf) * N + n] = new_plus - new_minus;
  }
  return m;
}

// The moments of node n's stored populations g (for the flow a finer lattice starts from).
template <class Real>
MESO_HD MESO_INLINE NodeMoments<Real> node_moments(std::uint64_t n, const Real* g,
                                                   const StepParams<Real>& p) {
  Real f[kQ];
  MESO_UNROLL
  for (int q = 0; q < kQ; ++q) f[q] = g[static_cast<std::uint64_t>(q) * p.nodes + n];
  Real d[kHalf + 1];
  return moments_of(f, p, d);
}

}  // namespace mesorock::lbm
