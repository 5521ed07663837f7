#pragma once
// An independent continuum reference for the permeability of a voxel image (`rockflow lbm`,
// docs/lbm.md): Stokes flow through the pore voxels of a sim::SolidMask, solved with a lattice
// Boltzmann scheme on the identical voxels, so the particle solver's k can be checked against a
// method that shares nothing with it but the image. This file: one lattice (one rung of the
// refinement ladder, ladder.h).
//
// Method (lattice units: voxel edge = 1, dt = 1, rho0 = 1, c_s^2 = 1/3):
// - D3Q19, one node per pore voxel centre; periodic on all three axes.
// - TRT collision (Ginzburg, Verhaeghe & d'Humieres 2008, Commun. Comput. Phys. 3, 427-478;
//   Ginzburg 2005, Adv. Water Resour. 28, 1171-1195): the symmetric part relaxes with
//   tau+ = tau (viscosity nu = (tau - 1/2) / 3), the antisymmetric part with tau- chosen so that
//   Lambda = (tau+ - 1/2)(tau- - 1/2) = 3/16. With this "magic" Lambda the halfway bounce-back
//   wall sits exactly half-way between a pore node and a solid node for the Poiseuille profile,
//   and the steady solution (hence k) is independent of tau for a fixed Lambda (d'Humieres &
//   Ginzburg 2009, Comput. Math. Appl. 58, 823-840; Talon et al. 2012, Water Resour. Res. 48,
//   W04526). BGK (one relaxation time) lacks this: its k drifts with tau (Pan, Luo & Miller
//   2006, Comput. Fluids 35, 898-909). Where throats are about one node wide, the force's own
//   share of the momentum (F/2 per node, not proportional to 1/nu) breaks it slightly: 0.9%
//   between tau 0.6 and 1 for overlapping spheres of k = 0.008 voxel^2.
// - Stokes equilibrium (linear in the momentum, no u u term), halfway bounce-back on every link
//   from a pore node to a solid node, a uniform body force F per node along `axis` with Guo
//   forcing restricted to the Stokes equilibrium (node_update.h has the update).
// - Result: the Darcy velocity q = sum of u_axis over the pore nodes / the TOTAL voxel count
//   (solid voxels count as zero velocity), k = nu q / F in voxel^2. The node sum is a midpoint
//   rule: for a slit of gap h it gives the exact nodal parabola's mean, k_pore = h^2/12 + 1/24.
//
// Storage: the percolating pore nodes only (lattice.h), in image order, structure of arrays: two
// copies of 19 populations (Real) and an 18-link pull table (uint32): 19 * 2 * sizeof(Real) + 72
// bytes a node (376 in double, 224 in single precision). The velocity sums are taken per fixed
// block of nodes in double and added in order on the host, so a result does not depend on the
// thread count. The same node body (node_update.h) runs in the CPU's OpenMP loop and in the CUDA
// kernel (cuda/steps_cuda.cu).
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sim/solid_grid.h"

namespace mesorock::lbm {

enum class Backend { CPU, CUDA };
enum class Precision { Single, Double };
const char* to_string(Backend b);
const char* to_string(Precision p);

// A converged flow, kept to start a finer lattice from it (ladder.h): per lattice voxel the node
// that was simulated there (or kWall), and per node its moments.
struct FlowField {
  std::array<std::int64_t, 3> dims{0, 0, 0};  // the lattice's voxels
  std::vector<std::uint32_t> node_of;         // [lattice voxel]
  std::vector<float> drho, jx, jy, jz;        // [node]
  double nu = 0;                              // the viscosity it was solved with
  double force = 0;
};

// How a lattice starts from the flow of a coarser one: the fine node at lattice voxel (i, j, k)
// takes the moments of the coarse node whose voxel holds its centre, with the velocity scaled by
// (fine nodes per coarse node edge)^2 nu_coarse / nu_fine (u ~ F l^2 / nu in lattice units) and
// the density by the ratio of edges (the pressure gradient ~ F per lattice spacing).
struct InitialFlow {
  const FlowField* field = nullptr;
  double ratio = 1;  // fine lattice edges per coarse lattice edge (r_fine / r_coarse)
};

struct LbmOptions {
  int axis = 0;  // flow axis 0, 1, 2 = x, y, z
  // Relaxation time of the symmetric part, > 1/2; nu = (tau - 1/2) / 3. k does not depend on it
  // (Lambda is fixed), only the number of steps does: small tau speeds up the slow pressure
  // relaxation along a long heterogeneous sample, large tau the viscous relaxation in wide
  // pores. 0.55 suits real rock images at one node per voxel (Berea 200x100x100: 2,800 steps;
  // 30,100 at tau = 1); well-resolved pores (a sphere array with 10-voxel spheres) converge
  // faster at 1 to 1.5.
  double tau = 0.55;
  double force = 1e-5;      // body force per node along the axis (lattice units); finite, not zero
  double tolerance = 1e-6;  // stop when |q - q_prev| / |q| over check_every steps is below
  int check_every = 100;    // steps between convergence checks (>= 1)
  std::int64_t max_steps = 200000;  // give up (converged = false) after this many steps (>= 1)
  int threads = 0;                  // OpenMP threads of the CPU backend (0: OpenMP's default)
  Backend backend = Backend::CPU;
  Precision precision = Precision::Double;
  InitialFlow initial;      // start from a coarser flow instead of rest (ladder.h)
  bool keep_field = false;  // return the converged flow in LbmResult::field
  // Called after every check (never from a worker thread); the library prints nothing.
  std::function<void(std::int64_t step, double rel_change)> progress;
  // Called at every check; throw from it (Interrupted) to stop.
  std::function<void()> poll;
};

struct LbmCheck {
  std::int64_t step = 0;
  double darcy_velocity = 0;  // q: sum of u_axis over the pore nodes / all voxels
  double rel_change = 0;      // |q - q_prev| / |q| (1 at the first check)
};

struct LbmResult {
  double k_voxel2 = 0;            // Darcy permeability nu q / F, in the lattice's voxel^2
  double k_rc2 = 0;               // k_voxel2 * voxel_edge_rc^2
  double porosity = 0;            // pore voxels / all voxels (isolated pores included)
  double darcy_velocity = 0;      // q (lattice units)
  double mean_pore_velocity = 0;  // q / porosity: the mean u_axis over all pore voxels
  double max_velocity = 0;        // largest |u| of a node
  double reynolds_estimate = 0;   // q sqrt(k) / nu (the permeability-based Reynolds number)
  double mean_density = 0;        // mean rho over the simulated nodes (1 up to rounding)
  std::int64_t steps = 0;
  bool converged = false;
  std::int64_t pore_voxels = 0;  // all pore voxels of the mask
  std::int64_t fluid_nodes = 0;  // the simulated ones: those of percolating components
  bool percolates = false;
  double tau_minus = 0;     // the antisymmetric relaxation time that makes Lambda = 3/16
  double seconds = 0;       // wall time of the whole call
  double step_seconds = 0;  // of it, the time in the steps (node updates / this = the rate)
  Backend backend = Backend::CPU;
  Precision precision = Precision::Double;
  std::vector<LbmCheck> history;  // every convergence check, in order
  FlowField field;                // with LbmOptions::keep_field
};

// Bytes a node of the lattice takes on the device or host running it (populations and links).
double bytes_per_node(Precision p);

// The steady Stokes permeability of `mask` along options.axis. Throws ConfigError for bad options
// (tau <= 1/2, zero or non-finite force, axis outside 0..2, tolerance negative, counts below 1),
// non-cubic voxels, a malformed mask, one without a pore voxel or one without a solid voxel (the
// flow would accelerate without bound); LimitError when the nodes do not fit in memory or exceed
// 2^32 - 2; DeviceError when CUDA is asked for and absent; NumericalError if the velocity stops
// being finite.
LbmResult lbm_permeability(const sim::SolidMask& mask, const LbmOptions& options);

// "" when a CUDA device can run the lattice, else why not (a build without CUDA, no device).
std::string cuda_unavailable_reason();

}  // namespace mesorock::lbm
