#include "pipeline/flow/capillary_pressure.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "mesorock/plot.h"
#include "mesorock/staged_outputs.h"
#include "mesorock/version.h"
#include "pipeline/flow/observable_outputs.h"
#include "pipeline/flow/progress.h"
#include "pipeline/flow/relperm.h"
#include "pipeline/flow/sweep.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

namespace {

// Below this S_w the block counts as entered (the summary's breakthrough bracket).
constexpr double kEnteredBelow = 0.95;

struct PcSetup {
  const Scene& scene;
  const PcCommand& c;
  DrainageCell cell;
  sim::Model model;  // two liquids, the membrane, the scene's slabs
  DrainageOptions o;
  double A_WW = 0;
  std::vector<WallAffinity> walls;  // each wall type's A_SW and A_SN
  std::optional<sim::UnitSystem> units;
};

int type_named(const Scene& scene, const std::string& name, const std::string& what,
               const std::string& where) {
  const int t = scene.model.type_index(name);
  if (t < 0)
    throw ConfigError(where + ": the scene has no type " + name + " (the " + what +
                      "; give it with --" + what + ")");
  if (!scene.model.is_mobile(t))
    throw ConfigError(where + ": the " + what + " type " + name +
                      " does not flow (frozen or a rigid slab)");
  return t;
}

// The block along the flow axis: the scene's region named "block".
void find_block(const Scene& scene, DrainageCell& cell, const std::string& where) {
  for (const RegionOutputSpec& r : scene.output.regions)
    if (r.name == "block") {
      cell.block_lo = r.lo[static_cast<size_t>(cell.axis)];
      cell.block_hi = r.hi[static_cast<size_t>(cell.axis)];
      return;
    }
  throw ConfigError(where +
                    ": the scene has no region named block ([[output.regions]]): pc needs the "
                    "porous block of a flooding set-up, as rockprep run --layout flooding writes "
                    "it");
}

// The slab's thickness along the axis and its mean position, from its particles: the extent of
// their centres plus one mean particle spacing (area x extent / count)^(1/3), the half spacing
// each face of a packed layer lies beyond its outermost centres.
std::pair<double, double> slab_extent(const sim::ParticleSet& p, int type, int axis, double area) {
  const std::vector<double>& x = axis == 0 ? p.x : axis == 1 ? p.y : p.z;
  double lo = 1e300, hi = -1e300, sum = 0;
  std::size_t n = 0;
  for (size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == type) {
      lo = std::min(lo, x[i]);
      hi = std::max(hi, x[i]);
      sum += x[i];
      ++n;
    }
  if (n == 0) return {0.0, NAN};
  const double spacing = std::cbrt(area * (hi - lo) / static_cast<double>(n));
  return {hi - lo + spacing, sum / static_cast<double>(n)};
}

// The scene's model as two immiscible liquids (relperm.h make_immiscible), filling s.walls.
void make_two_liquids(PcSetup& s, const std::string& where) {
  sim::Model& m = s.model;
  const int W = s.cell.wetting, N = s.cell.nonwetting;
  s.A_WW = m.pair(W, W).A;
  if (m.pair(N, N).A != s.A_WW || m.pair(N, N).B != m.pair(W, W).B)
    throw ConfigError(where +
                      ": the two fluids of the scene are different liquids (A or B of "
                      "their own pairs differ); pc makes them one liquid with two labels");
  s.walls = make_immiscible(m, W, N, s.c.cross_A, s.c.nonwetting_wall_A, where);
}

PcSetup pc_setup(const Scene& scene, const PcCommand& c, const sim::ParticleSet& particles) {
  const std::string where = scene.path.string() + ": pc";
  PcSetup s{scene, c, {}, scene.model, c.run, 0, {}, {}};
  if (scene.stages.empty()) throw ConfigError(where + ": the scene has no [[run]] stage");
  const std::vector<double>& up = c.run.pressures;
  for (size_t k = 1; k < up.size(); ++k)
    if (!(up[k] > up[k - 1]))
      throw ConfigError(where +
                        ": the capillary pressures must rise from level to level "
                        "(primary drainage); got " +
                        fmt(up[k - 1]) + " then " + fmt(up[k]));
  for (size_t k = 0; k < c.imbibition.size(); ++k) {
    const double before = k == 0 ? (up.empty() ? NAN : up.back()) : c.imbibition[k - 1];
    if (!(c.imbibition[k] < before))
      throw ConfigError(where +
                        ": the imbibition pressures must fall from the last drainage "
                        "level on; got " +
                        fmt(before) + " then " + fmt(c.imbibition[k]));
  }
  s.o.pressures.insert(s.o.pressures.end(), c.imbibition.begin(), c.imbibition.end());
  const sim::Model& m = scene.model;
  if (m.rigid_slabs.size() != 2)
    throw ConfigError(where +
                      ": pc needs a pushing slab and a back-pressure slab ([[slabs]], "
                      "the first pushing, as rockprep run --layout flooding writes "
                      "them); the scene has " +
                      std::to_string(m.rigid_slabs.size()));
  DrainageCell& cell = s.cell;
  cell.axis = m.rigid_slabs[0].axis;
  cell.wetting = type_named(scene, c.wetting, "wetting", where);
  cell.nonwetting = type_named(scene, c.nonwetting, "nonwetting", where);
  find_block(scene, cell, where);
  const double area = scene.box.volume() / scene.box.length(cell.axis);
  const auto [push_thickness, push_at] =
      slab_extent(particles, m.rigid_slabs[0].type, cell.axis, area);
  const auto [back_thickness, back_at] =
      slab_extent(particles, m.rigid_slabs[1].type, cell.axis, area);
  if (!(push_at < cell.block_lo) || !(back_at > cell.block_hi))
    throw ConfigError(where +
                      ": the first slab must lie before the block and the second after it "
                      "along the flow axis (the pushing and the back-pressure slab)");
  cell.slab_thickness = std::max(push_thickness, back_thickness);
  s.o.back_pressure = -m.rigid_slabs[1].applied_pressure;
  s.o.dt = scene.stages.back().dt;
  make_two_liquids(s, where);
  s.model.virtual_walls = {drainage_membrane(cell)};
  if (scene.units.nm_per_rc > 0) s.units = unit_system_of(scene.units);
  check_drainage(s.model, scene.box, cell, s.o, where);
  return s;
}

// The scene's stages before its last, once, at Pc = 0 with the scene's own virtual walls.
sim::ParticleSet prepared_start(const PcSetup& s, sim::ParticleSet particles,
                                ProgressMeter& meter) {
  SweepOptions prep;
  for (size_t k = 0; k + 1 < s.scene.stages.size(); ++k)
    prep.prepare.emplace_back(s.scene.stages[k].steps, s.scene.stages[k].dt);
  prep.sim = s.o.sim;
  prep.meter = &meter;
  sim::Model m = s.model;
  m.virtual_walls = s.scene.model.virtual_walls;
  m.rigid_slabs[0].applied_pressure = s.o.back_pressure;
  return prepare_sample({m, s.scene.box, std::move(particles)}, prep);
}

const char* branch_of(const PcSetup& s, size_t level) {
  return level < s.c.run.pressures.size() ? "drainage" : "imbibition";
}

std::string pa_text(const PcSetup& s, double p) {
  return s.units ? fmt(s.units->pressure_pa(p)) : std::string();
}

// pc.csv's text: a row per level run.
std::string level_table(const DrainageResult& r, const PcSetup& s) {
  std::ostringstream t;
  t << std::setprecision(10);
  t << "# mesorock " << kVersion << " (" << kGitCommit << "), rockflow pc of "
    << s.scene.path.string() << "\n";
  t << "# primary drainage: Pc = P_push - P_back applied by the slabs (P_back = "
    << s.o.back_pressure << "), S_w = W / (W + N) in the block, measured Pc = p_N - p_W of the "
    << "reservoirs (region stress); reduced units (kBT / rc^3)"
    << (s.units ? ", Pa where given" : "") << "; errors one standard error\n";
  t << "level,branch,Pc,Pc_Pa,S_w,S_w_error,Pc_measured,Pc_measured_error,p_N,p_N_error,p_W,p_W_"
       "error,"
       "W_in_block,N_in_block,behind_slabs,steady,steady_after_steps,steps,restarts,push_position,"
       "back_position,temperature,seconds\n";
  for (size_t k = 0; k < r.levels.size(); ++k) {
    const DrainageLevel& l = r.levels[k];
    t << k << "," << branch_of(s, k) << "," << l.pc_applied << "," << pa_text(s, l.pc_applied)
      << "," << l.saturation.mean << "," << l.saturation.error << "," << l.pc_measured.mean << ","
      << l.pc_measured.error << "," << l.p_nonwetting.mean << "," << l.p_nonwetting.error << ","
      << l.p_wetting.mean << "," << l.p_wetting.error << "," << l.wetting_in_block << ","
      << l.nonwetting_in_block << "," << l.behind_slabs << "," << (l.steady ? 1 : 0) << ","
      << l.steady_after << "," << l.steps << "," << l.restarts << "," << l.push_position << ","
      << l.back_position << "," << l.temperature << "," << l.seconds << "\n";
  }
  return t.str();
}

void write_tables(StagedOutputs& out, const fs::path& dir, const DrainageResult& r,
                  const PcSetup& s) {
  out.write_text(dir / "pc.csv", level_table(r, s));
  std::ostringstream b;
  b << std::setprecision(10);
  b << "# S_w in the block, each block of " << s.o.block_steps << " steps of every level\n";
  b << "level,Pc,block,S_w\n";
  for (size_t k = 0; k < r.levels.size(); ++k)
    for (size_t j = 0; j < r.levels[k].block_saturation.size(); ++j)
      b << k << "," << r.levels[k].pc_applied << "," << j + 1 << ","
        << r.levels[k].block_saturation[j] << "\n";
  out.write_text(dir / "pc_blocks.csv", b.str());
}

nlohmann::json value_json(const MeanWithError& v) {
  return {{"value", v.mean}, {"error", v.error}};
}

nlohmann::json levels_json(const DrainageResult& r, const PcSetup& s) {
  nlohmann::json a = nlohmann::json::array();
  for (size_t k = 0; k < r.levels.size(); ++k) {
    const DrainageLevel& l = r.levels[k];
    nlohmann::json j = {{"branch", branch_of(s, k)},
                        {"Pc", l.pc_applied},
                        {"S_w", value_json(l.saturation)},
                        {"Pc_measured", value_json(l.pc_measured)},
                        {"p_N", value_json(l.p_nonwetting)},
                        {"p_W", value_json(l.p_wetting)},
                        {"W_in_block", l.wetting_in_block},
                        {"N_in_block", l.nonwetting_in_block},
                        {"fluid_behind_slabs", l.behind_slabs},
                        {"steady", l.steady},
                        {"steady_after_steps", l.steady_after},
                        {"steps", l.steps},
                        {"restarts", l.restarts},
                        {"push_position", l.push_position},
                        {"back_position", l.back_position},
                        {"temperature", l.temperature},
                        {"seconds", l.seconds}};
    if (s.units) j["Pc_Pa"] = s.units->pressure_pa(l.pc_applied);
    if (s.scene.model.solid.mask) j["solid_invariant"] = l.leaks.json();
    a.push_back(j);
  }
  return a;
}

nlohmann::json summary_of(const DrainageResult& r, const PcSetup& s, const ProgressMeter& meter) {
  const DrainageOptions& o = s.o;
  nlohmann::json walls = nlohmann::json::object();
  for (const WallAffinity& w : s.walls)
    walls[s.model.types[static_cast<size_t>(w.type)].name] = {{"A_SW", w.A_SW}, {"A_SN", w.A_SN}};
  const EntryPressure e = entry_pressure(r.levels, kEnteredBelow);
  nlohmann::json j = {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"command", "rockflow pc"},
      {"scene_file", s.scene.path.string()},
      {"scene_name", s.scene.name},
      {"backend", sim::to_string(o.sim.backend)},
      {"flow_axis", std::string(1, "xyz"[s.cell.axis])},
      {"block", {{"lo", s.cell.block_lo}, {"hi", s.cell.block_hi}}},
      {"phases",
       {{"wetting", s.c.wetting},
        {"nonwetting", s.c.nonwetting},
        {"A_WW", s.A_WW},
        {"A_WN", s.c.cross_A},
        {"walls", walls},
        {"viscosity_ratio", 1.0},
        {"note",
         "W and N are one liquid with two labels but for A_WN and A_SN; A_SN = A_SW is neutral "
         "wetting (90 degrees, no capillary entry)"}}},
      {"back_pressure", o.back_pressure},
      {"definitions",
       "Pc = P_push - P_back, applied by the slabs; S_w = W / (W + N) over the fluid in the "
       "block; a membrane at the block's outlet face keeps N in the block; Pc_measured = p_N - "
       "p_W from the reservoirs' region stress (docs/relperm.md)"},
      {"steady_state",
       {{"ramp_steps", o.ramp_steps},
        {"ramp_parts", o.ramp_parts},
        {"block_steps", o.block_steps},
        {"sample_every", o.sample_every},
        {"window", o.window},
        {"tolerance", o.tolerance},
        {"measure_blocks", o.measure_blocks},
        {"max_level_steps", o.max_level_steps},
        {"rule",
         "S_w of the last two windows agree within the tolerance (relative) or two standard "
         "errors; then measure_blocks more, thrown away while they trend (t_99)"}}},
      {"dt", o.dt},
      {"seed", s.scene.model.seed},
      {"levels", levels_json(r, s)},
      {"entry",
       {{"rule",
         "the first level with S_w < " + fmt(kEnteredBelow) + ", bracketed by the level before"},
        {"found", e.found},
        {"lower", e.lower},
        {"upper", e.upper}}},
      {"inlet_used_up", r.inlet_used_up},
      {"room_used_up", r.room_used_up},
      {"units", units_json(s.units)},
      {"particle_steps", meter.work()},
      {"wall_seconds", meter.seconds()},
      {"mps", meter.seconds() > 0 ? meter.work() / meter.seconds() / 1e6 : 0.0},
      {"outputs", {"pc.csv", "pc_blocks.csv", "pc.json", "pc.png"}},
      {"scene", s.scene.source_text}};
  if (s.c.write_states) j["outputs"].push_back("states/");
  return j;
}

// pc.png: the applied Pc against S_w, and the measured one with its error bars.
void write_plot(StagedOutputs& out, const fs::path& dir, const DrainageResult& r,
                const PcSetup& s) {
  plot::Plot pl;
  pl.title = "primary drainage capillary pressure (" + s.scene.name + ")";
  pl.x_label = "wetting saturation S_w in the block";
  pl.y_label = "Pc (kBT / rc^3)";
  pl.style = plot::PlotStyle::kPoints;
  pl.label = "Pc applied";
  pl.x_from_zero = true;
  plot::Series m;
  m.label = "Pc measured (reservoirs, 1 s.error)";
  m.style = plot::PlotStyle::kPoints;
  for (const DrainageLevel& l : r.levels) {
    pl.x.push_back(l.saturation.mean);
    pl.y.push_back(l.pc_applied);
    m.x.push_back(l.saturation.mean);
    m.y.push_back(l.pc_measured.mean);
    m.y_error.push_back(l.pc_measured.error);
  }
  pl.more = {m};
  const fs::path png = dir / "pc.png";
  plot::write_plot_png(pl, out.stage(png), png.string());
}

void write_states(StagedOutputs& out, const fs::path& dir, const DrainageResult& r,
                  const PcSetup& s) {
  for (size_t k = 0; k < r.level_states.size(); ++k) {
    sim::ParticleFileMeta meta;
    for (const auto& t : s.model.types) meta.type_names.push_back(t.name);
    meta.box = s.scene.box;
    meta.created_by = "rockflow pc";
    meta.provenance_json = nlohmann::json{{"scene_file", s.scene.path.string()},
                                          {"level", k},
                                          {"Pc", r.levels[k].pc_applied},
                                          {"S_w", r.levels[k].saturation.mean}}
                               .dump();
    write_state_files(out, dir, "states/level_" + std::to_string(k), r.level_states[k], meta);
  }
}

}  // namespace

nlohmann::json run_pc_command(const Scene& scene, const PcCommand& c) {
  sim::ParticleSet particles = build_initial_particles(scene);
  PcSetup s = pc_setup(scene, c, particles);
  ProgressMeter meter("rockflow pc", std::cerr, c.progress);
  s.o.sim.on_run = [&meter](std::uint64_t steps, std::size_t n) { meter.advance(steps, n); };
  s.o.meter = &meter;
  std::uint64_t prepare_steps = 0;
  for (size_t k = 0; k + 1 < scene.stages.size(); ++k) prepare_steps += scene.stages[k].steps;
  const auto least = static_cast<std::uint64_t>(2 * s.o.window + s.o.measure_blocks);
  meter.set_total(
      static_cast<double>(particles.size()) *
      static_cast<double>(prepare_steps + s.o.pressures.size() * least * s.o.block_steps));
  std::error_code ec;
  fs::create_directories(c.out_dir, ec);
  if (ec) throw IoError(c.out_dir.string() + ": cannot create output folder: " + ec.message());
  // The levels so far, rewritten (atomically) after each: a run stopped from outside, by a time
  // limit say, keeps what it measured. Removed once the outputs are in place.
  const fs::path partial = c.out_dir / "pc.partial.csv";
  s.o.on_level = [&s, &partial](const DrainageResult& so_far) {
    StagedOutputs p = StagedOutputs::files();
    p.write_text(partial, "# partial: the run had not finished\n" + level_table(so_far, s));
    p.commit();
  };
  const sim::ParticleSet start = prepared_start(s, std::move(particles), meter);
  const DrainageResult r =
      run_drainage(s.model, scene.box, start, s.cell, s.o, /*keep_states=*/c.write_states);

  StagedOutputs outputs = StagedOutputs::files();
  write_tables(outputs, c.out_dir, r, s);
  write_plot(outputs, c.out_dir, r, s);
  if (c.write_states) {
    fs::create_directories(c.out_dir / "states", ec);
    if (ec) throw IoError((c.out_dir / "states").string() + ": cannot create: " + ec.message());
    write_states(outputs, c.out_dir, r, s);
  }
  const nlohmann::json summary = summary_of(r, s, meter);
  outputs.write_text(c.out_dir / "pc.json", summary.dump(2) + "\n");
  outputs.commit();
  // A stale partial table would only mislead; failing to remove it is harmless.
  fs::remove(partial, ec);
  meter.finish("outputs in " + c.out_dir.string());
  return summary;
}

}  // namespace mesorock::pipeline
