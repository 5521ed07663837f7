#pragma once
// Primary drainage under stepped capillary pressure: the engine of `rockflow pc` and of the
// drainage-slit validation case (docs/relperm.md).
//
// The set-up is a flooding layout (packing/flooding.h), along the flow axis:
//
//   | push slab | N reservoir | block: W in the pores, walls | W reservoir | back slab | room |
//
// The wetting liquid W fills the block and the outlet reservoir; the non-wetting liquid N fills
// the inlet reservoir. A virtual wall at the block's outlet face keeps N in the block and lets W
// through: the semi-permeable membrane of primary-drainage experiments (and of LBM set-ups), so
// each level ends in capillary equilibrium instead of N breaking through into the outlet.
//
// Level k holds the back slab at P_back and pushes with P_back + Pc_k. A slab at rest is in force
// balance, so in equilibrium the N reservoir is at P_back + Pc_k and the W reservoir at P_back:
// p_N - p_W = Pc_k, the applied capillary pressure. Between levels the pressures ramp (see
// DrainageOptions::ramp_steps); the run continues from its state with the slabs' applied forces
// changed (sim/checkpoint.h's SimulationState), so a level starts where the last one ended.
//
// At each level, S_w = N_W / (N_W + N_N) over the fluid particles inside the block is sampled
// every sample_every steps and averaged over blocks of block_steps. The level is steady by the
// sweep's rule (statistics.h halves_agree: the last two windows of `window` blocks agree within
// `tolerance`, relative, or within two standard errors); then measure_blocks further
// blocks give S_w and its error, thrown away while they trend (t_99, as the sweep). A level that
// is not steady after max_level_steps is measured on its last blocks and flagged. The pressures
// of the two reservoirs (region stress of the liquid at least 1 rc from its slab and 0.5 rc from
// the block; the regions follow the slabs) are averaged over the same blocks: the measured Pc.
//
// The run stops early, flagged, when the push slab comes within 1 rc of the block (the inlet
// reservoir is used up) or the back slab within 1 rc of the box's face. At every block the fluid
// particles behind either slab are counted (DrainageLevel::behind_slabs).
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "pipeline/flow/leak_invariant.h"
#include "pipeline/flow/statistics.h"
#include "sim/model.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

class ProgressMeter;

// Where things are in a drainage set-up.
struct DrainageCell {
  int axis = 0;                       // the flow axis (the slabs' axis)
  double block_lo = 0, block_hi = 0;  // the porous block along the axis
  int wetting = -1, nonwetting = -1;  // types
  int push_slab = 0, back_slab = 1;   // indices into Model::rigid_slabs
  double slab_thickness = 1;          // of each slab along the axis (rc)
};

struct DrainageResult;

struct DrainageOptions {
  // Pc of each level (P_push - P_back) in the order run: rising for primary drainage, then
  // (optionally) falling for imbibition.
  std::vector<double> pressures;
  double back_pressure = 0;  // P_back, the magnitude the back slab applies towards -axis
  double dt = 0.01;
  // The pressures move from one level to the next in ramp_parts equal steps spread over
  // ramp_steps (before the level's blocks): a sudden step sets the pistons ringing (a period of
  // about 10 time units, decaying over about 130: docs/flooding.md), and the overshoot pushes a
  // meniscus past where the level itself would hold it.
  std::uint64_t ramp_steps = 2000;
  int ramp_parts = 20;
  std::uint64_t block_steps = 1000, sample_every = 50;
  // Blocks per half of the steady test. The test's other branch (two standard errors) takes its
  // errors from the windows' own blocks: with 2 blocks a drift smaller than the block-to-block
  // noise passes, and on Berea (docs/relperm.md) levels called steady at 2 were still draining
  // by 0.005 per block. 4 blocks per window.
  int window = 4;
  // Relative, on S_w: near S_w = 1 a level that drains 1% of the pores is a change of 0.01, so the
  // sweep's 5% (or even 2%) would call a level steady while it drains.
  double tolerance = 0.005;
  int measure_blocks = 4;
  std::uint64_t max_level_steps = 20000;
  sim::SimulationOptions sim;
  ProgressMeter* meter = nullptr;
  // Called after each level with the levels so far (rockflow pc keeps a partial table with it,
  // so a run stopped from outside keeps what it measured).
  std::function<void(const DrainageResult&)> on_level;
};

struct DrainageLevel {
  double pc_applied = 0;
  MeanWithError saturation;               // S_w in the block
  MeanWithError p_nonwetting, p_wetting;  // reservoir pressures (region stress)
  MeanWithError pc_measured;              // p_N - p_W, block means of the difference
  std::vector<double> block_saturation;   // every block of the level, in order
  std::size_t wetting_in_block = 0, nonwetting_in_block = 0;  // at the end
  // Fluid particles behind a slab (beyond its far face), the most at any block: a slab that lets
  // fluid through no longer holds the pressure it applies.
  std::size_t behind_slabs = 0;
  bool steady = false;
  std::uint64_t steady_after = 0;  // steps of this level when the steady state was detected
  std::uint64_t steps = 0;         // steps run at this level
  int restarts = 0;                // measurements thrown away for a trend
  double push_position = 0, back_position = 0;  // the slabs' mean positions at the end
  double temperature = 0;
  double seconds = 0;
  LeakRecord leaks;
};

struct DrainageResult {
  std::vector<DrainageLevel> levels;  // those run, in order of Pc
  bool inlet_used_up = false;         // stopped early: the push slab reached the block
  bool room_used_up = false;          // stopped early: the back slab reached the box's face
  sim::ParticleSet final_state;       // at the end, when level_states is not kept
  std::vector<sim::ParticleSet> level_states;  // each level's end (keep_states)
  const sim::ParticleSet& end_state() const {
    return level_states.empty() ? final_state : level_states.back();
  }
};

// Checks the cell and options against the model (ConfigError naming the problem).
// `where` starts each message (the scene file, say).
void check_drainage(const sim::Model& model, const sim::BoxSpec& box, const DrainageCell& cell,
                    const DrainageOptions& options, const std::string& where = "drainage");

// Runs the levels from `start` (particles at rest or settled, slabs where they are). The model's
// slab pressures are replaced level by level; its virtual walls are used as given (the caller
// adds the membrane: drainage_membrane). keep_states: fill level_states.
DrainageResult run_drainage(const sim::Model& model, const sim::BoxSpec& box,
                            const sim::ParticleSet& start, const DrainageCell& cell,
                            const DrainageOptions& options, bool keep_states = false);

// The membrane: a virtual wall at the block's outlet face keeping N below it for good.
sim::VirtualWallSpec drainage_membrane(const DrainageCell& cell);

// The capillary entry pressure of a drainage: bracketed by the last level of the drainage branch
// (the levels up to the highest Pc) whose S_w stays at or above `invaded` and the first below it
// (lower = the level before, or 0 for the first level).
struct EntryPressure {
  bool found = false;
  double lower = 0, upper = 0;  // the bracket
  double estimate() const { return 0.5 * (lower + upper); }
  double half_width() const { return 0.5 * (upper - lower); }
};
EntryPressure entry_pressure(const std::vector<DrainageLevel>& levels, double invaded = 0.5);
// The re-entry of W on the imbibition branch (the levels after the highest Pc, falling): the first
// level there whose S_w is back at or above `invaded`, bracketed by its Pc and the level's before.
// Not found when the drainage never went below `invaded`.
EntryPressure reentry_pressure(const std::vector<DrainageLevel>& levels, double invaded = 0.5);

}  // namespace mesorock::pipeline
