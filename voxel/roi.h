#pragma once
// Regions of interest: cropping by a voxel box or a physical box, and resampling to another grid.
//
// Coordinates: voxel (z, y, x) covers [z dz, (z + 1) dz) x ... in the spacing's unit, with the
// volume's first voxel at the origin; its centre is at ((z + 0.5) dz, ...).
#include <array>
#include <cstdint>
#include <string>

#include "voxel/volume.h"

namespace mesorock::voxel {

// A box of voxels, half-open per axis: z in [z0, z1), and so on (numpy's slices).
struct VoxelBox {
  std::array<std::int64_t, 3> lo{};  // (z, y, x)
  std::array<std::int64_t, 3> hi{};
  Shape shape() const { return {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}; }
  std::string str() const;  // "z 0:10, y 5:20, x 0:64"
};

// A box in the spacing's unit, half-open per axis.
struct PhysicalBox {
  std::array<double, 3> lo{};  // (z, y, x)
  std::array<double, 3> hi{};
};

// Parses "Z0:Z1,Y0:Y1,X0:X1" (numbers; voxel boxes need integers). ConfigError naming `option`.
VoxelBox parse_voxel_box(const std::string& text, const std::string& option);
PhysicalBox parse_physical_box(const std::string& text, const std::string& option);

// The voxels whose centres lie in the physical box. Throws ConfigError when that is none.
VoxelBox voxels_in(const PhysicalBox& box, const Shape& shape, const Spacing& spacing);

// Throws ConfigError unless the box is non-empty and lies inside `shape`.
void check_box(const VoxelBox& box, const Shape& shape);

// A copy of the voxels in `box` (same dtype and spacing).
Volume crop(const Volume& volume, const VoxelBox& box);

enum class Interpolation {
  kNearest,  // the input voxel whose centre is nearest; the only choice for labels
  kLinear,   // trilinear between the 8 nearest centres (grey values; rounded for integers)
};
const char* interpolation_name(Interpolation interpolation);
Interpolation parse_interpolation(const std::string& name);  // throws ConfigError

struct ResampleOptions {
  Shape shape;      // output shape
  Spacing spacing;  // output spacing (same unit as the input)
  Interpolation interpolation = Interpolation::kNearest;
};

// The output grid for a zoom factor per axis (shape round(n f), spacing d n / n', so the
// physical extent is kept), or for a target spacing (shape round(n d / d'), spacing d').
ResampleOptions zoom_grid(const Shape& shape, const Spacing& spacing,
                          const std::array<double, 3>& factor);
ResampleOptions spacing_grid(const Shape& shape, const Spacing& spacing,
                             const std::array<double, 3>& target);

// Samples `volume` at the centres of the output grid: output voxel i' maps to input coordinate
// u = (i' + 0.5) d' / d - 0.5 per axis, clamped to the volume. Parallel over z.
Volume resample(const Volume& volume, const ResampleOptions& options);

}  // namespace mesorock::voxel
