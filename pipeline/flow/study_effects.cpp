// rockflow study, the effects study (docs/accuracy.md): the cost of each effect switched on alone
// over the bare conservative pass.
#include <algorithm>
#include <cmath>
#include <limits>

#include "pipeline/flow/statistics.h"
#include "pipeline/flow/study_common.h"
#include "pipeline/flow/wall_liquid.h"

namespace mesorock::pipeline::study_detail {

using namespace wall_liquid;

namespace {

// One scene of the effects study: the effects it switches on (not a scene file's pipeline::Scene).
// The bare pass: standard DPD conservative force (a = 25) only.
struct EffectScene {
  std::string name, effect;
  bool active = true;         // false: the effect is declared in a form that never acts
  std::string base = "bare";  // what its cost is compared with
  bool mdpd = false, thermostat = false, body_force = false, wall_model = false;
  int virtual_wall = 0;  // 0 none, 1 active, 2 passed (until_step = 1)
  bool slab = false;
  int injection = 0;  // 0 none, 1 every 5 steps, 2 never due
  // Observables, each sampled every `every` steps (0: not declared); `chunked` runs in chunks of
  // `every` steps even when nothing is due (an observable never sampled).
  bool stress = false, profile = false, region_counts = false, region_pressure = false;
  bool never_sampled = false;
};

std::vector<EffectScene> effect_scenes(int bare_repeats) {
  std::vector<EffectScene> effects;
  auto add = [&](EffectScene s) { effects.push_back(s); };
  EffectScene s;
  s = {};
  s.name = "mdpd";
  s.effect = "many-body density (mDPD: density pass, A = -40, B = 25)";
  s.mdpd = true;
  add(s);
  s = {};
  s.name = "thermostat";
  s.effect = "DPD thermostat (gamma = 4.5, pair random numbers)";
  s.thermostat = true;
  add(s);
  s = {};
  s.name = "body_force";
  s.effect = "body force (g_z = 0.02 on the fluid)";
  s.body_force = true;
  add(s);
  s = {};
  s.name = "wall_model";
  s.effect = "wall model (Li et al. 2018) on the frozen walls; needs the thermostat";
  s.thermostat = s.wall_model = true;
  s.base = "thermostat";
  add(s);
  s = {};
  s.name = "virtual_wall";
  s.effect = "virtual wall at x = Lx/2 (active)";
  s.virtual_wall = 1;
  add(s);
  s = {};
  s.name = "rigid_slab";
  s.effect = "rigid slab (a layer of fluid moving as one body along z, P = 0)";
  s.slab = true;
  add(s);
  s = {};
  s.name = "injection";
  s.effect = "injection/ejection, one particle every 5 steps";
  s.injection = 1;
  add(s);
  s = {};
  s.name = "stress";
  s.effect = "stress tensor every 10 steps";
  s.stress = true;
  add(s);
  s = {};
  s.name = "profile";
  s.effect = "binned profile along z (0.5 rc bins) every 10 steps";
  s.profile = true;
  add(s);
  s = {};
  s.name = "region_counts";
  s.effect = "region counts (2 types in a box) every 10 steps";
  s.region_counts = true;
  add(s);
  s = {};
  s.name = "region_pressure";
  s.effect = "region pressure (per-particle virial over a box) every 10 steps";
  s.region_pressure = true;
  add(s);
  s = {};
  s.name = "virtual_wall_passed";
  s.effect = "virtual wall whose until_step (1) has passed";
  s.active = false;
  s.virtual_wall = 2;
  add(s);
  s = {};
  s.name = "injection_never_due";
  s.effect = "injection boundary whose start step is never reached";
  s.active = false;
  s.injection = 2;
  add(s);
  s = {};
  s.name = "observables_never_sampled";
  s.effect =
      "stress, profile, region counts and pressure declared, never due (run in chunks of "
      "10 steps)";
  s.active = false;
  s.never_sampled = true;
  add(s);
  s = {};
  s.name = "all_inactive";
  s.effect = "all three inactive forms together";
  s.active = false;
  s.virtual_wall = 2;
  s.injection = 2;
  s.never_sampled = true;
  add(s);
  // The bare pass repeated, spread evenly over the list, so its spread includes any drift.
  EffectScene bare;
  bare.name = "bare";
  bare.effect = "bare conservative pass (standard DPD, a = 25; nothing else)";
  bare.active = false;
  std::vector<EffectScene> out{bare};
  const size_t n = effects.size();
  const size_t gaps = static_cast<size_t>(std::max(2, bare_repeats) - 1);
  size_t next = 0;
  for (size_t r = 1; r <= gaps; ++r) {
    while (next < n * r / gaps) out.push_back(effects[next++]);
    out.push_back(bare);
  }
  while (next < n) out.push_back(effects[next++]);
  return out;
}

// The effects system: the porous benchmark's particles (equilibrated), fluid split into types
// by place so that every scene has the same types: 0 fluid left of x = Lx/2, 1 wall (frozen),
// 2 a layer of fluid at z in [15.1, 15.9) (the slab candidate, above the first row of rings),
// 3 fluid right of x = Lx/2. All pairs have the same parameters in every scene.
struct EffectsSystem {
  sim::BoxSpec box;
  sim::ParticleSet particles;
  double Lx = 0, Ly = 0, Lz = 0;
};

EffectsSystem make_effects_system(const Context& c) {
  BuiltSystem s = make_porous_benchmark(c.z.effect_cells, c.z.effect_cells, c.o.seed + 61);
  s.model.precision = sim::Precision::Single;
  s = equilibrated(c, s, c.z.effect_equilibrate, "effects system");
  EffectsSystem e;
  e.box = s.box;
  e.Lx = s.box.length(0);
  e.Ly = s.box.length(1);
  e.Lz = s.box.length(2);
  e.particles = s.particles;
  for (size_t i = 0; i < e.particles.size(); ++i) {
    if (e.particles.type[i] != 0) continue;  // wall stays 1
    const double z = e.particles.z[i] - e.box.lo[2];
    if (z >= 15.1 && z < 15.9)
      e.particles.type[i] = 2;
    else if (e.particles.x[i] - e.box.lo[0] >= 0.5 * e.Lx)
      e.particles.type[i] = 3;
  }
  return e;
}

sim::Model effect_scene_model(const EffectsSystem& e, const EffectScene& sc, std::uint64_t seed) {
  sim::Model m;
  m.precision = sim::Precision::Single;
  m.seed = seed;
  m.rd = kRd;
  m.add_type({"left", false, {0, 0, 0}});
  m.add_type({"wall", true, {0, 0, 0}});
  m.add_type({"layer", false, {0, 0, 0}});
  m.add_type({"right", false, {0, 0, 0}});
  m.conservative = sc.mdpd ? sim::ConservativeKind::MDPD : sim::ConservativeKind::DPD;
  m.thermostat = sc.thermostat;
  const sim::PairSpec pair =
      sc.mdpd ? sim::PairSpec{-40, 25, kGamma} : sim::PairSpec{25, 0, kGamma};
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) m.set_pair(a, b, pair);
  if (sc.body_force)
    for (int t : {0, 2, 3}) m.types[static_cast<size_t>(t)].body_force = {0, 0, 0.02};
  if (sc.wall_model) {
    m.wall_model.enabled = true;
    m.wall_model.wall_types = 1u << 1;
    m.wall_model.wall_density = 8;
  }
  if (sc.virtual_wall > 0) {
    sim::VirtualWallSpec w;
    w.axis = 0;
    w.position = e.box.lo[0] + 0.5 * e.Lx;
    w.types = 1u << 0;
    w.keep_below = true;
    w.until_step = sc.virtual_wall == 1 ? std::numeric_limits<std::uint64_t>::max() : 1;
    m.virtual_walls.push_back(w);
  }
  if (sc.slab) m.rigid_slabs.push_back({2, 2, 0.0});
  if (sc.injection > 0) {
    sim::InjectionSpec q;
    q.inject_type = 0;
    q.eject_types = 1u << 3;
    // Across the box's top gap between rows of rings (z in [Lz - 1, Lz)): inlet left, outlet
    // right of the mid-plane.
    q.inlet_lo = {e.box.lo[0], e.box.lo[1], e.box.hi[2] - 1};
    q.inlet_hi = {e.box.lo[0] + 0.5 * e.Lx, e.box.hi[1], e.box.hi[2]};
    q.outlet_lo = {e.box.lo[0] + 0.5 * e.Lx, e.box.lo[1], e.box.hi[2] - 1};
    q.outlet_hi = {e.box.hi[0], e.box.hi[1], e.box.hi[2]};
    q.every = 5;
    q.per_event = 1;
    if (sc.injection == 2) q.start_step = std::uint64_t(1) << 50;
    m.injections.push_back(q);
  }
  return m;
}

// Runs `steps` of a scene the way a scene run samples its observables: chunks of 10 steps with
// the due observables after each; a scene without observables runs in one call.
void run_effect_scene_steps(sim::Simulation& s, const EffectScene& sc, const EffectsSystem& e,
                            std::uint64_t steps) {
  const bool observed = sc.stress || sc.profile || sc.region_counts || sc.region_pressure;
  if (!observed && !sc.never_sampled) {
    s.run(steps);
    return;
  }
  constexpr std::uint64_t kEvery = 10;
  const sim::BinGrid profile = sim::BinGrid::profile(
      2, std::max(1, static_cast<int>(std::lround(2 * e.Lz))), e.box.lo, e.box.hi);
  sim::BinGrid region;
  region.lo = e.box.lo;
  region.hi = {e.box.lo[0] + 0.5 * e.Lx, e.box.hi[1], e.box.lo[2] + 0.5 * e.Lz};
  sim::RegionSelection selection;
  selection.lo = region.lo;
  selection.hi = region.hi;
  selection.type_mask = (1u << 0) | (1u << 3);
  double sink = 0;  // keeps the observables' results alive
  for (std::uint64_t done = 0; done < steps; done += kEvery) {
    s.run(std::min(kEvery, steps - done));
    if (sc.never_sampled) continue;
    if (sc.stress) sink += s.stress().pressure();
    if (sc.profile) sink += s.bin_sums(profile)[0];
    if (sc.region_counts)
      for (int t : {0, 3}) {
        region.type_mask = 1u << t;
        sink += s.bin_sums(region)[sim::kBinCount];
      }
    if (sc.region_pressure) sink += s.region_stress(selection).pressure();
  }
  if (!std::isfinite(sink)) throw Unstable("an observable is not finite");
}

constexpr int kEffectStretches = 3;

}  // namespace

StudyResult run_effects(const Context& c) {
  StudyResult out;
  const auto t0 = Clock::now();
  const EffectsSystem e = make_effects_system(c);
  const std::vector<EffectScene> scenes = effect_scenes(c.z.bare_repeats);
  say(c, "effects on the porous benchmark (" + std::to_string(e.particles.size()) +
             " particles), " + std::to_string(scenes.size()) + " scenes");
  // Stretches of whole observable intervals (10 steps).
  const std::uint64_t stretch =
      std::max<std::uint64_t>(10, ((c.z.effect_steps / kEffectStretches + 9) / 10) * 10);
  out.parameters = {{"system", "porous benchmark, " + std::to_string(c.z.effect_cells) + " x " +
                                   std::to_string(c.z.effect_cells) + " cells"},
                    {"particles", e.particles.size()},
                    {"precision", "single"},
                    {"dt", 0.01},
                    {"equilibrate_steps", c.z.effect_equilibrate},
                    {"warm_steps", c.z.effect_warm},
                    {"timed_stretches", kEffectStretches},
                    {"steps_per_stretch", stretch},
                    {"bare_repeats", c.z.bare_repeats},
                    {"observable_interval", 10},
                    {"noise_criterion",
                     "within noise: ms/step <= bare mean + 2 standard deviations "
                     "of the repeated bare pass"}};
  struct Measured {
    const EffectScene* scene = nullptr;
    double ms = NAN, T = NAN;
    std::string pass;
    bool stable = true;
  };
  std::vector<Measured> measured;
  for (const EffectScene& sc : scenes) {
    Measured m;
    m.scene = &sc;
    try {
      auto s = sim::make_simulation(effect_scene_model(e, sc, c.o.seed + 62), e.box, e.particles,
                                    0.01, c.o.sim);
      m.pass = s->pass_name();
      run_effect_scene_steps(*s, sc, e, c.z.effect_warm);
      // The fastest of a few timed stretches of the same run: a load spike on a shared machine
      // only ever adds time.
      for (int k = 0; k < kEffectStretches; ++k) {
        synchronise(*s);
        const auto t1 = Clock::now();
        run_effect_scene_steps(*s, sc, e, stretch);
        synchronise(*s);
        const double ms = 1e3 * std::chrono::duration<double>(Clock::now() - t1).count() /
                          static_cast<double>(stretch);
        m.ms = k == 0 ? ms : std::min(m.ms, ms);
      }
      m.T = temperature_or_throw(*s, sc.name, kRunawayTemperature);
    } catch (const std::exception& u) {
      if (!is_instability(u)) throw;
      m.stable = false;
      say(c, std::string("unstable: ") + u.what());
    }
    say(c, sc.name + ": " + fmt(m.ms, 4) + " ms/step, T " + fmt(m.T, 4));
    measured.push_back(m);
  }
  // The noise of the bare pass.
  std::vector<double> bare;
  for (const auto& m : measured)
    if (m.scene->name == "bare" && std::isfinite(m.ms)) bare.push_back(m.ms);
  double mean = 0, ss = 0;
  for (double v : bare) mean += v;
  mean /= static_cast<double>(bare.size());
  for (double v : bare) ss += (v - mean) * (v - mean);
  const double sd = bare.size() > 1 ? std::sqrt(ss / static_cast<double>(bare.size() - 1)) : 0.0;
  double thermo = NAN;
  for (const auto& m : measured)
    if (m.scene->name == "thermostat") thermo = m.ms;
  const double n = static_cast<double>(e.particles.size());
  bool inactive_ok = true;
  int bare_index = 0;
  for (const auto& m : measured) {
    const EffectScene& sc = *m.scene;
    const double base = sc.base == "thermostat" ? thermo : mean;
    Json row;
    row["scene"] = sc.name;
    if (sc.name == "bare") row["scene"] = "bare#" + std::to_string(++bare_index);
    row["effect"] = sc.effect;
    row["active"] = sc.active;
    row["base"] = sc.base;
    row["pass"] = m.pass;
    row["stable"] = m.stable;
    row["ms_per_step"] = number_or_null(m.ms);
    row["mps"] = number_or_null(n / (m.ms * 1e-3) / 1e6);
    row["cost_vs_base"] = number_or_null(m.ms / base - 1);
    row["cost_vs_bare"] = number_or_null(m.ms / mean - 1);
    row["excess_in_bare_sd"] = number_or_null(sd > 0 ? (m.ms - mean) / sd : NAN);
    const bool within = std::isfinite(m.ms) && m.ms <= mean + 2 * sd;
    row["within_bare_noise"] = within;
    row["temperature_end"] = number_or_null(m.T);
    if (!sc.active && sc.name != "bare") inactive_ok = inactive_ok && within;
    out.rows.push_back(row);
  }
  out.summary = {{"bare_ms_per_step_mean", mean},
                 {"bare_ms_per_step_sd", sd},
                 {"bare_ms_per_step_min", *std::min_element(bare.begin(), bare.end())},
                 {"bare_ms_per_step_max", *std::max_element(bare.begin(), bare.end())},
                 {"bare_noise_relative", mean > 0 ? sd / mean : NAN},
                 {"bare_repeats", bare.size()},
                 {"inactive_scenes_within_noise", inactive_ok}};
  say(c, "bare pass " + fmt(mean, 4) + " +- " + fmt(sd, 2) + " ms/step over " +
             std::to_string(bare.size()) +
             " repeats; inactive scenes within noise: " + (inactive_ok ? "yes" : "no"));
  out.seconds = seconds_since(t0);
  return out;
}

}  // namespace mesorock::pipeline::study_detail
