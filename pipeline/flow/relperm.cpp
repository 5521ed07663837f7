#include "pipeline/flow/relperm.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "mesorock/plot.h"
#include "mesorock/staged_outputs.h"
#include "mesorock/version.h"
#include "pipeline/flow/observable_outputs.h"
#include "pipeline/flow/phase_connectivity.h"
#include "pipeline/flow/progress.h"
#include "pipeline/flow/statistics.h"
#include "sim/ensemble.h"
#include "sim/particle_io.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

namespace {

// Two particles of one phase closer than this are connected (phase_connectivity.h).
constexpr double kBondCutoff = 0.7;

// A value and its standard error.
using Value = MeanWithError;
nlohmann::json json_of(const Value& x) {
  return {{"value", x.mean}, {"error", x.error}};
}

// One run: a saturation (or the reference, S_w = 1).
struct RelpermRun {
  double target = 1;  // wanted S_w
  PlacementResult placed;
  SweepPoint point;
  sim::ParticleSet final_state;
  Value kr_w, kr_n, kr_sum;  // against the reference
  PhaseConnectivity w, n;    // of each phase in the final state, along the flow axis
};

// What the summary needs besides the runs.
struct RelpermSetup {
  const Scene& scene;
  const RelpermCommand& c;
  SweepOptions o;
  int wetting = 0, nonwetting = 0;
  double force = 0, cross_A = 0, wetting_wall_A = 0, nonwetting_wall_A = 0;
  PermeabilityUnits units;
  std::optional<Value> viscosity, k_abs;  // from --viscosity / --sweep
  nlohmann::json sweep_record;            // what --sweep said, for the summary
  double largest_radius = 0;              // of the drainage map (rc)
  nlohmann::json warmup;                  // the warm-up and where it came from (sweep_warmup)
};

void check_saturations(const std::string& where, std::vector<double> s) {
  if (s.empty()) throw ConfigError(where + ": no wetting saturation given (--saturations)");
  for (double v : s)
    if (!(v > 0 && v < 1))
      throw ConfigError(where +
                        ": every wetting saturation must lie strictly between 0 and 1 "
                        "(got " +
                        fmt(v) + "); S_w = 1 is the reference run, always made");
  std::sort(s.begin(), s.end());
  for (size_t k = 1; k < s.size(); ++k)
    if (s[k] == s[k - 1])
      throw ConfigError(where + ": the saturation " + fmt(s[k]) + " is given twice");
}

// The scene's model with the second liquid N added (see relperm.h); fills the setup's pair
// values. Throws ConfigError when N would mix with W or the name is taken.
sim::Model two_liquid_model(const Scene& scene, RelpermSetup& s, const std::string& where) {
  sim::Model m = scene.model;
  const int W = s.wetting;
  if (m.type_index("nonwetting") >= 0)
    throw ConfigError(where + ": the scene already has a type named nonwetting");
  sim::TypeSpec n = m.types[static_cast<size_t>(W)];
  n.name = "nonwetting";
  const int N = m.add_type(n);
  for (int t = 0; t < m.ntypes(); ++t)
    if (t != N) m.set_pair(N, t, m.pair(W, t));
  m.set_pair(N, N, m.pair(W, W));
  const std::vector<WallAffinity> walls =
      make_immiscible(m, W, N, s.c.cross_A, s.c.nonwetting_wall_A, where);
  for (const WallAffinity& w : walls)
    if (w.A_SW != walls[0].A_SW && !s.c.nonwetting_wall_A)
      throw ConfigError(where +
                        ": the wall types attract the fluid differently; give "
                        "--nonwetting-wall-A for all of them");
  s.cross_A = s.c.cross_A;
  s.wetting_wall_A = walls[0].A_SW;
  s.nonwetting_wall_A = walls[0].A_SN;
  s.nonwetting = N;
  return m;
}

// --sweep: the absolute permeability and the viscosity from rockflow sweep's summary.
void read_sweep_summary(RelpermSetup& s, const std::string& where) {
  const fs::path& path = s.c.sweep_json;
  std::error_code ec;
  // A folder read as "basic_filebuf::underflow" (an internal error), a FIFO blocked forever.
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec))
    throw IoError(path.string() + ": not a regular file (a folder, FIFO or device) (--sweep)");
  std::ifstream in(path);
  if (!in) throw IoError(path.string() + ": cannot open the sweep summary (--sweep)");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) throw ConfigError(path.string() + ": not valid JSON (--sweep)");
  try {
    const auto& k = j.at("fits").at("darcy").at("permeability");
    s.k_abs = Value{k.at("rc2").get<double>(), k.at("rc2_error").get<double>()};
    const auto& mu = j.at("viscosity");
    s.viscosity = Value{mu.at("value").get<double>(), mu.at("error").get<double>()};
    s.sweep_record = {{"file", path.string()},
                      {"k_abs_rc2", s.k_abs->mean},
                      {"k_abs_rc2_error", s.k_abs->error},
                      {"viscosity", s.viscosity->mean},
                      {"viscosity_error", s.viscosity->error},
                      {"scene_file", j.value("scene_file", "")}};
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(path.string() + ": not a rockflow sweep summary (" + e.what() + ")");
  }
  if (!(s.k_abs->mean > 0) || !(s.viscosity->mean > 0))
    throw ConfigError(path.string() + ": " + where +
                      ": the sweep's permeability and viscosity must be positive");
}

// k = mu J / (n_f^2 g) of a flux J (the sweep's definition, sweep.h), in rc^2; needs the
// viscosity (--viscosity or --sweep).
Value permeability_of(const RelpermSetup& s, double J, double J_error) {
  const double per_flux = s.viscosity->mean / (s.o.fluid_density * s.o.fluid_density * s.force);
  return {per_flux * J, per_flux * J_error};
}

// The kr of every run against the reference (runs[0]).
void relative_permeabilities(std::vector<RelpermRun>& runs) {
  const Value J1{runs[0].point.flux, runs[0].point.flux_error};
  if (!(J1.mean > 0))
    throw NumericalError("relperm: the single-phase flux is not positive (" + fmt(J1.mean) +
                         "): no flow to compare with; raise the force or the blocks");
  runs[0].kr_w = {1, 0};  // by definition (W alone)
  runs[0].kr_n = {0, 0};
  runs[0].kr_sum = {1, 0};
  for (size_t k = 1; k < runs.size(); ++k) {
    RelpermRun& r = runs[k];
    const SweepPoint& p = r.point;
    r.kr_w = ratio({p.phases[0].flux, p.phases[0].flux_error}, J1);
    r.kr_n = ratio({p.phases[1].flux, p.phases[1].flux_error}, J1);
    r.kr_sum = ratio({p.flux, p.flux_error}, J1);
  }
}

// The runs in order of their reached saturation (the reference last).
std::vector<const RelpermRun*> by_saturation(const std::vector<RelpermRun>& runs) {
  std::vector<const RelpermRun*> by_s;
  for (const auto& r : runs) by_s.push_back(&r);
  std::sort(by_s.begin(), by_s.end(), [](const RelpermRun* a, const RelpermRun* b) {
    return a->placed.saturation < b->placed.saturation;
  });
  return by_s;
}

// The checks on a rock: kr_W + kr_N below 1, both curves monotonic within two combined
// standard errors (kr_W rising, kr_N falling with S_w), end points.
nlohmann::json curve_checks(const std::vector<RelpermRun>& runs, const RelpermSetup& s) {
  const std::vector<const RelpermRun*> by_s = by_saturation(runs);
  bool below = true, w_monotonic = true, n_monotonic = true;
  for (size_t k = 0; k < by_s.size(); ++k) {
    if (by_s[k]->target < 1 && !(by_s[k]->kr_sum.mean < 1)) below = false;
    if (k == 0) continue;
    const RelpermRun &a = *by_s[k - 1], &b = *by_s[k];
    if (b.kr_w.mean - a.kr_w.mean < -2 * std::hypot(a.kr_w.error, b.kr_w.error))
      w_monotonic = false;
    if (b.kr_n.mean - a.kr_n.mean > 2 * std::hypot(a.kr_n.error, b.kr_n.error)) n_monotonic = false;
  }
  nlohmann::json j = {{"kr_sum_below_one", below},
                      {"kr_w_rises_within_2_sigma", w_monotonic},
                      {"kr_n_falls_within_2_sigma", n_monotonic}};
  if (s.k_abs && s.viscosity) {
    // The reference's k at this gradient against the sweep's Darcy fit.
    const SweepPoint& p = runs[0].point;
    const Value k1 = permeability_of(s, p.flux, p.flux_error);
    const Value q = ratio(k1, *s.k_abs);
    j["end_point"] = {{"k_single_phase_rc2", json_of(k1)},
                      {"k_abs_sweep_rc2", json_of(*s.k_abs)},
                      {"ratio", json_of(q)},
                      {"consistent_within_2_sigma", std::abs(q.mean - 1) <= 2 * q.error}};
  }
  return j;
}

// relperm.csv (a row per run, the reference first) and relperm_blocks.csv.
void write_tables(StagedOutputs& out, const fs::path& dir, const std::vector<RelpermRun>& runs,
                  const RelpermSetup& s) {
  std::ostringstream t;
  t << std::setprecision(10);
  t << "# mesorock " << kVersion << " (" << kGitCommit << "), rockflow relperm of "
    << s.scene.path.string() << "\n";
  t << "# reduced units: g = " << s.force << " per particle on both phases, J = sum v / V_total "
    << "per phase, kr = J_phase / J_1 (J_1: the single-phase run, S_w = 1, same g); placement "
    << to_string(s.c.placement) << "; A_WN = " << s.cross_A << ", A_SW = " << s.wetting_wall_A
    << ", A_SN = " << s.nonwetting_wall_A << "; errors one standard error\n";
  t << "S_w_target,S_w,fluid_particles,nonwetting_particles,entry_radius_rc,flux_W,flux_W_error,"
       "flux_N,flux_N_error,flux_total,flux_total_error,kr_W,kr_W_error,kr_N,kr_N_error,kr_sum,"
       "kr_sum_error,W_spans,W_spanning_share,N_spans,N_spanning_share,steady,steady_after_steps,"
       "steps,"
       "drift_W,drift_N,temperature,seconds\n";
  for (const RelpermRun& r : runs) {
    const SweepPoint& p = r.point;
    t << r.target << "," << r.placed.saturation << "," << r.placed.fluid << ","
      << r.placed.nonwetting << "," << r.placed.entry_radius << "," << p.phases[0].flux << ","
      << p.phases[0].flux_error << "," << p.phases[1].flux << "," << p.phases[1].flux_error << ","
      << p.flux << "," << p.flux_error << "," << r.kr_w.mean << "," << r.kr_w.error << ","
      << r.kr_n.mean << "," << r.kr_n.error << "," << r.kr_sum.mean << "," << r.kr_sum.error << ","
      << (r.w.spans ? 1 : 0) << "," << r.w.spanning_fraction << "," << (r.n.spans ? 1 : 0) << ","
      << r.n.spanning_fraction << "," << (p.steady ? 1 : 0) << "," << p.steady_after << ","
      << p.steps << "," << p.phases[0].drift << "," << p.phases[1].drift << "," << p.temperature
      << "," << p.seconds << "\n";
  }
  out.write_text(dir / "relperm.csv", t.str());
  std::ostringstream b;
  b << std::setprecision(10);
  b << "# flux J = sum v / V_total of each block of " << s.o.block_steps
    << " steps after the warm-up of " << s.o.warmup_steps << " steps: all fluid, W, N\n";
  b << "S_w,block,steps,flux_total,flux_W,flux_N\n";
  for (const RelpermRun& r : runs)
    for (size_t k = 0; k < r.point.block_flux.size(); ++k)
      b << r.placed.saturation << "," << k + 1 << ","
        << s.o.warmup_steps + (k + 1) * s.o.block_steps << "," << r.point.block_flux[k] << ","
        << r.point.phases[0].block_flux[k] << "," << r.point.phases[1].block_flux[k] << "\n";
  out.write_text(dir / "relperm_blocks.csv", b.str());
}

nlohmann::json connectivity_json(const PhaseConnectivity& c) {
  return {{"particles", c.particles},
          {"clusters", c.clusters},
          {"largest_cluster", c.largest},
          {"spans", c.spans},
          {"spanning_share", c.spanning_fraction}};
}

nlohmann::json runs_json(const std::vector<RelpermRun>& runs, const RelpermSetup& s) {
  nlohmann::json a = nlohmann::json::array();
  for (const RelpermRun& r : runs) {
    const SweepPoint& p = r.point;
    nlohmann::json j = {
        {"saturation_target", r.target},
        {"saturation", r.placed.saturation},
        {"fluid_particles", r.placed.fluid},
        {"nonwetting_particles", r.placed.nonwetting},
        {"entry_radius_rc", r.placed.entry_radius},
        {"flux_W", json_of({p.phases[0].flux, p.phases[0].flux_error})},
        {"flux_N", json_of({p.phases[1].flux, p.phases[1].flux_error})},
        {"flux_total", json_of({p.flux, p.flux_error})},
        {"kr_W", json_of(r.kr_w)},
        {"kr_N", json_of(r.kr_n)},
        {"kr_sum", json_of(r.kr_sum)},
        {"connectivity", {{"W", connectivity_json(r.w)}, {"N", connectivity_json(r.n)}}},
        {"steady", p.steady},
        {"steady_after_steps", p.steady_after},
        {"steps", p.steps},
        {"restarts", p.restarts},
        {"drift_W", json_of({p.phases[0].drift, p.phases[0].drift_error})},
        {"drift_N", json_of({p.phases[1].drift, p.phases[1].drift_error})},
        {"temperature", p.temperature},
        {"seconds", p.seconds}};
    if (s.viscosity) {
      const Value kw = permeability_of(s, p.phases[0].flux, p.phases[0].flux_error);
      const Value kn = permeability_of(s, p.phases[1].flux, p.phases[1].flux_error);
      j["k_W"] = s.units.json(kw.mean, kw.error);
      j["k_N"] = s.units.json(kn.mean, kn.error);
      if (s.k_abs) {
        j["kr_W_against_sweep"] = json_of(ratio(kw, *s.k_abs));
        j["kr_N_against_sweep"] = json_of(ratio(kn, *s.k_abs));
      }
    }
    if (s.scene.model.solid.mask) j["solid_invariant"] = p.leaks.json();
    a.push_back(j);
  }
  return a;
}

nlohmann::json summary_of(const std::vector<RelpermRun>& runs, const RelpermSetup& s,
                          const ProgressMeter& meter) {
  const SweepOptions& o = s.o;
  double seconds = 0, steps = 0;
  for (const auto& r : runs) {
    seconds = o.side_by_side ? std::max(seconds, r.point.seconds) : seconds + r.point.seconds;
    steps += static_cast<double>(r.point.steps);
  }
  const std::size_t particles = runs[0].final_state.size();
  nlohmann::json j = {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"command", "rockflow relperm"},
      {"scene_file", s.scene.path.string()},
      {"scene_name", s.scene.name},
      {"backend", sim::to_string(o.sim.backend)},
      {"flow_axis", std::string(1, "xyz"[o.axis])},
      {"phases",
       {{"wetting", s.scene.model.types[static_cast<size_t>(s.wetting)].name},
        {"nonwetting", "nonwetting"},
        {"A_WN", s.cross_A},
        {"A_SW", s.wetting_wall_A},
        {"A_SN", s.nonwetting_wall_A},
        {"viscosity_ratio", 1.0},
        {"note",
         "N is a copy of W but for A_WN and A_SN; A_SN = A_SW is neutral wetting (90 degrees "
         "by symmetry)"}}},
      {"connectivity_rule",
       "at the end of each run, particles of one phase closer than " + std::to_string(kBondCutoff) +
           " rc are bonded; a cluster spans when it closes a loop around the periodic box along "
           "the flow axis (docs/relperm.md)"},
      {"placement", to_string(s.c.placement)},
      {"drainage_largest_radius_rc", s.largest_radius},
      {"force_g", s.force},
      {"gradient_G", o.fluid_density * s.force},
      {"fluid_density", o.fluid_density},
      {"definitions",
       "J = sum v / V_total per phase; kr = J_phase / J_1 with J_1 the single-phase flux at the "
       "same g (the first run, S_w = 1); docs/relperm.md"},
      {"steady_state", steady_state_json(o)},
      {"dt", o.dt},
      {"seed", s.scene.model.seed},
      {"runs", runs_json(runs, s)},
      {"checks", curve_checks(runs, s)},
      {"units", units_json(s.units.units)},
      {"throughput",
       {{"seconds", seconds},
        {"particles", particles},
        {"mps", seconds > 0 ? static_cast<double>(particles) * steps / seconds / 1e6 : 0.0}}},
      {"particle_steps", meter.work()},
      {"wall_seconds", meter.seconds()},
      {"outputs", {"relperm.csv", "relperm_blocks.csv", "relperm.json", "relperm.png"}},
      {"scene", s.scene.source_text}};
  j["steady_state"]["warmup"] = s.warmup;
  if (!s.sweep_record.is_null()) j["sweep"] = s.sweep_record;
  if (s.viscosity) j["viscosity"] = json_of(*s.viscosity);
  if (s.c.write_states) j["outputs"].push_back("states/");
  return j;
}

// relperm.png: kr_W and kr_N against S_w with error bars, and their sum.
void write_plot(StagedOutputs& out, const fs::path& dir, const std::vector<RelpermRun>& runs,
                const RelpermSetup& s) {
  const std::vector<const RelpermRun*> by_s = by_saturation(runs);
  plot::Plot pl;
  pl.title =
      "relative permeability, " + to_string(s.c.placement) + " placement (" + s.scene.name + ")";
  pl.x_label = "wetting saturation S_w";
  pl.y_label = "kr";
  pl.style = plot::PlotStyle::kPoints;
  pl.label = "kr_W (1 s.error.)";
  pl.x_from_zero = true;
  plot::Series n, sum;
  n.label = "kr_N";
  n.style = plot::PlotStyle::kPoints;
  sum.label = "kr_W + kr_N";
  for (const RelpermRun* r : by_s) {
    pl.x.push_back(r->placed.saturation);
    pl.y.push_back(r->kr_w.mean);
    pl.y_error.push_back(r->kr_w.error);
    n.x.push_back(r->placed.saturation);
    n.y.push_back(r->kr_n.mean);
    n.y_error.push_back(r->kr_n.error);
    sum.x.push_back(r->placed.saturation);
    sum.y.push_back(r->kr_sum.mean);
  }
  pl.more = {n, sum};
  const fs::path png = dir / "relperm.png";
  plot::write_plot_png(pl, out.stage(png), png.string());
}

void write_states(StagedOutputs& out, const fs::path& dir, const std::vector<RelpermRun>& runs,
                  const RelpermSetup& s, const sim::Model& model) {
  for (const RelpermRun& r : runs) {
    sim::ParticleFileMeta meta;
    for (const auto& t : model.types) meta.type_names.push_back(t.name);
    meta.box = s.scene.box;
    meta.step = r.point.steps;
    meta.time = static_cast<double>(r.point.steps) * s.o.dt;
    meta.created_by = "rockflow relperm";
    meta.provenance_json = nlohmann::json{
        {"scene_file", s.scene.path.string()},
        {"saturation", r.placed.saturation},
        {"placement", to_string(s.c.placement)},
        {"force_g", s.force}}.dump();
    // The target: a stable name.
    write_state_files(out, dir, "states/S_" + fmt(r.target, 6), r.final_state, meta);
  }
}

}  // namespace

std::vector<WallAffinity> make_immiscible(sim::Model& m, int W, int N, double cross_A,
                                          std::optional<double> A_SN, const std::string& where) {
  sim::PairSpec cross = m.pair(W, W);
  if (!(cross_A > cross.A))
    throw ConfigError(where + ": the cross repulsion A_WN = " + fmt(cross_A) +
                      " must be less attractive than the fluid's own A = " + fmt(cross.A) +
                      " (else the two liquids mix)");
  cross.A = cross_A;
  m.set_pair(W, N, cross);
  std::vector<WallAffinity> walls;
  for (int t = 0; t < m.ntypes(); ++t) {
    if (!m.types[static_cast<size_t>(t)].frozen) continue;
    sim::PairSpec p = m.pair(W, t);
    if (A_SN) p.A = *A_SN;
    m.set_pair(N, t, p);
    walls.push_back({t, m.pair(W, t).A, p.A});
  }
  if (walls.empty()) throw ConfigError(where + ": the sample has no wall type (frozen particles)");
  return walls;
}

nlohmann::json run_relperm_command(const Scene& scene, const RelpermCommand& c) {
  const std::string where = scene.path.string() + ": relperm";
  if (scene.stages.empty()) throw ConfigError(where + ": the scene has no [[run]] stage");
  check_saturations(where, c.saturations);
  if (c.placement == Placement::Drainage && !scene.model.solid.mask)
    throw ConfigError(where +
                      ": the drainage placement needs the sample's solid grid ([solid] in "
                      "the scene, as rockprep run --layout permeability writes it); or use "
                      "--placement random");
  RelpermSetup s{scene, c,  c.sweep.run, 0, 0, 0, 0, 0, 0, PermeabilityUnits(scene),
                 {},    {}, {},          0, {}};
  const std::uint32_t driven = driven_types_of(scene, c.sweep, where);
  if ((driven & (driven - 1)) != 0)
    throw ConfigError(where +
                      ": relperm needs one driven fluid type (the wetting phase); give "
                      "--types");
  while (!((driven >> s.wetting) & 1u)) ++s.wetting;
  if (!scene.model.is_mobile(s.wetting))
    throw ConfigError(where + ": the fluid type does not flow (frozen or a rigid slab)");
  SweepOptions& o = s.o;
  o.axis = flow_axis_of(scene, c.sweep, driven);
  const std::optional<double> density =
      c.sweep.fluid_density ? c.sweep.fluid_density : density_from_scene(scene, driven);
  if (!density || !(*density > 0))
    throw ConfigError(where + ": give --fluid-density (the fluid's number density in the pores)");
  o.fluid_density = *density;
  s.force = c.force.value_or(
      std::abs(scene.model.types[static_cast<size_t>(s.wetting)].body_force[o.axis]));
  if (!std::isfinite(s.force) || !(s.force > 0))
    throw ConfigError(where + ": give --force (a positive body force per particle)");
  const sim::Model two = two_liquid_model(scene, s, where);
  if (!c.sweep_json.empty()) read_sweep_summary(s, where);
  if (c.sweep.viscosity)
    s.viscosity = Value{*c.sweep.viscosity, c.sweep.viscosity_error.value_or(0.0)};

  ProgressMeter meter("rockflow relperm", std::cerr, c.sweep.progress);
  o.sim.on_run = [&meter](std::uint64_t steps, std::size_t n) { meter.advance(steps, n); };
  o.meter = &meter;
  o.dt = scene.stages.back().dt;
  for (size_t k = 0; k + 1 < scene.stages.size(); ++k)
    o.prepare.emplace_back(scene.stages[k].steps, scene.stages[k].dt);
  o.viscosity = s.viscosity ? s.viscosity->mean : 1.0;  // kr does not need it
  // The warm-up from the sample's pores needs nu = mu / n_f: only with a viscosity known.
  s.warmup = sweep_warmup(scene, c.sweep, o, "rockflow relperm", s.viscosity.has_value());
  // Every run's options, checked before any step.
  o.driven_types = driven | (1u << s.nonwetting);
  o.phases = {1u << s.wetting, 1u << s.nonwetting};
  check_steady_options({two, scene.box, {}}, o);
  // The drainage map first (it needs no particles): a grid without pore or solid fails before any
  // step.
  const std::array<bool, 3> periodic = [&] {
    const auto v = sim::solid_view_of<double>(scene.model.solid, scene.box);
    return std::array<bool, 3>{v.periodic[0], v.periodic[1], v.periodic[2]};
  }();
  std::optional<DrainageMap> map;
  if (c.placement == Placement::Drainage) {
    meter.set_phase("pore sizes for the drainage placement");
    map = drainage_map(*scene.model.solid.mask, periodic, [&](int k, int K) {
      meter.set_phase("pore sizes for the drainage placement: radius " + std::to_string(k) + "/" +
                      std::to_string(K));
    });
    s.largest_radius = map->largest_radius;
  }
  // The scene's early stages once, with W alone; every run starts from what they leave.
  const SweepSample single{scene.model, scene.box, build_initial_particles(scene)};
  const double n_runs = static_cast<double>(c.saturations.size() + 1);
  std::uint64_t prepare_steps = 0;
  for (const auto& stage : o.prepare) prepare_steps += stage.first;
  meter.add_total(
      static_cast<double>(single.particles.size()) *
      (n_runs * static_cast<double>(o.warmup_steps +
                                    static_cast<std::uint64_t>(2 * o.window + o.measure_blocks) *
                                        o.block_steps) +
       static_cast<double>(prepare_steps)));
  const sim::ParticleSet prepared = prepare_sample(single, o);

  // Placement of every run (the reference keeps W alone).
  std::vector<RelpermRun> runs(c.saturations.size() + 1);
  std::vector<SweepSample> samples(runs.size(), SweepSample{two, scene.box, prepared});
  for (size_t k = 0; k < runs.size(); ++k) {
    runs[k].target = k == 0 ? 1.0 : c.saturations[k - 1];
    runs[k].placed = place_phases(samples[k].particles, s.wetting, s.nonwetting, runs[k].target,
                                  c.placement, scene.model.seed + 7919 * (k + 1),
                                  map ? &*map : nullptr, scene.model.solid.mask.get(), periodic);
  }
  auto run = [&](size_t k, const sim::SimulationOptions& so) {
    const std::string label = k == 0 ? std::string("reference S_w = 1")
                                     : "S_w = " + fmt(runs[k].placed.saturation, 3) + " (" +
                                           std::to_string(k) + "/" +
                                           std::to_string(runs.size() - 1) + ")";
    runs[k].point = run_steady_point(samples[k], o, s.force, scene.model.seed + k, label,
                                     samples[k].particles, so, &runs[k].final_state);
  };
  if (o.side_by_side) {
    const int n = static_cast<int>(runs.size());
    const sim::SimulationOptions each =
        sim::ensemble_member_options(o.sim, n, static_cast<double>(prepared.size()));
    meter.set_phase(std::to_string(n) + " runs side by side");
    sim::run_ensemble(n, [&](int k) { run(static_cast<size_t>(k), each); });
  } else {
    for (size_t k = 0; k < runs.size(); ++k) run(k, o.sim);
  }
  relative_permeabilities(runs);
  for (RelpermRun& r : runs) {
    r.w = phase_connectivity(r.final_state, s.wetting, scene.box, o.axis, kBondCutoff);
    r.n = phase_connectivity(r.final_state, s.nonwetting, scene.box, o.axis, kBondCutoff);
  }

  std::error_code ec;
  fs::create_directories(c.sweep.out_dir, ec);
  if (ec)
    throw IoError(c.sweep.out_dir.string() + ": cannot create output folder: " + ec.message());
  StagedOutputs outputs = StagedOutputs::files();
  write_tables(outputs, c.sweep.out_dir, runs, s);
  write_plot(outputs, c.sweep.out_dir, runs, s);
  if (c.write_states) {
    fs::create_directories(c.sweep.out_dir / "states", ec);
    if (ec)
      throw IoError((c.sweep.out_dir / "states").string() + ": cannot create: " + ec.message());
    write_states(outputs, c.sweep.out_dir, runs, s, two);
  }
  const nlohmann::json summary = summary_of(runs, s, meter);
  outputs.write_text(c.sweep.out_dir / "relperm.json", summary.dump(2) + "\n");
  outputs.commit();
  meter.finish("outputs in " + c.sweep.out_dir.string());
  return summary;
}

}  // namespace mesorock::pipeline
