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
// 2. A resolved pore size: the resolution study on real rock (docs/accuracy.md, "Resolution on
//    real rock") measured the error of rockflow sweep against rockflow lbm at 0.5, 0.75 and 1.0
//    rc per voxel. rockprep run reports the pore sizes in rc, warns below this size, and picks
//    the rc per voxel that reaches it when no length scale is given.
#include <algorithm>
#include <cmath>

namespace mesorock::pipeline::prep {

// The fluid-wall A of the permeability layout's default walls (both wall types).
constexpr double kNoSlipWallA = -18.0;

// The volume-weighted median local thickness (the diameter of the largest sphere that fits, by
// pore volume: the pores that carry the flow) in rc above which the study's error stays within
// 10%.
constexpr double kResolvedPoreDiameterRc = 5.0;
// The auto resolution's bounds: finer than 0.5 rc per voxel costs particles without need;
// coarser than 2 rc per voxel (8x the particles of 1) is better cropped smaller.
constexpr double kMinAutoRcPerVoxel = 0.5, kMaxAutoRcPerVoxel = 2.0;

// The rc per voxel that makes a median pore diameter of `median_voxels` voxels reach
// kResolvedPoreDiameterRc, rounded up to a multiple of 0.05, within the bounds above.
inline double auto_rc_per_voxel(double median_voxels) {
  if (!(median_voxels > 0)) return kMaxAutoRcPerVoxel;
  const double want = std::ceil(kResolvedPoreDiameterRc / median_voxels / 0.05 - 1e-9) * 0.05;
  return std::clamp(want, kMinAutoRcPerVoxel, kMaxAutoRcPerVoxel);
}

}  // namespace mesorock::pipeline::prep
