#pragma once
// A synthetic shale-like volume with known phases, for tests, samples and benchmarks.
//
// Organic matter is a union of spheres (physical spheres: ellipsoids in voxels when the spacing is
// anisotropic) in an inorganic matrix. Pores are smaller spheres, most placed inside organic
// matter (organic-hosted, labelled organic_pore) and a share in the matrix (labelled pore); each
// pore sphere is clipped to its host phase. The grey image is a mean grey level per phase, an
// optional blur (point-spread function), and Gaussian noise.
//
// Reproducible: one std::mt19937_64 stream (with our own integer-to-real transforms, because the
// std distributions differ between standard libraries) places the spheres; the noise of voxel i
// is a pure function of (seed, i) through a counter-based hash, so it is the same for any thread
// count.
#include <array>
#include <cstdint>

#include "voxel/segment.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

struct ShaleOptions {
  Shape shape{128, 128, 128};
  Spacing spacing{5.0, 2.5, 2.5, "nm"};  // FIB-SEM-like: 2.5 x 2.5 nm in-plane, 5 nm slices
  double porosity = 0.10;                // pore volume fraction (both pore phases)
  double organic_fraction = 0.25;        // organic matter including its pores
  double blob_radius = 12.0;             // mean organic sphere radius, in voxels along x
  double pore_radius = 0.0;              // mean pore radius in voxels along x; 0: blob_radius / 3
  double matrix_pore_share = 0.2;        // share of the pore volume in the inorganic matrix
  double noise = 20.0;                   // Gaussian noise standard deviation, grey levels (0-255)
  double blur = 0.0;                     // point-spread sigma in voxels, before the noise
  std::array<double, 3> grey{40, 100, 180};  // mean grey of pore, organic, inorganic (0-255)
  DType dtype = DType::kUInt8;               // uint8, or uint16 (grey levels scaled by 257)
  std::uint64_t seed = 1;
};

struct ShaleSample {
  Volume grey;   // the image
  Volume truth;  // uint8 phase codes (pore, organic, inorganic, organic_pore)
  PhaseCounts truth_counts;
};

// Throws ConfigError for parameters that cannot be met (e.g. more pore than organic volume).
ShaleSample make_shale(const ShaleOptions& options);

// The counter-based hash behind the noise (SplitMix64's finaliser), exposed for tests.
std::uint64_t mix64(std::uint64_t x);

}  // namespace mesorock::voxel
