#pragma once
// An independent continuum reference for the permeability of a voxel image (`rockflow lbm`,
// docs/lbm.md): Stokes flow through the pore voxels of a sim::SolidMask, solved with a lattice
// Boltzmann scheme on the identical voxels, so the particle solver's k can be checked against a
// method that shares nothing with it but the image.
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
//   2006, Comput. Fluids 35, 898-909). Measured: slit and sphere array independent of tau to
//   1e-6 or better, Berea 200x100x100 to 6e-5; the body force's own share of the momentum
//   (F/2 per node, not proportional to 1/nu) breaks it slightly where throats are about one
//   voxel wide: 0.9% between tau 0.6 and 1 for overlapping spheres of k = 0.008 voxel^2.
// - Stokes equilibrium (linear in the momentum, no u u term): e_q = w_q (rho + 3 c_q . j).
//   The scheme is then linear: k does not depend on the force except through rounding.
// - Halfway bounce-back on every link from a pore node to a solid node.
// - A uniform body force F per node along `axis` (force density = F since rho0 = 1), Guo
//   forcing (Guo, Zheng & Shi 2002, Phys. Rev. E 65, 046308) restricted to the Stokes
//   equilibrium: the source (1 - 1/(2 tau-)) 3 w_q c_q . F goes to the antisymmetric part and the
//   equilibrium momentum is j = sum_q f_q c_q + F / 2, the fluid velocity (rho0 = 1). This is
//   algebraically the same update as Ginzburg's TRT forcing (source 3 w_q c_q . F in full,
//   equilibrium from sum_q f_q c_q).
//
// Result: the Darcy velocity q = sum of u_axis over the pore nodes / the TOTAL voxel count (solid
// voxels count as zero velocity), k = nu q / F in voxel^2. The node sum is a midpoint rule: for
// a slit of gap h it gives the exact nodal parabola's mean, k_pore = h^2/12 + 1/24, not h^2/12
// (docs/lbm.md).
//
// Percolation: only pore components that connect to their own periodic image along the axis
// carry a steady flow (elsewhere the body force is balanced by pressure). Components are found
// with the links the LBM itself uses, 18-connectivity (faces and edges; two pore voxels that
// touch only at an edge are linked, voxels touching at a corner are not), on the periodic grid,
// tracking how many times a path wraps around the axis; a component percolates when it reaches
// a voxel with two different wrap counts. Only percolating components are simulated; a mask
// without one gives k = 0, percolates = false and runs no step.
//
// Storage: the pore nodes only, in image order (z-major), structure of arrays: two copies of
// 19 populations (double) and an 18-link table of the neighbour each population is pulled from
// (uint32; a solid neighbour is marked and the link bounces back): 376 bytes per node, 448 for
// a moment at set-up, plus 4 bytes per voxel while the links are found. One fused
// pull-stream-collide pass per step, OpenMP over nodes; the velocity sums are taken per fixed
// block of nodes and added serially, so results do not depend on the thread count.
#include <cstdint>
#include <functional>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/solid_grid.h"

namespace mesorock::pipeline {

struct LbmOptions {
  int axis = 0;  // flow axis 0, 1, 2 = x, y, z
  // Relaxation time of the symmetric part, > 1/2; nu = (tau - 1/2) / 3. k does not depend on it
  // (Lambda is fixed), only the number of steps does: small tau speeds up the slow pressure
  // relaxation along a long heterogeneous sample, large tau the viscous relaxation in wide
  // pores. 0.55 suits real rock images (Berea 200x100x100: 2,800 steps; 30,100 at tau = 1);
  // well-resolved pores (a sphere array with 10-voxel spheres) converge faster at 1 to 1.5.
  double tau = 0.55;
  double force = 1e-5;      // body force per node along the axis (lattice units); finite, not zero
  double tolerance = 1e-6;  // stop when |q - q_prev| / |q| over check_every steps is below
  int check_every = 100;    // steps between convergence checks (>= 1)
  std::int64_t max_steps = 200000;  // give up (converged = false) after this many steps (>= 1)
  int threads = 0;                  // OpenMP threads (0: OpenMP's default)
  // Called after every check (never from a worker thread); the library prints nothing.
  std::function<void(std::int64_t step, double rel_change)> progress;
};

struct LbmCheck {
  std::int64_t step = 0;
  double darcy_velocity = 0;  // q: sum of u_axis over the pore nodes / all voxels
  double rel_change = 0;      // |q - q_prev| / |q| (1 at the first check)
};

struct LbmResult {
  double k_voxel2 = 0;            // Darcy permeability nu q / F, voxel^2
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
  double tau_minus = 0;           // the antisymmetric relaxation time that makes Lambda = 3/16
  double seconds = 0;             // wall time of the whole call
  std::vector<LbmCheck> history;  // every convergence check, in order
};

// The steady Stokes permeability of `mask` along options.axis. Throws ConfigError for bad options
// (tau <= 1/2, zero or non-finite force, axis outside 0..2, tolerance negative, counts below 1),
// non-cubic voxels, a malformed mask or one without a pore voxel; LimitError when the nodes do
// not fit in memory or exceed 2^32 - 2; NumericalError if the velocity stops being finite.
LbmResult lbm_permeability(const sim::SolidMask& mask, const LbmOptions& options);

// The JSON report of `rockflow lbm` (lbm.json): version, input, options, mask, result (k in
// voxel^2, rc^2 and, when mask.nm_per_rc > 0, nm^2 and mD), convergence history.
// The same solid on a finer lattice: every voxel split into n^3 (voxel edges / n). The LBM's k on
// a voxel image converges only as the lattice refines the voxels: the node average of the
// velocity is a midpoint rule (a slit's k is h^2/12 + 1/24 voxel^2, not h^2/12), and throats of
// one or two voxels carry few nodes. On a Leopard sandstone crop k fell by 10% from n = 1 to 2
// (docs/lbm.md); rockflow lbm solves at n = 2 unless told otherwise. LimitError when the refined
// mask would exceed 2^33 voxels.
sim::SolidMask refine_mask(const sim::SolidMask& mask, int n);

nlohmann::json lbm_report_json(const std::string& input_file, const sim::SolidMask& mask,
                               const LbmOptions& options, const LbmResult& result);

}  // namespace mesorock::pipeline
