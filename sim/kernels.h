#pragma once
// The kernel bodies of one step, shared by the CPU backend (an OpenMP loop over particles) and
// the CUDA backend (one thread per particle). Each body handles one particle and writes only that
// particle's outputs, so neither backend needs atomics.
//
// Step (velocity Verlet, DPD variant of Groot & Warren 1997 with lambda; the 2020 paper's
// Algorithm 1):
//   kick_drift:  v <- v + dt/2 f;  v~ <- v_old + lambda dt f;  x <- x + dt v;  boundaries
//   density:     rho_i = sum_j w(r_ij)            (only with a many-body term)
//   forces:      f_i = sum_j F_ij(x, v~, rho) + g_type
//   kick:        v <- v + dt/2 f
// lambda = 0.5 makes v~ the half-step velocity: plain velocity Verlet.
#include <cstdint>

#include "sim/box.h"
#include "sim/cell_grid.h"
#include "sim/hd.h"
#include "sim/observables.h"
#include "sim/pair_terms.h"
#include "sim/rng.h"

namespace mesorock::sim {

// Everything a pass reads or writes, as raw pointers: valid for host or device memory alike.
template <class Real>
struct StepView {
  int n = 0;
  Real *x = nullptr, *y = nullptr, *z = nullptr;
  Real *vx = nullptr, *vy = nullptr, *vz = nullptr;
  // Velocity estimate v~ for the dissipative force; absent (null) without a thermostat.
  Real *vex = nullptr, *vey = nullptr, *vez = nullptr;
  Real *fx = nullptr, *fy = nullptr, *fz = nullptr;
  Real* rho = nullptr;
  const std::int32_t* type = nullptr;
  const std::int64_t* id = nullptr;

  // Cell list: particles are stored sorted by cell; cell c holds [cell_start[c], cell_start[c+1]).
  const int* cell_start = nullptr;

  Box<Real> box;
  CellGrid<Real> grid;

  const PairParams<Real>* table = nullptr;  // ntypes x ntypes, symmetric
  int ntypes = 0;
  const Real* body_force = nullptr;  // ntypes x 3
  int body_force_axis = 2;           // profile axis of a position-dependent body force
  Real body_force_midplane = 0;      // its sign changes here (ReversedBodyForce)
  std::uint32_t frozen_mask = 0;     // bit t set: type t never moves

  Real rd = Real(0.75);
  Real dt = Real(0.01);
  Real inv_sqrt_dt = Real(10);
  Real lambda = Real(0.5);
  std::uint64_t seed = 0;
  std::uint64_t step = 0;  // the step whose forces are being computed (keys the pair RNG)

  MESO_HD bool frozen(int i) const { return (frozen_mask >> type[i]) & 1u; }
};

// Calls visit(j, dx, dy, dz, r2) for every particle j != i within the cutoff rc = 1.
// Periodic images come from per-cell shifts (no per-pair branch) except on axes with fewer than 3
// cells, where minimum_image decides per pair. Either way dx_ij = -dx_ji exactly.
template <class Real, class Visit>
MESO_HD MESO_INLINE void for_each_neighbour(const StepView<Real>& v, int i, Visit&& visit) {
  const Real xi = v.x[i], yi = v.y[i], zi = v.z[i];
  const int cx = v.grid.coordinate(xi, v.box.lo[0], 0);
  const int cy = v.grid.coordinate(yi, v.box.lo[1], 1);
  const int cz = v.grid.coordinate(zi, v.box.lo[2], 2);
  int nx[3], ny[3], nz[3];
  Real sx[3], sy[3], sz[3];
  bool mx, my, mz;
  const int kx = v.grid.axis_neighbours(cx, 0, v.box.periodic[0], v.box.length[0], nx, sx, mx);
  const int ky = v.grid.axis_neighbours(cy, 1, v.box.periodic[1], v.box.length[1], ny, sy, my);
  const int kz = v.grid.axis_neighbours(cz, 2, v.box.periodic[2], v.box.length[2], nz, sz, mz);
  for (int c = 0; c < kz; ++c) {
    for (int b = 0; b < ky; ++b) {
      // Cells along x are contiguous in the cell index, and so are their particles: one run
      // per (y, z) row unless x wraps around.
      for (int a = 0; a < kx; ++a) {
        const int cell = v.grid.index(nx[a], ny[b], nz[c]);
        const int end = v.cell_start[cell + 1];
        for (int j = v.cell_start[cell]; j < end; ++j) {
          if (j == i) continue;
          Real dx = (xi - v.x[j]) - sx[a];
          Real dy = (yi - v.y[j]) - sy[b];
          Real dz = (zi - v.z[j]) - sz[c];
          if (mx) dx = v.box.minimum_image(dx, 0);
          if (my) dy = v.box.minimum_image(dy, 1);
          if (mz) dz = v.box.minimum_image(dz, 2);
          const Real r2 = dx * dx + dy * dy + dz * dz;
          if (r2 < Real(1)) visit(j, dx, dy, dz, r2);
        }
      }
    }
  }
}

// Below this separation the pair direction is undefined: coincident particles exert no force on
// each other (finite, not NaN). The conservative force is bounded, so this loses nothing physical.
template <class Real>
MESO_HD MESO_INLINE constexpr Real coincident_r2() {
  return Real(1e-20);
}

// ---------------------------------------------------------------------------------------------
// Density pass: rho_i = sum_{j != i} w(r_ij). Frozen particles need it too (their rho enters the
// many-body force on the fluid).
template <class Real, class DensityKernel>
MESO_HD MESO_INLINE void density_of_particle(const StepView<Real>& v, int i) {
  Real rho = 0;
  const Real rd = v.rd;
  const Real rd2 = rd * rd;
  for_each_neighbour(v, i, [&](int, Real, Real, Real, Real r2) {
    if (r2 < rd2) rho += DensityKernel::weight(real_sqrt(r2), rd);
  });
  v.rho[i] = rho;
}

// Per-pair force split into its parts, for the force pass and the stress observable alike.
template <class Real>
struct PairForce {
  Real conservative = 0, dissipative = 0, random = 0;  // components along e_ij
  Real r = 0;
};

template <class Real, class Conservative, class Thermostat>
MESO_HD MESO_INLINE PairForce<Real> pair_force(const StepView<Real>& v, int i, int j, Real dx,
                                               Real dy, Real dz, Real r2) {
  PairForce<Real> f;
  if (r2 < coincident_r2<Real>()) return f;
  const Real r = real_sqrt(r2);
  f.r = r;
  const PairParams<Real>& p = v.table[v.type[i] * v.ntypes + v.type[j]];
  if constexpr (Conservative::enabled) {
    Real rho_i = 0, rho_j = 0;
    if constexpr (Conservative::needs_density) {
      rho_i = v.rho[i];
      rho_j = v.rho[j];
    }
    f.conservative = Conservative::magnitude(r, rho_i, rho_j, p, v.rd);
  }
  if constexpr (Thermostat::enabled) {
    const Real inv_r = Real(1) / r;
    const Real e_dot_v =
        (dx * (v.vex[i] - v.vex[j]) + dy * (v.vey[i] - v.vey[j]) + dz * (v.vez[i] - v.vez[j])) *
        inv_r;
    f.dissipative = Thermostat::dissipative(r, e_dot_v, p);
    const Real xi = pair_random<Real>(v.seed, v.step, static_cast<std::uint64_t>(v.id[i]),
                                      static_cast<std::uint64_t>(v.id[j]));
    f.random = Thermostat::random(r, xi, v.inv_sqrt_dt, p);
  }
  return f;
}

// Force pass for one particle: f_i = sum_j F_ij + g_type. Frozen particles get f = 0.
template <class Real, class Conservative, class Thermostat, class BodyForce>
MESO_HD MESO_INLINE void force_on_particle(const StepView<Real>& v, int i) {
  Real fx = 0, fy = 0, fz = 0;
  if (!v.frozen(i)) {
    for_each_neighbour(v, i, [&](int j, Real dx, Real dy, Real dz, Real r2) {
      const PairForce<Real> f = pair_force<Real, Conservative, Thermostat>(v, i, j, dx, dy, dz, r2);
      if (f.r == Real(0)) return;
      const Real s = (f.conservative + f.dissipative + f.random) / f.r;
      fx += s * dx;
      fy += s * dy;
      fz += s * dz;
    });
    if constexpr (BodyForce::enabled) {
      const Real* g = v.body_force + 3 * v.type[i];
      const Real* pos = v.body_force_axis == 0 ? v.x : (v.body_force_axis == 1 ? v.y : v.z);
      const Real s = BodyForce::sign(pos[i], v.body_force_midplane);
      fx += s * g[0];
      fy += s * g[1];
      fz += s * g[2];
    }
  }
  v.fx[i] = fx;
  v.fy[i] = fy;
  v.fz[i] = fz;
}

// ---------------------------------------------------------------------------------------------
// Integration.

// Reflective face: mirror the position back inside and reverse the normal velocity components
// (v~ too when the run keeps one).
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void apply_boundary(const StepView<Real>& v, int i, Real* pos, Real* vel,
                                        Real* vel_est, int axis) {
  const Real lo = v.box.lo[axis];
  const Real hi = lo + v.box.length[axis];
  Real p = pos[i];
  if (v.box.periodic[axis]) {
    if (p >= hi) p -= v.box.length[axis];
    if (p < lo) p += v.box.length[axis];
    // A particle that moved more than a box length per step is caught by the watchdog; keep the
    // position in range so the cell lookup stays valid until then.
    if (p >= hi || p < lo) p = lo;
  } else {
    if (p < lo) {
      p = lo + (lo - p);
      vel[i] = -vel[i];
      if constexpr (kVelocityEstimate) vel_est[i] = -vel_est[i];
    } else if (p >= hi) {
      p = hi - (p - hi);
      vel[i] = -vel[i];
      if constexpr (kVelocityEstimate) vel_est[i] = -vel_est[i];
    }
    if (p < lo || p >= hi) p = lo + Real(0.5) * v.box.length[axis];
  }
  pos[i] = p;
}

// First half: v~ = v + lambda dt f; v += dt/2 f; x += dt v; boundaries.
// v~ feeds only the dissipative force: without a thermostat (kVelocityEstimate false) it is
// neither computed nor stored.
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void kick_drift(const StepView<Real>& v, int i) {
  if (v.frozen(i)) return;
  const Real dt = v.dt;
  const Real half = Real(0.5) * dt;
  if constexpr (kVelocityEstimate) {
    const Real ld = v.lambda * dt;
    v.vex[i] = v.vx[i] + ld * v.fx[i];
    v.vey[i] = v.vy[i] + ld * v.fy[i];
    v.vez[i] = v.vz[i] + ld * v.fz[i];
  }
  v.vx[i] += half * v.fx[i];
  v.vy[i] += half * v.fy[i];
  v.vz[i] += half * v.fz[i];
  v.x[i] += dt * v.vx[i];
  v.y[i] += dt * v.vy[i];
  v.z[i] += dt * v.vz[i];
  apply_boundary<Real, kVelocityEstimate>(v, i, v.x, v.vx, v.vex, 0);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.y, v.vy, v.vey, 1);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.z, v.vz, v.vez, 2);
}

// Second half: v += dt/2 f(t + dt).
template <class Real>
MESO_HD MESO_INLINE void kick(const StepView<Real>& v, int i) {
  if (v.frozen(i)) return;
  const Real half = Real(0.5) * v.dt;
  v.vx[i] += half * v.fx[i];
  v.vy[i] += half * v.fy[i];
  v.vz[i] += half * v.fz[i];
}

// ---------------------------------------------------------------------------------------------
// Stress observable: per-particle half of the pair virial, split into conservative, dissipative
// and random parts: W_i^{ab} = 1/2 sum_j r_ij^a F_ij^b. Summed over i and divided by the volume
// it is the configurational stress; the kinetic part is added by the caller.
template <class Real>
struct ParticleVirial {
  Real conservative[6] = {0, 0, 0, 0, 0, 0};  // xx yy zz xy xz yz
  Real dissipative[6] = {0, 0, 0, 0, 0, 0};
  Real random[6] = {0, 0, 0, 0, 0, 0};
};

template <class Real, class Conservative, class Thermostat>
MESO_HD MESO_INLINE ParticleVirial<Real> virial_of_particle(const StepView<Real>& v, int i) {
  ParticleVirial<Real> w;
  for_each_neighbour(v, i, [&](int j, Real dx, Real dy, Real dz, Real r2) {
    // Frozen-frozen pairs exert no force that matters (neither moves) and are left out.
    if (v.frozen(i) && v.frozen(j)) return;
    const PairForce<Real> f = pair_force<Real, Conservative, Thermostat>(v, i, j, dx, dy, dz, r2);
    if (f.r == Real(0)) return;
    // r_ij^a F_ij^b = f d^a d^b / r with F_ij = f e and e = d / r; half to each particle.
    const Real rr[6] = {dx * dx, dy * dy, dz * dz, dx * dy, dx * dz, dy * dz};
    const Real h = Real(0.5) / f.r;
    for (int c = 0; c < 6; ++c) {
      w.conservative[c] += h * f.conservative * rr[c];
      w.dissipative[c] += h * f.dissipative * rr[c];
      w.random[c] += h * f.random * rr[c];
    }
  });
  return w;
}

// ---------------------------------------------------------------------------------------------
// Binned observables: the bin particle i adds to, or -1 when its type is not counted or it lies
// outside the grid.
template <class Real>
MESO_HD MESO_INLINE int bin_of_particle(const StepView<Real>& v, const BinView<Real>& b, int i) {
  if (!((b.type_mask >> v.type[i]) & 1u)) return -1;
  return b.bin_of(v.x[i], v.y[i], v.z[i]);
}

}  // namespace mesorock::sim
