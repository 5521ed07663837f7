#pragma once
// What the permeability layout assumes of a rock image in the Stokes regime (micro-CT voxels of
// micrometres, many rc: no adsorbed layers, no slip on the grains) so that rockflow sweep's k is
// the continuum k of the same voxels (rockflow lbm):
//
// 1. The no-slip plane on the voxel faces. An attractive wall (fluid-wall A = -40 against wall
//    tiles of density 8) holds a layer of fluid still: in a flat slit packed by rockprep (4 rc
//    gap, 0.5 rc voxels) the velocity profile's zeros sat 0.19 rc inside the pore, and k was 24%
//    below h^2/12. The fluid-wall A sets that offset (the dissipation does not: gamma_FW = 1 moved
//    it by 0.05 rc): -30 gave 0.13 rc, -20 0.05 rc, -15 -0.03 rc, -10 -0.07 rc (docs/walls.md,
//    "Where the no-slip plane lies"). kNoSlipWallA is where it crosses zero. Flooding set-ups
//    keep their wetting values (-30, -40): there the wall affinity is the contact angle.
// 2. Resolved throats: the resolution study on real rock (docs/accuracy.md, "Resolution on real
//    rock") compared rockflow sweep with rockflow lbm --refine 2 on Berea and Leopard crops. The
//    error follows the critical pore diameter along the flow axis (the largest sphere that
//    passes through, voxel::critical_pore_diameter), not the median pore size: -24% at 2.0 rc,
//    -10% at 2.24 rc, -3.5% at 2.83 rc, +3.8% at 3.0 rc against refine 2. Refine 2 is 12-14%
//    above the converged k (docs/lbm.md, the ladder): against it the same sweeps read about
//    +11% at resolved scales (Berea 50^3: +10% at 2.83 rc, +12% at 5.7 rc), so this rule, fitted
//    to refine 2, is still to be re-derived (issue 52). rockprep run reports the diameter in rc,
//    warns below kResolvedThroatRc, and, with no length scale given, picks the rc per voxel that
//    reaches it (at least 0.5).
#include <algorithm>
#include <array>
#include <cmath>

namespace mesorock::pipeline::prep {

// The fluid-wall A of the permeability layout's default walls (both wall types).
constexpr double kNoSlipWallA = -18.0;

// The critical pore diameter in rc from which on the study's errors were within 10% (2.83 rc
// gave -3.5%; 2.24 rc gave -10% +- 8%, on the edge).
constexpr double kResolvedThroatRc = 2.8;
// The auto resolution's bounds: finer than 0.5 rc per voxel costs particles without need;
// coarser than 2 rc per voxel (8x the particles of 1) is better cropped smaller.
constexpr double kMinAutoRcPerVoxel = 0.5, kMaxAutoRcPerVoxel = 2.0;

// The rc per voxel that makes a critical pore diameter of `critical_voxels` voxels reach
// kResolvedThroatRc, rounded up to a multiple of 0.05, within the bounds above.
inline double auto_rc_per_voxel(double critical_voxels) {
  if (!(critical_voxels > 0)) return kMaxAutoRcPerVoxel;
  const double want = std::ceil(kResolvedThroatRc / critical_voxels / 0.05 - 1e-9) * 0.05;
  return std::clamp(want, kMinAutoRcPerVoxel, kMaxAutoRcPerVoxel);
}

// The body forces rockprep suggests for rockflow sweep. The resolution study's forces (0.16 at
// a median pore of 3.79 rc, 0.0711 at 5.68, 0.04 at 7.57, 0.0278 at 9.09, 0.0156 at 12.1, 0.01 at
// 15.1) kept g d^2 = 2.29 for the median pore d, so that the pores' velocities, and the flux's
// signal over its thermal noise, stayed alike; each gave k within 3.5% of the LBM
// (docs/accuracy.md). The suggestion: that force and 3/4, 1/2, 1/4 of it.
constexpr double kSweepForceTimesPore2 = 2.29;
inline std::array<double, 4> suggested_sweep_forces(double median_pore_rc) {
  const double top = kSweepForceTimesPore2 / (median_pore_rc * median_pore_rc);
  return {top / 4, top / 2, 3 * top / 4, top};
}

}  // namespace mesorock::pipeline::prep
