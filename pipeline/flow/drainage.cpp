#include "pipeline/flow/drainage.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "pipeline/flow/darcy_fit.h"
#include "pipeline/flow/progress.h"
#include "sim/checkpoint.h"
#include "sim/observables.h"

namespace mesorock::pipeline {

namespace {

// What every level shares: the block's two count bins and the box's cross-section.
struct DrainagePlan {
  size_t axis = 0;
  sim::BinGrid wetting, nonwetting;  // one bin over the block, one type each
  double area = 0;                   // the box's cross-section across the axis
};

DrainagePlan make_plan(const sim::BoxSpec& box, const DrainageCell& c) {
  DrainagePlan p;
  p.axis = static_cast<size_t>(c.axis);
  p.wetting.lo = box.lo;
  p.wetting.hi = box.hi;
  p.wetting.lo[p.axis] = c.block_lo;
  p.wetting.hi[p.axis] = c.block_hi;
  p.nonwetting = p.wetting;
  p.wetting.type_mask = 1u << c.wetting;
  p.nonwetting.type_mask = 1u << c.nonwetting;
  p.area = box.volume() / box.length(c.axis);
  return p;
}

// The model with level pressures: push at P_back + Pc towards +axis, back at P_back towards -axis.
sim::Model at_pressures(sim::Model m, const DrainageCell& c, double back, double pc) {
  m.rigid_slabs[static_cast<size_t>(c.push_slab)].applied_pressure = back + pc;
  m.rigid_slabs[static_cast<size_t>(c.back_slab)].applied_pressure = -back;
  return m;
}

// Continues `sim` under the model's slab pressures: its state with the slabs' applied forces (and
// the forces of the last pass, which include them) replaced.
std::unique_ptr<sim::Simulation> with_pressures(sim::Simulation& sim, const sim::Model& model,
                                                const sim::BoxSpec& box, double area,
                                                const sim::SimulationOptions& options) {
  sim::SimulationState state = sim.state();
  for (size_t k = 0; k < state.slabs.size(); ++k) {
    const double applied = model.rigid_slabs[k].applied_pressure * area;
    state.slabs[k].force += applied - state.slabs[k].applied_force;
    state.slabs[k].applied_force = applied;
  }
  return sim::resume_simulation(model, box, state, options);
}

// One sample of the reservoirs' pressures: false when a reservoir is thinner than 1 rc.
bool reservoir_pressures(sim::Simulation& sim, const sim::BoxSpec& box, const DrainageCell& c,
                         double& p_n, double& p_w) {
  const auto a = static_cast<size_t>(c.axis);
  const auto slabs = sim.rigid_slabs();
  const double half = 0.5 * c.slab_thickness;
  sim::RegionSelection n, w;
  n.type_mask = w.type_mask = (1u << c.wetting) | (1u << c.nonwetting);
  n.lo = w.lo = box.lo;
  n.hi = w.hi = box.hi;
  n.lo[a] = slabs[static_cast<size_t>(c.push_slab)].position + half + 1;
  n.hi[a] = c.block_lo - 0.5;
  w.lo[a] = c.block_hi + 0.5;
  w.hi[a] = slabs[static_cast<size_t>(c.back_slab)].position - half - 1;
  if (n.hi[a] - n.lo[a] < 1 || w.hi[a] - w.lo[a] < 1) return false;
  p_n = sim.region_stress(n).pressure();
  p_w = sim.region_stress(w).pressure();
  return true;
}

// The fluid particles behind the slabs now: below the pushing slab's far face and above the back
// slab's.
std::size_t fluid_behind_slabs(sim::Simulation& sim, const sim::BoxSpec& box,
                               const DrainageCell& c) {
  const auto a = static_cast<size_t>(c.axis);
  const auto slabs = sim.rigid_slabs();
  const double half = 0.5 * c.slab_thickness;
  sim::BinGrid behind;
  behind.lo = box.lo;
  behind.hi = box.hi;
  behind.type_mask = (1u << c.wetting) | (1u << c.nonwetting);
  behind.hi[a] = slabs[static_cast<size_t>(c.push_slab)].position - half;
  double n = behind.hi[a] > behind.lo[a] ? sim.bin_sums(behind)[sim::kBinCount] : 0.0;
  behind.lo[a] = slabs[static_cast<size_t>(c.back_slab)].position + half;
  behind.hi[a] = box.hi[a];
  if (behind.hi[a] > behind.lo[a]) n += sim.bin_sums(behind)[sim::kBinCount];
  return static_cast<std::size_t>(n);
}

// The block series of one level and its verdicts.
struct LevelSeries {
  std::vector<double> saturation, p_n, p_w, pc;  // block means
  size_t measure_from = 0;
};

MeanWithError measured(const std::vector<double>& v, size_t from) {
  if (from >= v.size()) return {NAN, NAN, 0};
  return {mean_of(v, from, v.size()), standard_error_of(v, from, v.size()), v.size() - from};
}

// Runs one block of the level: S_w and the pressures sampled every sample_every steps.
void run_block(sim::Simulation& sim, const sim::BoxSpec& box, const DrainagePlan& plan,
               const DrainageCell& c, const DrainageOptions& o, LevelSeries& s,
               DrainageLevel& level) {
  const std::uint64_t samples = std::max<std::uint64_t>(1, o.block_steps / o.sample_every);
  double sw = 0, pn = 0, pw = 0;
  std::uint64_t pressures = 0;
  for (std::uint64_t k = 0; k < samples; ++k) {
    sim.run(o.sample_every);
    const double nw = sim.bin_sums(plan.wetting)[sim::kBinCount];
    const double nn = sim.bin_sums(plan.nonwetting)[sim::kBinCount];
    sw += nw + nn > 0 ? nw / (nw + nn) : NAN;
    level.wetting_in_block = static_cast<size_t>(nw);
    level.nonwetting_in_block = static_cast<size_t>(nn);
    double a = 0, b = 0;
    if (reservoir_pressures(sim, box, c, a, b)) {
      pn += a;
      pw += b;
      ++pressures;
    }
  }
  level.steps += samples * o.sample_every;
  s.saturation.push_back(sw / static_cast<double>(samples));
  const double np = static_cast<double>(pressures);
  s.p_n.push_back(pressures ? pn / np : NAN);
  s.p_w.push_back(pressures ? pw / np : NAN);
  s.pc.push_back(pressures ? (pn - pw) / np : NAN);
  if (!std::isfinite(s.saturation.back()))
    throw NumericalError("drainage: Pc = " + fmt(level.pc_applied) +
                         ": the block's saturation is not finite after " +
                         std::to_string(level.steps) + " steps (no fluid in the block?)");
}

// Runs a level to its steady state (or out of steps, or out of room); fills `level`.
void run_level(sim::Simulation& sim, const sim::BoxSpec& box, const DrainagePlan& plan,
               const DrainageCell& c, const DrainageOptions& o, DrainageLevel& level,
               DrainageResult& result) {
  LevelSeries s;
  const auto w = static_cast<size_t>(o.window);
  const auto t0 = std::chrono::steady_clock::now();
  while (true) {
    run_block(sim, box, plan, c, o, s, level);
    level.leaks.check(sim, sim.step());
    level.behind_slabs = std::max(level.behind_slabs, fluid_behind_slabs(sim, box, c));
    if (!level.steady && halves_agree(s.saturation, w, o.tolerance)) {
      level.steady = true;
      level.steady_after = level.steps;
      s.measure_from = s.saturation.size();
    }
    const auto slabs = sim.rigid_slabs();
    level.push_position = slabs[static_cast<size_t>(c.push_slab)].position;
    level.back_position = slabs[static_cast<size_t>(c.back_slab)].position;
    const double half = 0.5 * c.slab_thickness;
    result.inlet_used_up = level.push_position + half > c.block_lo - 1;
    result.room_used_up = level.back_position + half > box.hi[plan.axis] - 1;
    if (result.inlet_used_up || result.room_used_up) break;
    if (level.steady &&
        s.saturation.size() - s.measure_from >= static_cast<size_t>(o.measure_blocks)) {
      if (!trend_of(s.saturation, s.measure_from, s.saturation.size()).significant()) break;
      level.steady = false;  // still moving: wait for a steady state again
      ++level.restarts;
    }
    if (level.steps + o.block_steps > o.max_level_steps) break;
    if (o.meter) {
      // Past the least plan (2 windows + the measurement): one more block to expect.
      if (s.saturation.size() >= static_cast<size_t>(2 * o.window + o.measure_blocks))
        o.meter->add_total(static_cast<double>(sim.size()) * static_cast<double>(o.block_steps));
      o.meter->set_phase("Pc = " + fmt(level.pc_applied, 4) + ": block " +
                         std::to_string(s.saturation.size()) +
                         (level.steady ? ", steady, measuring" : ", waiting for a steady S_w") +
                         ", S_w = " + fmt(s.saturation.back(), 3));
    }
  }
  const size_t n = s.saturation.size();
  if (level.steady && n - s.measure_from < static_cast<size_t>(o.measure_blocks))
    level.steady = false;
  if (!level.steady) s.measure_from = n - std::min(n, static_cast<size_t>(o.measure_blocks));
  level.saturation = measured(s.saturation, s.measure_from);
  level.p_nonwetting = measured(s.p_n, s.measure_from);
  level.p_wetting = measured(s.p_w, s.measure_from);
  level.pc_measured = measured(s.pc, s.measure_from);
  level.block_saturation = s.saturation;
  level.temperature = sim.kinetic_temperature();
  level.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

sim::VirtualWallSpec drainage_membrane(const DrainageCell& c) {
  sim::VirtualWallSpec v;
  v.axis = c.axis;
  v.position = c.block_hi;
  v.types = 1u << c.nonwetting;
  v.keep_below = true;
  v.until_step = ~std::uint64_t(0);
  return v;
}

void check_drainage(const sim::Model& m, const sim::BoxSpec& box, const DrainageCell& c,
                    const DrainageOptions& o, const std::string& where) {
  auto refuse = [&](const std::string& why) { throw ConfigError(where + ": " + why); };
  if (c.axis < 0 || c.axis > 2) refuse("the flow axis must be x, y or z");
  const auto a = static_cast<size_t>(c.axis);
  if (!(c.block_lo < c.block_hi) || !(c.block_lo > box.lo[a]) || !(c.block_hi < box.hi[a]))
    refuse("the block [" + fmt(c.block_lo) + ", " + fmt(c.block_hi) +
           ") must lie inside the box along the flow axis, with room for both reservoirs");
  for (int t : {c.wetting, c.nonwetting})
    if (!m.is_mobile(t)) refuse("the wetting and non-wetting types must be mobile fluids");
  if (c.wetting == c.nonwetting) refuse("the wetting and non-wetting types must differ");
  const int slabs = static_cast<int>(m.rigid_slabs.size());
  for (int k : {c.push_slab, c.back_slab})
    if (k < 0 || k >= slabs) refuse("needs a pushing slab and a back-pressure slab ([[slabs]])");
  if (c.push_slab == c.back_slab) refuse("the pushing and back-pressure slabs must differ");
  for (int k : {c.push_slab, c.back_slab})
    if (m.rigid_slabs[static_cast<size_t>(k)].axis != c.axis)
      refuse("both slabs must move along the flow axis");
  if (box.periodic[a]) refuse("the box must be closed (not periodic) along the flow axis");
  if (!(c.slab_thickness > 0)) refuse("the slabs have no thickness");
  if (o.pressures.empty()) refuse("no capillary pressure given (--pressures)");
  for (size_t k = 0; k < o.pressures.size(); ++k) {
    if (!std::isfinite(o.pressures[k]) || o.pressures[k] < 0)
      refuse("every capillary pressure must be finite and >= 0 (got " + fmt(o.pressures[k]) + ")");
    if (k > 0 && o.pressures[k] == o.pressures[k - 1])
      refuse("two levels in a row at the same capillary pressure " + fmt(o.pressures[k]));
  }
  if (!std::isfinite(o.back_pressure) || o.back_pressure < 0)
    refuse("the back pressure must be finite and >= 0 (got " + fmt(o.back_pressure) + ")");
  if (!(o.dt > 0) || o.sample_every == 0 || o.block_steps < o.sample_every)
    refuse("needs dt > 0 and blocks of at least one sample (block_steps >= sample_every >= 1)");
  if (o.ramp_parts < 1) refuse("needs at least one ramp part");
  if (o.window < 1 || o.measure_blocks < 3)
    refuse("needs a window of at least 1 block and at least 3 measured blocks (for the trend)");
  if (!(o.tolerance >= 0)) refuse("the tolerance must be >= 0");
  const std::uint64_t least = static_cast<std::uint64_t>(2 * o.window + o.measure_blocks);
  if (o.max_level_steps < o.ramp_steps + least * o.block_steps)
    refuse("the most steps per level (" + std::to_string(o.max_level_steps) +
           ") leave no room for the steady test: the ramp of " + std::to_string(o.ramp_steps) +
           " steps and at least " + std::to_string(least) + " blocks of " +
           std::to_string(o.block_steps) +
           " steps (--max-level-steps, --ramp-steps, --block-steps)");
}

DrainageResult run_drainage(const sim::Model& model, const sim::BoxSpec& box,
                            const sim::ParticleSet& start, const DrainageCell& c,
                            const DrainageOptions& o, bool keep_states) {
  check_drainage(model, box, c, o);
  const DrainagePlan plan = make_plan(box, c);
  DrainageResult result;
  std::unique_ptr<sim::Simulation> sim;
  for (size_t k = 0; k < o.pressures.size(); ++k) {
    DrainageLevel level;
    level.pc_applied = o.pressures[k];
    if (k == 0) {
      const sim::Model m = at_pressures(model, c, o.back_pressure, o.pressures[0]);
      sim = sim::make_simulation(m, box, start, o.dt, o.sim);
    } else {
      // The ramp from the last level's pressure, its last part at this level's.
      const double from = o.pressures[k - 1], to = o.pressures[k];
      const int parts = std::max(1, o.ramp_parts);
      for (int j = 1; j <= parts; ++j) {
        const double pc = j == parts ? to : from + (to - from) * j / parts;
        sim = with_pressures(*sim, at_pressures(model, c, o.back_pressure, pc), box, plan.area,
                             o.sim);
        const std::uint64_t steps = o.ramp_steps * static_cast<std::uint64_t>(j) / parts -
                                    o.ramp_steps * static_cast<std::uint64_t>(j - 1) / parts;
        if (o.meter) o.meter->set_phase("ramp to Pc = " + fmt(to, 4) + ", " + fmt(pc, 4));
        sim->run(steps);
        level.steps += steps;
      }
    }
    run_level(*sim, box, plan, c, o, level, result);
    result.levels.push_back(std::move(level));
    if (keep_states) result.level_states.push_back(sim->particles());
    if (o.on_level) o.on_level(result);
    if (result.inlet_used_up || result.room_used_up) break;
  }
  if (!keep_states) result.final_state = sim->particles();
  return result;
}

namespace {

// The level of the highest Pc: the end of the drainage branch.
size_t highest(const std::vector<DrainageLevel>& levels) {
  size_t top = 0;
  for (size_t k = 1; k < levels.size(); ++k)
    if (levels[k].pc_applied > levels[top].pc_applied) top = k;
  return top;
}

}  // namespace

EntryPressure entry_pressure(const std::vector<DrainageLevel>& levels, double invaded) {
  EntryPressure e;
  if (levels.empty()) return e;
  const size_t top = highest(levels);
  for (size_t k = 0; k <= top; ++k)
    if (levels[k].saturation.mean < invaded) {
      e.found = true;
      e.upper = levels[k].pc_applied;
      e.lower = k > 0 ? levels[k - 1].pc_applied : 0.0;
      break;
    }
  return e;
}

EntryPressure reentry_pressure(const std::vector<DrainageLevel>& levels, double invaded) {
  EntryPressure e;
  if (levels.empty()) return e;
  const size_t top = highest(levels);
  if (!(levels[top].saturation.mean < invaded)) return e;  // never drained
  for (size_t k = top + 1; k < levels.size(); ++k)
    if (levels[k].saturation.mean >= invaded) {
      e.found = true;
      e.lower = levels[k].pc_applied;
      e.upper = levels[k - 1].pc_applied;
      break;
    }
  return e;
}

}  // namespace mesorock::pipeline
