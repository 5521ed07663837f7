#pragma once
// Filters for noisy grey-level stacks. All work in place and keep the volume's dtype: a 1024^3
// uint8 volume stays 1 GiB, plus a few slices of scratch per thread.
#include <cstdint>
#include <vector>

#include "voxel/volume.h"

namespace mesorock::voxel {

enum class MedianShape { kCube, kBall };

struct MedianOptions {
  // Window half-widths in voxels along each axis. kCube: every voxel with |dz| <= radius_z,
  // |dy| <= radius_y, |dx| <= radius_x (radius 1: the 3x3x3 cube). kBall: the voxels with
  // (dz/radius_z)^2 + (dy/radius_y)^2 + (dx/radius_x)^2 <= 1 (radius 1: the 7-voxel cross;
  // 0.75, 1.5, 1.5: the 3x3 in-plane square, suited to FIB-SEM slices twice as thick as pixels).
  // A radius of 0 keeps that axis out of the window.
  double radius_z = 1;
  double radius_y = 1;
  double radius_x = 1;
  MedianShape shape = MedianShape::kCube;
};

MedianOptions cube_median(int radius);

// 3-D median. Near the faces the window is clipped and holds fewer voxels; with an even count
// the lower of the two middle values is taken. 8-bit volumes use a sliding histogram (Huang's
// method, per window row); uint16 and float32 volumes select the median of each window (slower).
void median_filter(Volume& volume, const MedianOptions& options = {});

// The window offsets as rows: (dz, dy, half-width in x). Exposed for tests.
struct MedianRow {
  int dz;
  int dy;
  int half_x;
};
std::vector<MedianRow> median_window(const MedianOptions& options);

struct GaussianOptions {
  // Standard deviation along each axis in voxels; 0 skips that axis.
  double sigma_z = 1.0;
  double sigma_y = 1.0;
  double sigma_x = 1.0;
  double truncate = 4.0;  // kernel half-width in standard deviations (as scipy.ndimage)
};

// The same sigma, in voxels, along every axis.
GaussianOptions isotropic_gaussian(double sigma_voxels);
// sigma in the spacing's length unit, converted per axis (anisotropic stacks).
GaussianOptions physical_gaussian(double sigma, const Spacing& spacing);

// Separable Gaussian with mirrored ("reflect") borders. Integer volumes are rounded back to their
// type after the in-plane pass and after the z pass (at most one grey level of extra error).
// bool volumes are refused (ConfigError).
void gaussian_filter(Volume& volume, const GaussianOptions& options);

// A circular field of view in every xy slice (micro-CT reconstructions are round). Coordinates
// are voxel indices: x along columns, y along rows.
struct FieldOfView {
  double cx = 0;
  double cy = 0;
  double radius = 0;
  bool contains(double x, double y) const {
    return (x - cx) * (x - cx) + (y - cy) * (y - cy) <= radius * radius;
  }
  // The columns [first, last] of row y inside the circle (first > last when none).
  void row_span(std::int64_t y, std::int64_t nx, std::int64_t* first, std::int64_t* last) const;
};

// The largest centred circle: centre of the slice, radius min(nx, ny) / 2.
FieldOfView inscribed_field_of_view(const Shape& shape);

// The circle whose area and centroid match the voxels not equal to `outside_value` (scanners
// often write a sentinel such as 0 or 1 outside the reconstruction). Averaged over all slices.
// Throws ConfigError when every voxel has that value.
FieldOfView field_of_view_from_value(const Volume& volume, double outside_value);

// Sets every voxel outside `fov` to `fill` (which must be representable in the dtype); returns
// how many voxels were outside.
std::int64_t apply_field_of_view(Volume& volume, const FieldOfView& fov, double fill);

}  // namespace mesorock::voxel
