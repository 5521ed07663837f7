#pragma once
// Euclidean distance transform and local thickness (pore-size distribution) of the pore space of
// a phase-label volume, with anisotropic voxel spacing.
//
// Definitions (docs/voxel.md):
// * distance of a pore voxel: the Euclidean distance, in the spacing's unit, from its centre to
//   the centre of the nearest voxel of the volume that is not pore (solid or outside). The space
//   beyond the volume's faces is not a wall (as scipy.ndimage.distance_transform_edt treats it).
// * local thickness of a pore voxel q (Hildebrand and Ruegsegger 1997): the diameter 2R of the
//   largest sphere that contains q, is centred on a pore voxel c, and holds no voxel that is not
//   pore; R = distance(c), and the sphere holds the voxels q with |q - c| < R.
#include <cstdint>
#include <vector>

#include "voxel/volume.h"

namespace mesorock::voxel {

// Squared distances (float32 volume, spacing unit squared): 0 for voxels that are not pore,
// +infinity for pore voxels when the volume holds no voxel that is not pore. Separable exact EDT
// (Felzenszwalb and Huttenlocher 2012, lower envelope of parabolas), one pass per axis, lines in
// parallel. Memory: 4 bytes per voxel.
Volume squared_pore_distance(const Volume& labels);

// The critical pore diameter along volume axis `axis_zyx` (0 z, 1 y, 2 x): the largest sphere
// that can pass through the sample between its two faces normal to that axis, the diameter that
// controls permeability (Katz & Thompson 1986; what mercury intrusion measures). A sphere of
// diameter d fits with its centre on a pore voxel whose distance (squared_pore_distance) is at
// least d / 2; d passes when those voxels hold a 6-connected cluster touching both faces. The
// largest such d among the voxels' own 2 x distance values, by bisection; in the spacing's unit
// along x (an anisotropic spacing mixes units: the distance is Euclidean in the spacing's unit).
// 0 when no pore cluster spans the axis. Memory: the distance volume and one label volume.
double critical_pore_diameter(const Volume& labels, int axis_zyx);

struct LocalThicknessOptions {
  // Paint only the "ridge" spheres: a sphere that lies inside a neighbour's sphere (R' >= R +
  // |c' - c|) cannot raise any voxel's value and is skipped. Exact either way; off for tests.
  bool skip_contained_spheres = true;
};

// Local thickness (float32 volume of diameters in the spacing's unit; 0 for voxels that are not
// pore). Computes the squared distances, keeps the sphere centres, and paints the spheres into
// the same buffer (slabs of z in parallel, each task writing only its own slices; the maximum
// does not depend on the order, so the result is the same for any thread count). Memory: 4 bytes
// per voxel plus 16 bytes per ridge centre. Throws ConfigError when the volume holds no voxel that
// is not pore (no sphere is bounded).
Volume local_thickness(const Volume& labels, const LocalThicknessOptions& options = {});

// Pore volume distribution of local thickness.
struct SizeDistribution {
  std::vector<double> edges;            // bins + 1 edges, in the spacing's unit
  std::vector<std::int64_t> voxels;     // pore voxels per bin, bin i = [edges[i], edges[i+1])
  std::vector<double> volume_fraction;  // of the pore volume, per bin
  std::int64_t pore_voxels = 0;
  double mean = 0;    // volume-weighted mean thickness
  double median = 0;  // thickness below which half the pore volume lies (bin-interpolated)
  double max = 0;
};

// bins = 0: bin width = the smallest voxel spacing (the resolution of the thickness) and as many
// bins as hold the largest value, or 100 bins of max / 100 when that would give more. The last
// bin is closed (holds the maximum).
SizeDistribution size_distribution(const Volume& thickness, const Volume& labels, int bins = 0);

}  // namespace mesorock::voxel
