#pragma once
// The surface-wall sweep: the solid voxels within a wall thickness of the pore space, with their
// phase, as sparse OpenVDB masks; the length scale between voxels and the solver's units (rc);
// and the particle-count estimate every command that leads to particles makes first.
//
// Definitions (docs/voxel.md, "rockprep part 2"):
// * wall voxel: a solid voxel (organic or inorganic) within the box |dz| <= tz, |dy| <= ty,
//   |dx| <= tx voxels of a pore voxel (pore or organic_pore), with t_a = ceil(T / h_a) for a wall
//   thickness T and voxel edge h_a along axis a, both in rc. The box (Chebyshev) neighbourhood
//   contains the Euclidean ball of radius T, so every solid point within T of the pore space is
//   in the wall.
// * particle estimate (before anything is built): N = rho_f V_pore + rho_w V_wall, volumes in
//   rc^3; before the sweep V_wall is estimated as sum_a F_a A_a t_a h_a (F_a pore/solid faces
//   normal to a, A_a their area), after it V_wall = wall voxels x voxel volume. Memory = N x
//   250 bytes (the solver's budget per particle on the GPU).
#include <array>
#include <cstdint>
#include <string>

#include <openvdb/openvdb.h>

#include "voxel/pore_analysis.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

// ---------------------------------------------------------------------------------------------
// Length scale

// Exactly one of the two is positive.
struct LengthScale {
  double nm_per_rc = 0;     // physical nanopores: rc in nanometres (needs a physical spacing)
  double rc_per_voxel = 0;  // scale-free: rc per voxel edge along x (y and z scale with the
                            // spacing's ratios, so anisotropic voxels stay anisotropic)
  std::string str() const;  // "2.5 nm per rc" or "0.5 rc per voxel"
};

// Nanometres per `unit` (nm, um, mm, cm, m, angstrom, pm); ConfigError for other units,
// including "voxel" (no physical size).
double nanometres_per(const std::string& unit);

// Voxel edges (z, y, x) in rc. Throws ConfigError when the scale is missing, twice given, not
// positive, or needs a physical spacing that `spacing` lacks.
std::array<double, 3> voxel_size_rc(const LengthScale& scale, const Spacing& spacing);

// Wall layers per axis: ceil(thickness_rc / h_a) (at least 1). thickness_rc must be >= 1 (the
// mDPD cutoff): ConfigError otherwise.
std::array<int, 3> wall_layers(double thickness_rc, const std::array<double, 3>& voxel_rc);

// ---------------------------------------------------------------------------------------------
// Particle estimate

struct ParticleEstimateOptions {
  double fluid_density = 6.88;      // particles per rc^3 in the pore space
  double wall_density = 6.88;       // particles per rc^3 in the wall shell
  double bytes_per_particle = 250;  // GPU memory per particle
  std::int64_t max_particles = 50'000'000;
};

struct ParticleEstimate {
  double pore_volume_rc3 = 0;
  double wall_volume_rc3 = 0;
  bool wall_exact = false;  // wall volume counted (after the sweep) or estimated from faces
  double fluid_particles = 0;
  double wall_particles = 0;
  double total() const { return fluid_particles + wall_particles; }
  double bytes = 0;
  std::string str() const;  // one line with the numbers and the formula
};

// Before the sweep: the wall volume from the pore/solid faces (see the header comment).
ParticleEstimate estimate_particles(const PoreStatistics& stats,
                                    const std::array<double, 3>& voxel_rc,
                                    const std::array<int, 3>& layers,
                                    const ParticleEstimateOptions& options = {});
// After the sweep: the wall volume counted.
ParticleEstimate count_particles(std::int64_t pore_voxels, std::int64_t wall_voxels,
                                 const std::array<double, 3>& voxel_rc,
                                 const ParticleEstimateOptions& options = {});

// Throws LimitError with the estimate when it exceeds options.max_particles.
void check_particle_limit(const ParticleEstimate& estimate, const ParticleEstimateOptions& options);

// ---------------------------------------------------------------------------------------------
// Sweep

struct WallOptions {
  std::array<int, 3> layers{1, 1, 1};  // (z, y, x) voxels, each >= 1
};

struct WallSweep {
  // One MaskGrid per solid phase that has wall voxels, named after the phase ("organic",
  // "inorganic"), metadata "phase", "phase_code", "wall_layers_zyx", "unit".
  openvdb::GridPtrVec walls;
  std::array<std::int64_t, kPhaseCount> voxels{};  // wall voxels per phase code
  std::int64_t total() const;
  std::int64_t surface_voxels = 0;  // pore voxels with a face neighbour that is not pore
};

// Runs the sweep on the phase masks of build_phase_grids (the grids named "pore",
// "organic_pore", "organic", "inorganic"; others are ignored):
// 1. pore = pore | organic_pore; its surface = pore minus its face-neighbour erosion (OpenVDB
//    erodeActiveValues), so the interior of large pores costs nothing;
// 2. the surface dilated by min_a t_a with OpenVDB's 26-neighbour dilateActiveValues, then along
//    single axes (dilate_along_axis) up to t_a, giving the box neighbourhood;
// 3. intersected with each solid phase mask (topologyIntersection).
// Memory follows the pore surface, not the volume.
WallSweep sweep_walls(const openvdb::GridPtrVec& phase_masks, const WallOptions& options);

// Dilates the active voxels of `tree` by `steps` voxels along one axis (0 = z, 1 = y, 2 = x) in
// both directions, leaf mask word by word (OpenVDB has no single-axis dilation). Active tiles
// are voxelized first.
void dilate_along_axis(openvdb::MaskTree& tree, int axis, int steps);

}  // namespace mesorock::voxel
