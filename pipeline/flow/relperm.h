#pragma once
// `rockflow relperm SAMPLE.toml` (docs/relperm.md): steady-state relative permeability of a
// periodic sample (rockprep run --layout permeability) at a list of wetting saturations.
//
// The scene's fluid is the wetting phase W. The command adds a second liquid N ("nonwetting"),
// a copy of W with two differences: the cross repulsion A_WN (less attractive than A_WW, so the
// two do not mix; -30 against the standard liquid's -40 by default, the pair of the relperm-slit,
// laplace-cylinder and capillary-slit validation cases) and, when given, its affinity A_SN to
// every wall type. With A_SN = A_SW (the default) the two liquids are the same fluid up to a
// label and the W-N interface meets the walls at 90 degrees by symmetry (neutral wetting); a less
// attractive A_SN makes W the wetting phase. The viscosity ratio is 1 (one liquid).
//
// For each saturation S_w the prepared sample's fluid particles are split by the placement rule
// (phase_placement.h), both phases feel the same body force g along the flow axis (the same
// pressure gradient G = n_f g), and the run goes to a steady state with the sweep's machinery
// (sweep.h: blocks, the steady test on the total flux and on each phase's, the trend check). A
// reference run with W alone (S_w = 1) at the same g and settings gives the single-phase flux
// J_1, and
//   kr_W = J_W / J_1,   kr_N = J_N / J_1
// (each phase's number flux over the single-phase one: one density and one viscosity, so the
// ratio of fluxes is the ratio k_phase / k_abs at this gradient). With a `rockflow sweep` summary
// of the same sample (--sweep), k_abs is also the sweep's Darcy fit and the reference's k = mu
// J_1 / (n_f^2 g) is compared with it (the end point), and each phase's k is given in rc^2, nm^2
// and mD. Each run's final state also says whether each phase spans the sample along the flow
// axis (phase_connectivity.h): a phase that does not span carries flux only by clusters that
// move with the flow.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/flow/phase_placement.h"
#include "pipeline/flow/sweep.h"
#include "pipeline/scene.h"

namespace mesorock::pipeline {

// The default cross repulsion of the two liquids (immiscible against A_WW = -40; validated in
// relperm-slit, laplace-cylinder and capillary-slit).
constexpr double kDefaultCrossA = -30.0;

// One wall type's affinities to the two liquids.
struct WallAffinity {
  int type = 0;
  double A_SW = 0, A_SN = 0;
};

// Makes N immiscible with W (shared by relperm and `rockflow pc`): the W-N pair is W-W's with
// A = cross_A (ConfigError unless less attractive than A_WW: else the two mix), and N meets every
// frozen type as W does, with A = A_SN when given. Returns each wall type's affinities;
// ConfigError when there is no frozen type. `where` starts the messages.
std::vector<WallAffinity> make_immiscible(sim::Model& model, int W, int N, double cross_A,
                                          std::optional<double> A_SN, const std::string& where);

struct RelpermCommand {
  // The fluid and steady-state options shared with `rockflow sweep` (out_dir, axis, types,
  // fluid_density, viscosity, run); its forces are not used.
  SweepCommand sweep;
  std::vector<double> saturations;  // target wetting saturations, each in (0, 1)
  Placement placement = Placement::Drainage;
  std::optional<double> force;              // g; default: the scene's body force on the fluid
  double cross_A = kDefaultCrossA;          // A_WN
  std::optional<double> nonwetting_wall_A;  // A_SN for every wall type; default: W's own
  std::filesystem::path sweep_json;         // rockflow sweep's sweep.json of the same sample
  bool write_states = true;                 // states/S_*.h5 + .xmf: the phases at the end
};

// Runs the saturations and the reference, writes OUT/relperm.csv, relperm_blocks.csv,
// relperm.json, relperm.png (and states/), and returns the summary (relperm.json).
nlohmann::json run_relperm_command(const Scene& scene, const RelpermCommand& command);

}  // namespace mesorock::pipeline
