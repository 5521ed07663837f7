#pragma once
// The converged continuum reference: the lattice Boltzmann k of a voxel image on a ladder of
// ever finer lattices, extrapolated to the limit (`rockflow lbm`, docs/lbm.md).
//
// Why a ladder: the voxels are the geometry, but the lattice need not be as coarse. Refining
// splits each voxel into r^3 nodes (the same staircase). On rock the k of refine r converges at
// first order, k(r) = k_inf + C1 / r + ...: the staircase's edges and corners (measured on
// Berea 50^3 with an independent solver: 1558.8, 1384.8, 1327.4, 1299.7 mD at r = 1..4, changes
// falling 3 : 1 then 2 : 1; ../shared/findings/converged-reference.md). Refine 2 was 12% above
// the limit there. Flat, grid-aligned walls converge at second order instead (the node sum's
// midpoint rule: a slit's k_pore = h^2/12 + 1/(24 r^2)).
//
// The extrapolation (extrapolate()): with three or more rungs, k(r) = k_inf + C1 / r + C2 / r^2
// through the last three (exact for both orders and their mix); the order p of the power law
// k_inf + C r^-p through the same three is reported, and the ladder is called asymptotic when p
// lies in [0.5, 3] with the changes shrinking and, with four or more rungs, the order of the
// previous three agrees within 0.5. The error: with four or more rungs, the change of k_inf
// between the last three rungs and the three before them; with three, how far the three-term
// limit lies from the other models the rungs allow (the power law, and the two-term model of the
// nearest whole order through the last two): a spread, not a measured change, which a fourth
// rung checks; with two, first order is assumed and the error is the whole correction.
//
// Each rung runs at tau_r = 1/2 + (tau - 1/2) r (the viscosity grows with r): the slow viscous
// relaxation of a pore of l r nodes takes ~ (l r)^2 / nu steps and the pressure relaxation along
// the sample ~ nu (independent of r), so nu ~ r keeps both balanced and the steps grow as r, not
// r^2; k does not depend on tau (Lambda = 3/16). Each rung starts from the previous rung's flow
// (InitialFlow, solver.h) instead of rest.
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lbm/solver.h"

namespace mesorock::lbm {

struct LadderOptions {
  std::vector<int> refines;  // the rungs, increasing, 1..8; empty: auto_rungs()
  LbmOptions base;           // base.tau is the relaxation time at refine 1
  bool scale_tau = true;     // tau_r = 1/2 + (tau - 1/2) r; false: every rung at base.tau
  bool warm_start = true;    // start each rung from the previous rung's flow
  // Called before each rung (index from 0, its refinement, its node count) and after it.
  std::function<void(int index, int refine, std::int64_t nodes)> rung_start;
  std::function<void(int index, int refine, const LbmResult& result)> rung_done;
};

struct Rung {
  int refine = 1;
  double tau = 0;
  double k_voxel2 = 0;  // in the image's voxels: the lattice's k / refine^2
  LbmResult result;
};

struct Extrapolation {
  bool extrapolated = false;  // at least two rungs
  double k_voxel2 = 0;        // k_inf (the last rung's k when not extrapolated)
  double error_voxel2 = 0;    // see the header comment; NaN with one rung
  double order = 0;           // p of the last three rungs; NaN when not measured
  double order_previous = 0;  // p of the three before; NaN with fewer than four rungs
  bool asymptotic = false;
  std::string method;  // how k_inf and its error were found, in words
  std::vector<std::string> warnings;
};

struct LadderResult {
  std::vector<Rung> rungs;
  Extrapolation extrapolation;
  double porosity = 0;
  bool percolates = false;
  double seconds = 0;
};

// k_inf from k at the refinements `refines` (increasing, at least one), as described above.
Extrapolation extrapolate(const std::vector<int>& refines, const std::vector<double>& k);

// The rungs `rockflow lbm` runs by default: 1, 2, 3, 4 when refine 4 of the mask's pore voxels
// fits (on the CPU at most 2 M nodes, so that a 50^3 crop takes minutes on two cores; on the GPU
// its free memory), else 1, 2, 3 (whose error only the spread of extrapolations estimates).
std::vector<int> auto_rungs(const sim::SolidMask& mask, Backend backend, Precision precision);

// Runs the ladder on `image` (the rock's own voxels); k in the image's voxels.
LadderResult lbm_ladder(const sim::SolidMask& image, const LadderOptions& options);

// The JSON report of `rockflow lbm` (lbm.json): version, input, options, mask, result (k_inf and
// its error in voxel^2, rc^2 and, when image.nm_per_rc > 0, nm^2 and mD), every rung with its
// convergence history.
nlohmann::json ladder_report_json(const std::string& input_file, const sim::SolidMask& image,
                                  const LadderOptions& options, const LadderResult& result);

}  // namespace mesorock::lbm
