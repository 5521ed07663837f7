#include "pipeline/flow/sweep.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <tuple>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "mesorock/plot.h"
#include "mesorock/staged_outputs.h"
#include "mesorock/version.h"
#include "pipeline/flow/observable_outputs.h"
#include "pipeline/flow/progress.h"
#include "pipeline/flow/statistics.h"
#include "pipeline/flow/viscosity_calibration.h"
#include "sim/ensemble.h"
#include "sim/observables.h"
#include "sim/particle_io.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

namespace {

constexpr double kMillidarcyM2 = 9.869233e-16;  // 1 mD in m^2 (1 D = 9.869233e-13 m^2)

// The force list is checked whole before any work: a repeated force used to be simulated with the
// others and refused only at the fit, losing every point.
void check_forces(const std::string& where, const std::vector<double>& forces) {
  if (forces.empty()) throw ConfigError(where + ": no driving forces given");
  for (double g : forces)
    if (!std::isfinite(g) || !(g > 0))
      throw ConfigError(where + ": every driving force must be a positive number (got " +
                        std::to_string(g) + ")");
  std::vector<double> sorted = forces;
  std::sort(sorted.begin(), sorted.end());
  for (size_t k = 1; k < sorted.size(); ++k)
    if (sorted[k] == sorted[k - 1])
      throw ConfigError(where + ": the force " + std::to_string(sorted[k]) +
                        " is given twice (each point needs its own force)");
}

}  // namespace

void check_steady_options(const SweepSample& s, const SweepOptions& o) {
  if (o.axis < 0 || o.axis > 2) throw ConfigError("sweep: the flow axis must be x, y or z");
  if (o.driven_types == 0) throw ConfigError("sweep: no driven type");
  for (int t = 0; t < s.model.ntypes(); ++t) {
    if (!((o.driven_types >> t) & 1u)) continue;
    const std::string& name = s.model.types[static_cast<size_t>(t)].name;
    if (s.model.types[static_cast<size_t>(t)].frozen)
      throw ConfigError("sweep: driven type " + name + " is frozen");
    for (const auto& r : s.model.rigid_slabs)
      if (r.type == t) throw ConfigError("sweep: driven type " + name + " is a rigid slab");
  }
  if (s.model.body_force_profile != sim::BodyForceProfile::Uniform)
    throw ConfigError("sweep: the scene's body force profile must be uniform");
  if (!(o.fluid_density > 0)) throw ConfigError("sweep: the fluid density must be positive");
  if (!(o.viscosity > 0)) throw ConfigError("sweep: the viscosity must be positive");
  if (o.block_steps == 0 || o.sample_every == 0 || o.block_steps % o.sample_every != 0)
    throw ConfigError("sweep: block steps must be a positive multiple of the sampling interval");
  if (o.window < 2) throw ConfigError("sweep: the steady-state window needs at least 2 blocks");
  if (o.measure_blocks < 2) throw ConfigError("sweep: measuring needs at least 2 blocks");
  if (!(o.tolerance > 0)) throw ConfigError("sweep: the steady-state tolerance must be positive");
  const std::uint64_t least =
      o.warmup_steps + static_cast<std::uint64_t>(2 * o.window + o.measure_blocks) * o.block_steps;
  if (o.max_steps < least)
    throw ConfigError(
        "sweep: max steps " + std::to_string(o.max_steps) +
        " is less than warm-up + (2 window + measure) blocks = " + std::to_string(least));
  for (std::uint32_t phase : o.phases)
    if (phase == 0 || (phase & ~o.driven_types) != 0)
      throw ConfigError("sweep: a measured phase must be a non-empty set of driven types");
}

namespace {

void check_options(const SweepSample& s, const SweepOptions& o) {
  check_forces("sweep", o.forces);
  check_steady_options(s, o);
}

// What every point of a sweep shares.
struct SweepPlan {
  std::vector<double> forces;  // ascending
  double volume = 0;
  sim::BinGrid whole;                // one bin over the box, driven types only: its sum v is V J
  std::vector<sim::BinGrid> phases;  // the same bin for each measured phase's types
  size_t axis = 0;
  std::uint64_t least_blocks = 0;
};

SweepPlan make_plan(const SweepSample& sample, const SweepOptions& o) {
  SweepPlan plan;
  plan.forces = o.forces;
  std::sort(plan.forces.begin(), plan.forces.end());
  plan.volume = sample.box.volume();
  plan.whole.lo = sample.box.lo;
  plan.whole.hi = sample.box.hi;
  plan.whole.type_mask = o.driven_types;
  for (std::uint32_t phase : o.phases) {
    plan.phases.push_back(plan.whole);
    plan.phases.back().type_mask = phase;
  }
  plan.axis = static_cast<size_t>(o.axis);
  plan.least_blocks = static_cast<std::uint64_t>(2 * o.window + o.measure_blocks);
  return plan;
}

// The relative change of J[from, to) across its blocks (least-squares trend) and its error.
std::pair<double, double> drift_of(const std::vector<double>& J, size_t from, size_t to,
                                   double mean) {
  const Trend t = trend_of(J, from, to);
  const double blocks = static_cast<double>(to - from);
  if (mean == 0) return {0.0, 0.0};
  return {t.slope * blocks / mean, std::abs(t.slope_error * blocks / mean)};
}

// One point: `from` driven by `force` with the model's seed `seed`; `final_state`, when given,
// receives its last particles (the next chained point's start). `phases`: the point may name
// what it does on the progress line (false when points run side by side).
SweepPoint run_point(const SweepSample& sample, const SweepOptions& o, const SweepPlan& plan,
                     double force, std::uint64_t seed, const std::string& label,
                     const sim::ParticleSet& from, const sim::SimulationOptions& sim_options,
                     bool phases, sim::ParticleSet* final_state) {
  phases = phases && o.meter;
  SweepPoint p;
  p.force = force;
  p.gradient = o.fluid_density * p.force;
  sim::Model model = sample.model;
  for (int t = 0; t < model.ntypes(); ++t)
    if ((o.driven_types >> t) & 1u) {
      model.types[static_cast<size_t>(t)].body_force = {0, 0, 0};
      model.types[static_cast<size_t>(t)].body_force[plan.axis] = p.force;
    }
  model.seed = seed;
  p.phases.resize(plan.phases.size());
  const auto t_point = std::chrono::steady_clock::now();
  auto sim = sim::make_simulation(model, sample.box, from, o.dt, sim_options);
  if (phases) o.meter->set_phase(label + ": warm-up");
  sim->run(o.warmup_steps);
  p.steps = o.warmup_steps;
  std::vector<double>& J = p.block_flux;
  size_t measure_from = 0;
  const std::uint64_t per_block = o.block_steps / o.sample_every;
  // Every measured series: the total flux and each phase's.
  std::vector<std::vector<double>*> series{&J};
  for (PhaseFlux& f : p.phases) series.push_back(&f.block_flux);
  auto all_steady = [&] {
    for (const auto* v : series)
      if (!halves_agree(*v, static_cast<size_t>(o.window), o.tolerance)) return false;
    return true;
  };
  auto any_trend = [&](size_t from) {
    for (const auto* v : series)
      if (trend_of(*v, from, v->size()).significant()) return true;
    return false;
  };
  std::vector<double> sums(series.size());
  while (true) {
    std::fill(sums.begin(), sums.end(), 0.0);
    for (std::uint64_t s = 0; s < per_block; ++s) {
      sim->run(o.sample_every);
      sums[0] += sim->bin_sums(plan.whole)[sim::kBinVx + plan.axis] / plan.volume;
      for (size_t f = 0; f < plan.phases.size(); ++f)
        sums[f + 1] += sim->bin_sums(plan.phases[f])[sim::kBinVx + plan.axis] / plan.volume;
    }
    for (size_t f = 0; f < series.size(); ++f)
      series[f]->push_back(sums[f] / static_cast<double>(per_block));
    p.steps += o.block_steps;
    if (!std::isfinite(J.back()))
      throw NumericalError("sweep: " + label + ": the flow rate is not finite after " +
                           std::to_string(p.steps) + " steps");
    if (!p.steady && all_steady()) {
      p.steady = true;
      p.steady_after = p.steps;
      measure_from = J.size();
    }
    p.leaks.check(*sim, sim->step());  // the leak invariant (throws past its limit)
    if (p.steady && J.size() - measure_from >= static_cast<size_t>(o.measure_blocks)) {
      if (!any_trend(measure_from)) break;
      // Still drifting: this measurement does not describe a steady flow. Wait again.
      p.steady = false;
      ++p.restarts;
    }
    if (p.steps + o.block_steps > o.max_steps) break;
    if (o.meter) {  // (thread-safe: ProgressMeter)
      // Past the least plan (warm-up + 2 windows + measurement): one more block to expect.
      if (J.size() >= plan.least_blocks)
        o.meter->add_total(static_cast<double>(sample.particles.size()) *
                           static_cast<double>(o.block_steps));
      if (phases)
        o.meter->set_phase(label + ": block " + std::to_string(J.size()) +
                           (p.steady ? ", steady, measuring" : ", waiting for a steady flow") +
                           ", J = " + fmt(J.back(), 3));
    }
  }
  // Out of steps before the measurement was complete (steady only in the last blocks, after a
  // restart): not steady, measured on the last blocks. Measuring from the steady block on gave an
  // empty or one-block measurement, a NaN flux (found by the relperm tests).
  if (p.steady && J.size() - measure_from < size_t(o.measure_blocks)) p.steady = false;
  if (!p.steady) measure_from = J.size() - std::min(J.size(), size_t(o.measure_blocks));
  p.flux = mean_of(J, measure_from, J.size());
  p.flux_error = standard_error_of(J, measure_from, J.size());
  std::tie(p.drift, p.drift_error) = drift_of(J, measure_from, J.size(), p.flux);
  for (PhaseFlux& f : p.phases) {
    f.flux = mean_of(f.block_flux, measure_from, f.block_flux.size());
    f.flux_error = standard_error_of(f.block_flux, measure_from, f.block_flux.size());
    std::tie(f.drift, f.drift_error) =
        drift_of(f.block_flux, measure_from, f.block_flux.size(), f.flux);
  }
  if (p.steady && any_trend(measure_from)) p.steady = false;  // ran out of steps while drifting
  p.darcy_velocity = p.flux / o.fluid_density;
  p.darcy_velocity_error = p.flux_error / o.fluid_density;
  p.permeability = o.viscosity * p.darcy_velocity / p.gradient;
  p.permeability_error =
      std::abs(p.permeability) *
      std::hypot(p.flux != 0 ? p.flux_error / p.flux : 0.0, o.viscosity_error / o.viscosity);
  p.temperature = sim->kinetic_temperature();
  p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_point).count();
  if (final_state) *final_state = sim->particles();
  return p;
}

}  // namespace

sim::ParticleSet prepare_sample(const SweepSample& sample, const SweepOptions& o) {
  if (o.prepare.empty()) return sample.particles;
  // The scene's early stages, once, without the driving force.
  sim::Model model = sample.model;
  for (auto& t : model.types) t.body_force = {0, 0, 0};
  auto sim =
      sim::make_simulation(model, sample.box, sample.particles, o.prepare.front().second, o.sim);
  if (o.meter) o.meter->set_phase("preparing: the scene's stages before the last");
  for (const auto& [steps, dt] : o.prepare) {
    sim->set_dt(dt);
    sim->run(steps);
  }
  return sim->particles();
}

SweepPoint run_steady_point(const SweepSample& sample, const SweepOptions& o, double force,
                            std::uint64_t seed, const std::string& label,
                            const sim::ParticleSet& from, const sim::SimulationOptions& sim_options,
                            sim::ParticleSet* final_state) {
  check_steady_options(sample, o);
  check_forces("sweep", {force});
  // Side by side (several points on their threads at once), no point names the progress line.
  return run_point(sample, o, make_plan(sample, o), force, seed, label, from, sim_options,
                   !o.side_by_side, final_state);
}

std::vector<SweepPoint> run_sweep(const SweepSample& sample, const SweepOptions& o) {
  check_options(sample, o);
  const SweepPlan plan = make_plan(sample, o);
  const std::vector<double>& forces = plan.forces;
  std::uint64_t prepare_steps = 0;
  for (const auto& stage : o.prepare) prepare_steps += stage.first;
  if (o.meter)
    o.meter->add_total(
        static_cast<double>(sample.particles.size()) *
        (static_cast<double>(forces.size()) *
             static_cast<double>(o.warmup_steps + plan.least_blocks * o.block_steps) +
         static_cast<double>(prepare_steps)));
  std::vector<SweepPoint> points;
  const sim::ParticleSet prepared = prepare_sample(sample, o);
  // Point k: its force, an independent thermal noise (the seed), its name.
  auto point = [&](size_t k, const sim::ParticleSet& from, const sim::SimulationOptions& so,
                   bool phases, sim::ParticleSet* final_state) {
    const std::string label = "point " + std::to_string(k + 1) + "/" +
                              std::to_string(forces.size()) + " g = " + fmt(forces[k], 3);
    return run_point(sample, o, plan, forces[k], sample.model.seed + k, label, from, so, phases,
                     final_state);
  };
  if (o.side_by_side) {
    // Every point from the prepared particles, all at once (sim/ensemble.h); on the CPU they
    // share the cores.
    const sim::SimulationOptions each = sim::ensemble_member_options(
        o.sim, static_cast<int>(forces.size()), static_cast<double>(prepared.size()));
    if (o.meter) o.meter->set_phase(std::to_string(forces.size()) + " points side by side");
    points.resize(forces.size());
    sim::run_ensemble(static_cast<int>(forces.size()), [&](int k) {
      points[static_cast<size_t>(k)] =
          point(static_cast<size_t>(k), prepared, each, false, nullptr);
    });
    return points;
  }
  sim::ParticleSet start = prepared;
  for (size_t k = 0; k < forces.size(); ++k)
    points.push_back(point(k, o.chain ? start : prepared, o.sim, true, o.chain ? &start : nullptr));
  return points;
}

SweepFits fit_sweep(const std::vector<SweepPoint>& points, double viscosity,
                    double viscosity_error) {
  std::vector<double> G, q, e;
  for (const auto& p : points) {
    G.push_back(p.gradient);
    q.push_back(p.darcy_velocity);
    e.push_back(p.darcy_velocity_error);
  }
  SweepFits f;
  f.darcy = fit_proportional(G, q, e);
  f.k = viscosity * f.darcy.slope;
  f.k_error =
      std::abs(f.k) * std::hypot(f.darcy.slope_error / f.darcy.slope, viscosity_error / viscosity);
  if (points.size() >= 2) f.line = fit_line(G, q, e);
  if (points.size() >= 3) f.quadratic = fit_quadratic_through_origin(G, q, e);
  return f;
}

// --------------------------------------------------------------------------------------------
// The command.

namespace {

int parse_axis(const std::string& a) {
  if (a == "x") return 0;
  if (a == "y") return 1;
  if (a == "z") return 2;
  throw ConfigError("sweep: --axis must be x, y or z (got " + a + ")");
}

// The provenance JSON a particle file records (not an object: none, or not JSON).
nlohmann::json particle_file_provenance(const fs::path& file) {
  return nlohmann::json::parse(sim::read_particle_file_meta(file).provenance_json, nullptr, false);
}

// The fluid density a particle file records for the driven types, if any: `rockprep run
// --layout permeability` writes {"fluid_types": [...], "fluid_density": n} in the file's
// provenance, since a file block of the scene has no density.
std::optional<double> density_from_particle_file(const Scene& scene, const InitSpec& b,
                                                 std::uint32_t driven) {
  const nlohmann::json j = particle_file_provenance(b.file);
  if (!j.is_object() || !j.contains("fluid_density") || !j["fluid_density"].is_number() ||
      !j.contains("fluid_types") || !j["fluid_types"].is_array())
    return std::nullopt;
  for (int t = 0; t < scene.model.ntypes(); ++t) {
    if (!((driven >> t) & 1u)) continue;
    const std::string& name = scene.model.types[static_cast<size_t>(t)].name;
    if (std::find(j["fluid_types"].begin(), j["fluid_types"].end(), name) == j["fluid_types"].end())
      return std::nullopt;
  }
  return j["fluid_density"].get<double>();
}

}  // namespace

// The fluid density the scene's [[init]] blocks give the driven types (one value), if any.
std::optional<double> density_from_scene(const Scene& scene, std::uint32_t driven) {
  std::optional<double> found;
  for (const auto& b : scene.init) {
    double rho = 0;
    if (b.kind == InitSpec::Kind::File) {
      const std::optional<double> recorded = density_from_particle_file(scene, b, driven);
      if (!recorded) continue;
      rho = *recorded;
    } else {
      const int t = scene.model.type_index(b.type);
      if (t < 0 || !((driven >> t) & 1u)) continue;
      double v = 1;
      for (int a = 0; a < 3; ++a) v *= b.hi[static_cast<size_t>(a)] - b.lo[static_cast<size_t>(a)];
      rho = b.density ? *b.density : static_cast<double>(b.count.value_or(0)) / v;
    }
    if (found && std::abs(*found - rho) > 1e-9 * rho)
      throw ConfigError(scene.path.string() +
                        ": sweep: the driven types' [[init]] blocks have different densities (" +
                        fmt(*found) + ", " + fmt(rho) + "): give --fluid-density");
    found = rho;
  }
  return found;
}

std::uint64_t viscous_warmup_steps(double pore_diameter, double kinematic_viscosity, double dt,
                                   std::uint64_t least) {
  if (!(pore_diameter > 0) || !(kinematic_viscosity > 0) || !(dt > 0) ||
      !std::isfinite(pore_diameter * pore_diameter / kinematic_viscosity / dt))
    throw ConfigError("sweep: the warm-up needs a positive pore diameter, viscosity and dt");
  const double pi = 3.14159265358979323846;
  const double relaxation = pore_diameter * pore_diameter / (pi * pi * kinematic_viscosity);
  const double steps = std::ceil(kWarmupRelaxations * relaxation / dt / 100 - 1e-9) * 100;
  // Beyond 10^12 steps no sweep would end: the caller's max steps refuses it.
  return std::max(least, static_cast<std::uint64_t>(std::min(steps, 1e12)));
}

std::optional<double> median_pore_diameter_of(const Scene& scene) {
  for (const auto& b : scene.init) {
    if (b.kind != InitSpec::Kind::File) continue;
    const nlohmann::json j = particle_file_provenance(b.file);
    if (!j.is_object() || !j.contains("pore_sizes") || !j["pore_sizes"].is_object()) continue;
    const nlohmann::json& sizes = j["pore_sizes"];
    if (!sizes.contains("median_rc") || !sizes["median_rc"].is_number()) continue;
    const double d = sizes["median_rc"].get<double>();
    if (!(d > 0) || !std::isfinite(d))
      throw ConfigError(b.file.string() + ": pore_sizes.median_rc in the provenance is " + fmt(d) +
                        ", not a positive diameter");
    return d;
  }
  return std::nullopt;
}

namespace {

// sweep_warmup's choice: the record, with o.warmup_steps and o.max_steps set.
nlohmann::json choose_warmup(const Scene& scene, const SweepCommand& c, SweepOptions& o,
                             bool viscosity_known) {
  if (!c.warmup_from_pores) return {{"steps", o.warmup_steps}, {"source", "given"}};
  const std::optional<double> d = median_pore_diameter_of(scene);
  if (!d)
    return {{"steps", o.warmup_steps},
            {"source", "the default: the sample records no pore sizes (rockprep run writes them)"}};
  if (!viscosity_known)
    return {{"steps", o.warmup_steps},
            {"source", "the default: no viscosity to scale it by (--viscosity or --sweep)"}};
  const double nu = o.viscosity / o.fluid_density;  // m = 1
  const std::uint64_t pores = viscous_warmup_steps(*d, nu, o.dt, 0);
  const std::uint64_t steps = std::max(pores, o.warmup_steps);
  const std::string times = fmt(kWarmupRelaxations) +
                            " momentum-diffusion times of the median pore (d = " + fmt(*d, 3) +
                            " rc, nu = " + fmt(nu, 3) + ")";
  const std::string source = pores > o.warmup_steps
                                 ? times
                                 : "the least warm-up; " + times + " are " + std::to_string(pores);
  if (c.max_steps_from_warmup) o.max_steps += steps - o.warmup_steps;
  o.warmup_steps = steps;
  return {{"steps", steps},
          {"source", source},
          {"median_pore_diameter_rc", *d},
          {"kinematic_viscosity", nu},
          {"relaxations", kWarmupRelaxations},
          {"rule",
           "relaxations x d^2 / (pi^2 nu) in steps of dt, rounded up to 100, at least the "
           "default warm-up"}};
}

}  // namespace

nlohmann::json sweep_warmup(const Scene& scene, const SweepCommand& c, SweepOptions& o,
                            const std::string& tool, bool viscosity_known) {
  const nlohmann::json warmup = choose_warmup(scene, c, o, viscosity_known);
  if (c.warmup_from_pores && c.progress) {
    clear_progress_line(std::cerr);
    std::cerr << tool << ": warm-up " << o.warmup_steps << " steps ("
              << warmup.at("source").get<std::string>() << "; --warmup sets it)\n";
  }
  return warmup;
}

// The types the sweep drives: --types, else the scene's body-force types, else every mobile one.
std::uint32_t driven_types_of(const Scene& scene, const SweepCommand& c, const std::string& where) {
  const sim::Model& model = scene.model;
  std::uint32_t driven = 0;
  if (!c.types.empty()) {
    for (const auto& name : c.types) {
      const int t = model.type_index(name);
      if (t < 0) throw ConfigError(where + ": --types: no type named " + name);
      driven |= 1u << t;
    }
  } else {
    for (int t = 0; t < model.ntypes(); ++t) {
      const auto& f = model.types[static_cast<size_t>(t)].body_force;
      if (f[0] != 0 || f[1] != 0 || f[2] != 0) driven |= 1u << t;
    }
    if (driven == 0) driven = model.mobile_mask();
  }
  if (driven == 0)
    throw ConfigError(where + ": no driven type (every type is frozen or a rigid slab)");
  return driven;
}

// The flow axis: --axis, else the axis of the driven types' largest body force.
int flow_axis_of(const Scene& scene, const SweepCommand& c, std::uint32_t driven) {
  if (!c.axis.empty()) return parse_axis(c.axis);
  int axis = 0;
  double best = 0;
  for (int t = 0; t < scene.model.ntypes(); ++t)
    if ((driven >> t) & 1u)
      for (int a = 0; a < 3; ++a) {
        const double v = std::abs(scene.model.types[static_cast<size_t>(t)].body_force[a]);
        if (v > best) best = v, axis = a;
      }
  return axis;
}

namespace {

// The viscosity that turns the flux into a permeability: given, or calibrated (cached) for the
// driven fluid. Returns its record for sweep.json.
nlohmann::json sweep_viscosity(const Scene& scene, const SweepCommand& c, const std::string& where,
                               SweepOptions& o, ProgressMeter& meter) {
  if (c.viscosity) {
    o.viscosity = *c.viscosity;
    o.viscosity_error = c.viscosity_error.value_or(0.0);
    return {{"value", o.viscosity}, {"error", o.viscosity_error}, {"source", "given"}};
  }
  const sim::Model& model = scene.model;
  const std::uint32_t driven = o.driven_types;
  int first = -1;
  for (int t = 0; t < model.ntypes() && first < 0; ++t)
    if ((driven >> t) & 1u) first = t;
  const sim::PairSpec p = model.pair(first, first);
  for (int a = 0; a < model.ntypes(); ++a)
    for (int b = 0; b < model.ntypes(); ++b)
      if (((driven >> a) & 1u) && ((driven >> b) & 1u)) {
        const sim::PairSpec& q = model.pair(a, b);
        if (q.A != p.A || q.B != p.B || q.gamma != p.gamma)
          throw ConfigError(where +
                            ": the driven types are not one fluid (their pair parameters "
                            "differ), so no single viscosity calibration fits: give "
                            "--viscosity");
      }
  FluidSpec fluid;
  fluid.conservative = model.conservative;
  fluid.density_kernel = model.density_kernel;
  fluid.A = p.A;
  fluid.B = p.B;
  fluid.gamma = p.gamma;
  fluid.rd = model.rd;
  fluid.kBT = model.kBT;
  fluid.lambda = model.lambda;
  fluid.density = o.fluid_density;
  fluid.dt = o.dt;
  fluid.precision = model.precision;
  if (!model.thermostat || !(p.gamma > 0))
    throw ConfigError(where + ": the viscosity calibration needs the thermostat: give --viscosity");
  const fs::path cache = c.viscosity_cache.empty() ? default_viscosity_cache() : c.viscosity_cache;
  const CalibratedViscosity v =
      calibrated_viscosity(fluid, parse_calibration_size(c.calibration), cache, o.sim, &meter);
  o.viscosity = v.value;
  o.viscosity_error = v.error;
  return {{"value", v.value},
          {"error", v.error},
          {"source", v.source},
          {"cache_file", v.cache_file.string()},
          {"calibration", v.record}};
}

// What the sweep ran on and measured, for its outputs.
struct SweepRecord {
  const Scene& scene;
  const SweepOptions& o;
  const std::vector<SweepPoint>& points;
  const SweepFits& fits;
  PermeabilityUnits k;
};

// sweep.csv (a row per point) and sweep_blocks.csv (the flux of every block).
void write_sweep_tables(StagedOutputs& outputs, const fs::path& out_dir, const SweepRecord& r) {
  const SweepOptions& o = r.o;
  const bool solid = r.scene.model.solid.mask != nullptr;
  std::ostringstream s;
  s << std::setprecision(10);
  s << "# mesorock " << kVersion << " (" << kGitCommit << "), rockflow sweep of "
    << r.scene.path.string() << "\n";
  s << "# reduced units (rc = m = kBT = 1): g per particle, G = n_f g with n_f = "
    << o.fluid_density << ", J = sum v / V_total, q = J / n_f (Darcy velocity), k = mu q / G "
    << "with mu = " << o.viscosity << " +- " << o.viscosity_error
    << "; errors one standard error; k_nm2 and k_mD need [units] nm_per_rc"
    << (r.k.units ? " (" + fmt(r.scene.units.nm_per_rc) + " nm per rc)"
                  : std::string(" (not given)"))
    << "\n";
  s << "point,force_g,gradient_G,flux_J,flux_J_error,darcy_velocity_q,darcy_velocity_q_error,"
       "k_rc2,k_rc2_error,k_nm2,k_nm2_error,k_mD,k_mD_error,steady,steady_after_steps,steps,"
       "temperature,drift,drift_error,restarts"
    << (solid ? ",solid_inside_max,solid_max_depth" : "") << "\n";
  for (size_t k = 0; k < r.points.size(); ++k) {
    const SweepPoint& p = r.points[k];
    s << k + 1 << "," << p.force << "," << p.gradient << "," << p.flux << "," << p.flux_error << ","
      << p.darcy_velocity << "," << p.darcy_velocity_error << "," << p.permeability << ","
      << p.permeability_error << ",";
    if (r.k.units)
      s << p.permeability * r.k.nm2 << "," << p.permeability_error * r.k.nm2 << ","
        << p.permeability * r.k.mD << "," << p.permeability_error * r.k.mD;
    else
      s << ",,,";
    s << "," << (p.steady ? 1 : 0) << "," << p.steady_after << "," << p.steps << ","
      << p.temperature << "," << p.drift << "," << p.drift_error << "," << p.restarts;
    if (solid) s << "," << p.leaks.max_inside << "," << p.leaks.max_depth;
    s << "\n";
  }
  outputs.write_text(out_dir / "sweep.csv", s.str());
  std::ostringstream b;
  b << std::setprecision(10);
  b << "# flux J = sum v / V_total of each block of " << o.block_steps
    << " steps after the warm-up of " << o.warmup_steps << " steps\n";
  b << "point,force_g,block,steps,flux_J\n";
  for (size_t k = 0; k < r.points.size(); ++k)
    for (size_t j = 0; j < r.points[k].block_flux.size(); ++j)
      b << k + 1 << "," << r.points[k].force << "," << j + 1 << ","
        << o.warmup_steps + (j + 1) * o.block_steps << "," << r.points[k].block_flux[j] << "\n";
  outputs.write_text(out_dir / "sweep_blocks.csv", b.str());
}

nlohmann::json points_json(const SweepRecord& r) {
  nlohmann::json pj = nlohmann::json::array();
  for (const auto& p : r.points)
    pj.push_back({{"force_g", p.force},
                  {"gradient_G", p.gradient},
                  {"flux_J", p.flux},
                  {"flux_J_error", p.flux_error},
                  {"darcy_velocity_q", p.darcy_velocity},
                  {"darcy_velocity_q_error", p.darcy_velocity_error},
                  {"permeability", r.k.json(p.permeability, p.permeability_error)},
                  {"steady", p.steady},
                  {"steady_after_steps", p.steady_after},
                  {"steps", p.steps},
                  {"temperature", p.temperature},
                  {"drift", p.drift},
                  {"drift_error", p.drift_error},
                  {"drift_note",
                   "change of J across the measured blocks relative to J (least-squares trend)"},
                  {"restarts", p.restarts}});
  if (r.scene.model.solid.mask)
    for (size_t k = 0; k < r.points.size(); ++k)
      pj[k]["solid_invariant"] = r.points[k].leaks.json();
  return pj;
}

// The quadratic fit's relative departure from the Darcy line at the largest gradient, and its
// error (0, 0 without the quadratic fit).
std::pair<double, double> quadratic_departure(const SweepRecord& r) {
  if (!r.fits.quadratic) return {0.0, 0.0};
  const double Gmax = r.points.back().gradient;
  return {r.fits.quadratic->departure(Gmax), r.fits.quadratic->departure_error(Gmax)};
}

nlohmann::json fits_json(const SweepRecord& r) {
  const SweepFits& fits = r.fits;
  nlohmann::json j = {
      {"darcy",
       {{"model", "q = (k / mu) G"},
        {"slope", fits.darcy.slope},
        {"slope_error", fits.darcy.slope_error},
        {"permeability", r.k.json(fits.k, fits.k_error)},
        {"chi2", fits.darcy.chi2},
        {"dof", fits.darcy.dof},
        {"chi2_99", chi2_99(fits.darcy.dof)},
        {"consistent", fits.darcy.dof < 1 || fits.darcy.chi2 <= chi2_99(fits.darcy.dof)}}}};
  if (fits.line)
    j["line"] = {{"model", "q = a + b G"},
                 {"intercept", fits.line->intercept},
                 {"intercept_error", fits.line->intercept_error},
                 {"slope", fits.line->slope},
                 {"slope_error", fits.line->slope_error},
                 {"chi2", fits.line->chi2},
                 {"dof", fits.line->dof}};
  if (fits.quadratic) {
    const QuadraticFit& qf = *fits.quadratic;
    const auto [deviation, deviation_error] = quadratic_departure(r);
    const double mu = r.o.viscosity;
    j["quadratic"] = {
        {"model", "q = c1 G + c2 G^2"},
        {"c1", qf.c1},
        {"c1_error", qf.c1_error},
        {"c2", qf.c2},
        {"c2_error", qf.c2_error},
        {"covariance", qf.covariance},
        {"chi2", qf.chi2},
        {"dof", qf.dof},
        {"permeability_at_zero_gradient", r.k.json(mu * qf.c1, mu * qf.c1_error)},
        {"forchheimer_beta", -qf.c2 / (qf.c1 * qf.c1 * qf.c1)},
        {"forchheimer_note",
         "to first order G = q / c1 + beta q^2 with beta = -c2 / c1^3 (reduced units)"},
        {"deviation_at_largest_gradient", deviation},
        {"deviation_error", deviation_error},
        {"deviation_significant", std::abs(deviation) > 2 * deviation_error},
        {"deviation_note",
         "c2 G_max / c1: relative departure of the flow rate from the Darcy line at the "
         "largest gradient; significant when beyond two standard errors"}};
  }
  return j;
}

// The points' throughput (the calibration and the preparing stages left out): MPS/s over all
// particles and over the mobile ones (frozen walls count as particles but do not move).
nlohmann::json points_throughput(const SweepRecord& r, std::size_t particles, std::size_t mobile) {
  double seconds = 0, steps = 0;
  nlohmann::json each = nlohmann::json::array();  // timings stay out of "points" (results)
  for (const auto& p : r.points) {
    // Side by side, the points' times overlap: the longest is the time they took.
    seconds = r.o.side_by_side ? std::max(seconds, p.seconds) : seconds + p.seconds;
    steps += static_cast<double>(p.steps);
    each.push_back(p.seconds);
  }
  const auto rate = [&](std::size_t n) {
    return seconds > 0 ? static_cast<double>(n) * steps / seconds / 1e6 : 0.0;
  };
  nlohmann::json j;
  j["seconds"] = seconds;
  j["point_seconds"] = each;
  j["steps"] = steps;
  j["particles"] = particles;
  j["mobile_particles"] = mobile;
  j["mps"] = rate(particles);
  j["mobile_mps"] = rate(mobile);
  return j;
}

nlohmann::json sweep_summary(const SweepRecord& r, std::size_t fluid_count,
                             const nlohmann::json& viscosity, const ProgressMeter& meter) {
  const SweepOptions& o = r.o;
  const sim::Model& model = r.scene.model;
  nlohmann::json summary = {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"command", "rockflow sweep"},
      {"scene_file", r.scene.path.string()},
      {"scene_name", r.scene.name},
      {"backend", sim::to_string(o.sim.backend)},
      {"precision", sim::to_string(model.precision)},
      {"flow_axis", std::string(1, "xyz"[o.axis])},
      {"driven_types", nlohmann::json::array()},
      {"fluid_particles", fluid_count},
      {"fluid_density", o.fluid_density},
      {"porosity_estimate",
       static_cast<double>(fluid_count) / (o.fluid_density * r.scene.box.volume())},
      {"viscosity", viscosity},
      {"definitions",
       "G = n_f g (pressure-gradient equivalent of the body force), J = sum v / V_total, "
       "q = J / n_f (Darcy velocity), k = mu q / G; docs/permeability.md"},
      {"steady_state", steady_state_json(o)},
      {"dt", o.dt},
      {"prepared_with",
       [&] {
         nlohmann::json j = nlohmann::json::array();
         for (const auto& [steps, dt] : o.prepare) j.push_back({{"steps", steps}, {"dt", dt}});
         return j;
       }()},
      {"solid", solid_json(model.solid,
                           [&] {
                             LeakRecord all;
                             for (const SweepPoint& p : r.points) all.merge(p.leaks);
                             return all;
                           }())},
      {"points", points_json(r)},
      {"fits", fits_json(r)},
      {"units", units_json(r.k.units)},
      {"particle_steps", meter.work()},
      {"wall_seconds", meter.seconds()},
      {"outputs", {"sweep.csv", "sweep_blocks.csv", "sweep.json", "sweep.png"}},
      {"scene", r.scene.source_text}};
  for (int t = 0; t < model.ntypes(); ++t)
    if ((o.driven_types >> t) & 1u)
      summary["driven_types"].push_back(model.types[static_cast<size_t>(t)].name);
  return summary;
}

// sweep.png: q against G with error bars, the Darcy line and the quadratic.
void write_sweep_plot(StagedOutputs& outputs, const fs::path& out_dir, const SweepRecord& r) {
  plot::Plot pl;
  pl.title = "Darcy velocity vs pressure gradient (" + r.scene.name + ")";
  pl.x_label = "G = n g  (kBT / rc^4)";
  pl.y_label = "q  (rc / tau)";
  pl.style = plot::PlotStyle::kPoints;
  pl.label = "measured (1 s.e.)";
  pl.x_from_zero = true;
  for (const auto& p : r.points) {
    pl.x.push_back(p.gradient);
    pl.y.push_back(p.darcy_velocity);
    pl.y_error.push_back(p.darcy_velocity_error);
  }
  const double Gmax = r.points.back().gradient * 1.05;
  plot::Series darcy;
  std::string k_text = "Darcy: k = " + fmt(r.fits.k, 3) + " rc^2";
  if (r.k.units) k_text += " = " + fmt(r.fits.k * r.k.mD, 3) + " mD";
  darcy.label = k_text;
  darcy.x = {0, Gmax};
  darcy.y = {0, r.fits.darcy.slope * Gmax};
  pl.more.push_back(darcy);
  if (r.fits.quadratic) {
    const auto [deviation, deviation_error] = quadratic_departure(r);
    plot::Series quad;
    quad.label = "quadratic: deviation " + fmt(100 * deviation, 2) + " +- " +
                 fmt(100 * deviation_error, 2) + " %";
    for (int i = 0; i <= 40; ++i) {
      const double G = Gmax * i / 40.0;
      quad.x.push_back(G);
      quad.y.push_back(r.fits.quadratic->c1 * G + r.fits.quadratic->c2 * G * G);
    }
    pl.more.push_back(quad);
  }
  const fs::path png = out_dir / "sweep.png";
  plot::write_plot_png(pl, outputs.stage(png), png.string());
}

}  // namespace

nlohmann::json steady_state_json(const SweepOptions& o) {
  return {{"warmup_steps", o.warmup_steps},
          {"block_steps", o.block_steps},
          {"sample_every", o.sample_every},
          {"window_blocks", o.window},
          {"tolerance", o.tolerance},
          {"measure_blocks", o.measure_blocks},
          {"max_steps", o.max_steps},
          {"chained", o.chain && !o.side_by_side},
          {"side_by_side", o.side_by_side},
          {"rule",
           "steady when the mean flux of the last window blocks agrees with the window before "
           "within the tolerance (relative) or two combined standard errors; then measure_blocks "
           "blocks give the flux and its standard error, unless their least-squares trend is "
           "beyond Student's t_99 standard errors (a drifting flux: the point waits again); with "
           "phases measured apart, the total flux and every phase's must pass"}};
}

PermeabilityUnits::PermeabilityUnits(const Scene& scene) {
  if (!(scene.units.nm_per_rc > 0)) return;
  units = unit_system_of(scene.units);
  nm2 = scene.units.nm_per_rc * scene.units.nm_per_rc;
  mD = units->permeability_m2(1.0) / kMillidarcyM2;
}

nlohmann::json PermeabilityUnits::json(double k, double e) const {
  nlohmann::json j = {{"rc2", k}, {"rc2_error", e}};
  if (units) {
    j["nm2"] = k * nm2;
    j["nm2_error"] = e * nm2;
    j["mD"] = k * mD;
    j["mD_error"] = e * mD;
  }
  return j;
}

nlohmann::json run_sweep_command(const Scene& scene, const SweepCommand& c) {
  const std::string where = scene.path.string() + ": sweep";
  if (scene.stages.empty()) throw ConfigError(where + ": the scene has no [[run]] stage");
  const sim::Model& model = scene.model;
  const std::uint32_t driven = driven_types_of(scene, c, where);
  const int axis = flow_axis_of(scene, c, driven);
  check_forces(where, c.forces);
  for (int t = 0; t < model.ntypes(); ++t) {
    if (((driven >> t) & 1u) && !model.is_mobile(t))
      throw ConfigError(where + ": driven type " + model.types[static_cast<size_t>(t)].name +
                        " does not flow (frozen or a rigid slab)");
  }
  std::optional<double> density = c.fluid_density;
  if (!density) density = density_from_scene(scene, driven);
  if (!density)
    throw ConfigError(where +
                      ": give --fluid-density (the fluid's number density in the pores; no "
                      "[[init]] block of a driven type says)");
  if (!(*density > 0)) throw ConfigError(where + ": --fluid-density must be positive");

  // The sample, built before any step: a sample without solid (an all-pore image, a bulk box)
  // has no permeability (the driven fluid accelerates without bound; such runs reported
  // k = 3.3 and 11.9 rc^2), so it is refused here rather than given a number.
  SweepSample sample{scene.model, scene.box, build_initial_particles(scene)};
  std::size_t fluid_count = 0, frozen_count = 0, mobile_count = 0;
  for (auto t : sample.particles.type) {
    fluid_count += (driven >> t) & 1u;
    frozen_count += model.types[static_cast<size_t>(t)].frozen ? 1 : 0;
    mobile_count += model.is_mobile(t) ? 1 : 0;
  }
  const bool solid_voxels =
      model.solid.mask && std::find(model.solid.mask->solid.begin(), model.solid.mask->solid.end(),
                                    std::uint8_t{1}) != model.solid.mask->solid.end();
  if (frozen_count == 0 && !solid_voxels)
    throw ConfigError(where +
                      ": the sample has no solid (no wall particles and no solid voxel), and a "
                      "sample without solid has no permeability");

  ProgressMeter meter("rockflow sweep", std::cerr, c.progress);
  SweepOptions o = c.run;
  o.sim.on_run = [&meter](std::uint64_t steps, std::size_t n) { meter.advance(steps, n); };
  o.meter = &meter;
  o.axis = axis;
  o.driven_types = driven;
  o.fluid_density = *density;
  o.forces = c.forces;
  o.dt = scene.stages.back().dt;
  for (size_t k = 0; k + 1 < scene.stages.size(); ++k)
    o.prepare.emplace_back(scene.stages[k].steps, scene.stages[k].dt);
  const nlohmann::json viscosity = sweep_viscosity(scene, c, where, o, meter);
  const nlohmann::json warmup = sweep_warmup(scene, c, o);

  const std::vector<SweepPoint> points = run_sweep(sample, o);
  const SweepFits fits = fit_sweep(points, o.viscosity, o.viscosity_error);
  const SweepRecord record{scene, o, points, fits, PermeabilityUnits(scene)};

  std::error_code ec;
  fs::create_directories(c.out_dir, ec);
  if (ec) throw IoError(c.out_dir.string() + ": cannot create output folder: " + ec.message());
  // The four outputs appear together or not at all (sweep.json, written last, marks a complete
  // sweep): each is staged under a temporary name and all are renamed at the end.
  StagedOutputs outputs = StagedOutputs::files();
  write_sweep_tables(outputs, c.out_dir, record);
  nlohmann::json summary = sweep_summary(record, fluid_count, viscosity, meter);
  summary["steady_state"]["warmup"] = warmup;
  summary["throughput"] = points_throughput(record, sample.particles.size(), mobile_count);
  write_sweep_plot(outputs, c.out_dir, record);
  outputs.write_text(c.out_dir / "sweep.json", summary.dump(2) + "\n");
  outputs.commit();
  const PermeabilityUnits& k = record.k;
  meter.finish("k = " + fmt(fits.k) + " +- " + fmt(fits.k_error, 2) + " rc^2" +
               (k.units ? " (" + fmt(fits.k * k.mD) + " mD)" : std::string()) + "; outputs in " +
               c.out_dir.string());
  return summary;
}

}  // namespace mesorock::pipeline
