#pragma once
// Pore analysis of a phase-label volume (uint8 phase codes, see segment.h): porosity, surface
// area, porosity profiles, connected pore clusters and percolation.
//
// Definitions (docs/voxel.md, "rockprep part 2"):
// * pore voxels are the codes pore (1) and organic_pore (4); solid voxels are organic (2) and
//   inorganic (3); outside voxels (0) are neither and are not counted in the bulk volume.
// * porosity = pore voxels / counted voxels (all but outside).
// * the pore/solid interface is counted face by face: every pair of face-adjacent voxels of which
//   one is pore and the other solid contributes one voxel face (dy*dz for a face normal to x,
//   and so on). Faces against outside voxels or the volume's faces are not interface.
// * a cluster is a connected set of pore voxels, with 6-connectivity (faces) or 26-connectivity
//   (faces, edges and corners). A cluster spans axis a when it holds voxels in both the first
//   and the last slice along a; the percolating porosity along a is the volume of the clusters
//   that span a divided by the counted voxels. A cluster that spans no axis is isolated.
#include <array>
#include <cstdint>
#include <vector>

#include "voxel/segment.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

inline bool is_pore_code(std::uint8_t code) {
  return code == static_cast<std::uint8_t>(Phase::kPore) ||
         code == static_cast<std::uint8_t>(Phase::kOrganicPore);
}
inline bool is_solid_code(std::uint8_t code) {
  return code == static_cast<std::uint8_t>(Phase::kOrganic) ||
         code == static_cast<std::uint8_t>(Phase::kInorganic);
}

// Axes in the order the volume stores them.
enum Axis : int { kAxisZ = 0, kAxisY = 1, kAxisX = 2 };
const char* axis_name(int axis);          // "z", "y", "x"
int parse_axis(const std::string& name);  // throws ConfigError

// ---------------------------------------------------------------------------------------------
// One streaming pass: phase counts, interface faces, slice profiles.

struct PoreStatistics {
  Shape shape;
  PhaseCounts counts;
  // faces[axis][phase]: faces normal to `axis` between a pore voxel and a voxel of solid `phase`
  // (only organic and inorganic entries are non-zero).
  std::array<std::array<std::int64_t, kPhaseCount>, 3> faces{};
  // Per slice along each axis: pore voxels and counted voxels.
  std::array<std::vector<std::int64_t>, 3> slice_pore;
  std::array<std::vector<std::int64_t>, 3> slice_counted;

  std::int64_t pore_voxels() const;
  std::int64_t faces_normal_to(int axis) const;  // all solid phases
  // Interface area in the spacing's unit squared (all solid phases, or one).
  double interface_area(const Spacing& spacing) const;
  double interface_area(const Spacing& spacing, Phase solid) const;
  // Interface area per bulk volume (counted voxels), in 1 / unit. 0 when nothing is counted.
  double specific_surface_area(const Spacing& spacing) const;
  // Porosity of each slice along `axis` (NaN-free: 0 for a slice with no counted voxel).
  std::vector<double> porosity_profile(int axis) const;
};

// Throws ConfigError when `labels` is not uint8 or holds a value that is not a phase code.
PoreStatistics measure_pores(const Volume& labels);

// ---------------------------------------------------------------------------------------------
// Connected pore clusters.
//
// Labelled run by run rather than voxel by voxel: the pore voxels of each row (fixed z, y) form
// runs [x_begin, x_end), and union-find joins runs of neighbouring rows that touch. Memory is 12
// bytes per run plus 4 for the union-find parent, so it follows the pore surface, not the volume
// (a 1024^3 shale with 10% porosity has about 20 million runs; a voxel-wise label volume would
// take 4 GiB). Why not OpenVDB: tools::extractActiveVoxelSegmentMasks makes one grid per cluster
// (hundreds of thousands here) and knows face connectivity only.

struct PoreRuns {
  Shape shape;
  std::vector<std::int64_t> row_begin;  // nz * ny + 1 offsets into x_begin / x_end, row = z*ny+y
  std::vector<std::int32_t> x_begin;
  std::vector<std::int32_t> x_end;  // exclusive
  std::int64_t count() const { return static_cast<std::int64_t>(x_begin.size()); }
  std::size_t bytes() const;
};

// The runs of pore voxels (is_pore_code) of every row, in C order. Parallel.
PoreRuns find_pore_runs(const Volume& labels);

struct Cluster {
  std::int64_t voxels = 0;
  std::uint8_t faces = 0;  // bit 2a: touches the first slice along axis a; bit 2a+1: the last
  std::array<std::int32_t, 3> lo{};  // bounding box (z, y, x), inclusive
  std::array<std::int32_t, 3> hi{};

  bool touches(int axis, bool last) const { return faces & (1u << (2 * axis + (last ? 1 : 0))); }
  bool spans(int axis) const { return touches(axis, false) && touches(axis, true); }
  bool percolates() const { return spans(0) || spans(1) || spans(2); }
  bool touches_boundary() const { return faces != 0; }
};

struct ClusterOptions {
  int connectivity = 6;  // 6 (faces) or 26 (faces, edges, corners); ConfigError otherwise
};

// Clusters in the order of their first voxel (C order), so the result is the same for any thread
// count.
std::vector<Cluster> find_pore_clusters(const PoreRuns& runs, const ClusterOptions& options = {});

// The same labelling, giving the cluster index of every run (runs in PoreRuns order) so that a
// caller can select voxels by cluster; the clusters go to *clusters when given.
std::vector<std::uint32_t> label_pore_runs(const PoreRuns& runs, const ClusterOptions& options = {},
                                           std::vector<Cluster>* clusters = nullptr);

struct PercolationSummary {
  std::int64_t clusters = 0;
  std::array<std::int64_t, 3> spanning_clusters{};  // per axis
  std::array<std::int64_t, 3> spanning_voxels{};    // per axis
  std::int64_t percolating_voxels = 0;              // in clusters spanning at least one axis
  std::int64_t isolated_clusters = 0;               // spanning no axis
  std::int64_t isolated_voxels = 0;
  std::int64_t enclosed_clusters = 0;  // isolated and touching no face of the volume
  std::int64_t enclosed_voxels = 0;
  std::vector<Cluster> largest_isolated;  // the `largest` biggest isolated clusters, biggest first
};

PercolationSummary summarize_clusters(const std::vector<Cluster>& clusters,
                                      std::size_t largest = 10);

}  // namespace mesorock::voxel
