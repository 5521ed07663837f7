#include "pipeline/flow/run_scene.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mesorock/checked_text_file.h"
#include "mesorock/errors.h"
#include "mesorock/staged_outputs.h"
#include "mesorock/version.h"
#include "pipeline/flow/checkpoint_io.h"
#include "pipeline/flow/interrupt.h"
#include "pipeline/flow/leak_invariant.h"
#include "pipeline/flow/observable_outputs.h"
#include "pipeline/flow/statistics.h"
#include "sim/particle_io.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

const char* const kStressNames[6] = {"xx", "yy", "zz", "xy", "xz", "yz"};

// The types a binned observable counts: the named ones, or every mobile type.
std::uint32_t type_mask_for(const Scene& scene, const std::vector<std::string>& names) {
  std::uint32_t mask = 0;
  if (names.empty()) {
    mask = scene.model.mobile_mask();
  } else {
    for (const auto& n : names) mask |= 1u << scene.model.type_index(n);
  }
  return mask;
}

struct BinnedRun {
  BinnedOutputSpec spec;
  sim::BinnedAverage average;
};

BinnedRun make_binned(const Scene& scene, const BinnedOutputSpec& spec) {
  sim::BinGrid g;
  g.cells = spec.cells;
  g.lo = scene.box.lo;
  g.hi = scene.box.hi;
  g.type_mask = type_mask_for(scene, spec.types);
  return BinnedRun{spec, sim::BinnedAverage(g)};
}

nlohmann::json mean_json(const MeanWithError& m) {
  return {{"mean", m.mean}, {"error", m.error}, {"samples", m.samples}};
}

// Time series of the scalar observables sampled in the averaged stages.
struct ScalarSeries {
  std::vector<double> temperature, pressure, pressure_conservative;
  std::array<std::vector<double>, 6> stress;

  void add(double T, const sim::StressSample& st) {
    temperature.push_back(T);
    pressure.push_back(st.pressure());
    pressure_conservative.push_back(st.pressure_conservative());
    const auto total = st.total();
    for (int c = 0; c < 6; ++c)
      stress[static_cast<size_t>(c)].push_back(total[static_cast<size_t>(c)]);
  }
  nlohmann::json to_json() const {
    nlohmann::json j = {{"temperature", mean_json(block_average(temperature))},
                        {"pressure", mean_json(block_average(pressure))},
                        {"pressure_conservative", mean_json(block_average(pressure_conservative))}};
    for (int c = 0; c < 6; ++c)
      j["stress"][kStressNames[c]] = mean_json(block_average(stress[static_cast<size_t>(c)]));
    return j;
  }
  // For checkpoints: every series under "series.NAME".
  std::vector<std::pair<std::string, std::vector<double>*>> named() {
    std::vector<std::pair<std::string, std::vector<double>*>> out = {
        {"series.temperature", &temperature},
        {"series.pressure", &pressure},
        {"series.pressure_conservative", &pressure_conservative}};
    for (int c = 0; c < 6; ++c)
      out.push_back(
          {std::string("series.stress_") + kStressNames[c], &stress[static_cast<size_t>(c)]});
    return out;
  }
};

// A CSV series of the run (thermo.csv, regions.csv, ...): it grows under its staged name with
// every write checked; each checkpoint records its text so far, and --resume starts it again from
// that text. It takes its final name with the run's other outputs.
struct CsvSeries : CheckedTextFile {
  explicit CsvSeries(fs::path final_path, bool resumed_from_checkpoint = true)
      : path(std::move(final_path)), resumed(resumed_from_checkpoint) {}
  fs::path path;
  bool resumed;  // false: the file starts afresh on --resume and is not in the checkpoint

  // The rows written so far (flushed first), for the checkpoint record.
  std::string text_so_far() {
    flush();
    std::ifstream in(temporary(), std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    if (!in.good() && !in.eof())
      throw IoError(path.string() + ": cannot read back for the checkpoint");
    return s.str();
  }
};

// A region of [[output.regions]] being sampled: one single-bin grid per counted type.
struct RegionRun {
  const RegionOutputSpec* spec = nullptr;
  std::vector<int> types;
  int saturation_type = -1;  // index into types, or -1
  sim::BinGrid grid;
  nlohmann::json last = nlohmann::json::object();  // the last sample, for summary.json
};

std::vector<RegionRun> make_regions(const Scene& scene) {
  std::vector<RegionRun> out;
  for (const auto& spec : scene.output.regions) {
    RegionRun r;
    r.spec = &spec;
    for (const auto& name : spec.types) {
      if (name == spec.saturation_of) r.saturation_type = static_cast<int>(r.types.size());
      r.types.push_back(scene.model.type_index(name));
    }
    r.grid.lo = spec.lo;
    r.grid.hi = spec.hi;
    out.push_back(std::move(r));
  }
  return out;
}

// One sample of every region due at `step`: a regions.csv row per (region, type) with the count,
// the number density and the mass flow rate along each axis, Q_a = sum v_a / L_a (m = 1; for a thin
// slab across an axis, the flow rate through that plane); a saturation.csv row per region that
// names saturation_of: S = n_type / n_counted and the recovery 1 - S.
void sample_regions(sim::Simulation& sim, const Scene& scene, std::vector<RegionRun>& regions,
                    std::uint64_t step, double time, const std::string& stage,
                    CheckedTextFile& rows, CheckedTextFile& saturation, CheckedTextFile& pressure) {
  for (auto& r : regions) {
    if (step % r.spec->every != 0) continue;  // each region has its own interval
    double counted = 0, of_type = 0;
    const double volume = r.grid.bin_volume();
    nlohmann::json per_type = nlohmann::json::object();
    for (size_t k = 0; k < r.types.size(); ++k) {
      r.grid.type_mask = 1u << r.types[k];
      const std::vector<double> sums = sim.bin_sums(r.grid);
      const double n = sums[sim::kBinCount];
      double q[3];
      for (int a = 0; a < 3; ++a)
        q[a] = sums[static_cast<size_t>(sim::kBinVx + a)] / r.grid.width(a);
      const std::string& name = scene.model.types[static_cast<size_t>(r.types[k])].name;
      rows << step << "," << time << "," << stage << "," << r.spec->name << "," << name << "," << n
           << "," << n / volume << "," << q[0] << "," << q[1] << "," << q[2] << "\n";
      per_type[name] = {{"count", n}, {"flow_rate", {q[0], q[1], q[2]}}};
      counted += n;
      if (static_cast<int>(k) == r.saturation_type) of_type = n;
    }
    r.last = {{"step", step}, {"types", per_type}};
    if (r.spec->pressure) {
      sim::RegionSelection sel;
      sel.lo = r.spec->lo;
      sel.hi = r.spec->hi;
      sel.type_mask = 0;
      for (int t : r.types) sel.type_mask |= 1u << t;
      const sim::StressSample st = sim.region_stress(sel);
      const auto total = st.total();
      pressure << step << "," << time << "," << stage << "," << r.spec->name << ","
               << st.pressure();
      for (double v : total) pressure << "," << v;
      pressure << "\n";
      r.last["pressure"] = st.pressure();
    }
    if (r.saturation_type >= 0) {
      const double sat = counted > 0 ? of_type / counted : 0.0;
      saturation << step << "," << time << "," << stage << "," << r.spec->name << "," << sat << ","
                 << 1.0 - sat << "," << counted << "\n";
      r.last["saturation"] = sat;
      r.last["recovery"] = 1.0 - sat;
    }
  }
}

std::string step_name(std::uint64_t step) {
  std::ostringstream s;
  s << "step_" << std::setw(9) << std::setfill('0') << step;
  return s.str();
}

}  // namespace

void run_scene(const Scene& scene, const RunOptions& o) {
  const auto t_start = Clock::now();
  const fs::path checkpoint_file = checkpoint_path(o.out_dir);
  std::optional<ResumePoint> resume;
  std::unique_ptr<sim::Simulation> sim;
  if (o.resume) {
    if (scene.stages.empty()) throw ConfigError(scene.path.string() + ": run: no stages");
    resume = read_run_checkpoint(checkpoint_file, scene);
    sim = sim::resume_simulation(scene.model, scene.box, resume->state, o.sim);
  } else {
    if (fs::exists(checkpoint_file))
      throw ConfigError(checkpoint_file.string() +
                        ": an interrupted run's checkpoint is here: continue it with --resume, or "
                        "remove it (or choose another --out) to start afresh");
    sim::ParticleSet initial = build_initial_particles(scene);
    if (scene.stages.empty()) throw ConfigError(scene.path.string() + ": run: no stages");
    sim = sim::make_simulation(scene.model, scene.box, initial, scene.stages.front().dt, o.sim);
  }
  const std::uint64_t checkpoint_every = o.checkpoint_every.value_or(scene.output.checkpoint_every);

  // A decomposed run (mpirun): every rank takes part in every step and every observable (they
  // are collective); rank 0 alone writes files and progress.
  const bool root = sim->rank() == 0;
  const bool progress = o.progress && root;
  std::error_code ec;
  if (root) fs::create_directories(o.out_dir, ec);
  if (ec) throw IoError(o.out_dir.string() + ": cannot create output folder: " + ec.message());

  if (progress)
    std::cerr << "rockflow: " << scene.path.string() << ": " << sim->size() << " particles, "
              << sim->pass_name() << ", backend " << sim->backend_name() << ", "
              << sim::to_string(scene.model.precision) << " precision"
              << (resume ? ", resumed at step " + std::to_string(sim->step()) : std::string())
              << "\n";

  const nlohmann::json provenance = {{"scene", scene.path.string()},
                                     {"seed", scene.model.seed},
                                     {"backend", sim->backend_name()},
                                     {"pass", sim->pass_name()}};
  sim::ParticleFileMeta particle_meta;
  for (const auto& t : scene.model.types) particle_meta.type_names.push_back(t.name);
  particle_meta.box = scene.box;
  particle_meta.created_by = "rockflow run";
  particle_meta.provenance_json = provenance.dump();
  particle_meta.length_unit = "rc";

  // Every output of the run is staged: the CSV series grow under temporary names, the end-of-run
  // files are written under temporary names, and all take their final names together once
  // everything is written (summary.json last). A failure anywhere leaves none of them behind.
  StagedOutputs outputs = StagedOutputs::files();
  // A fresh run replaces the folder's outputs: the last run's completion record goes now, so a
  // failure cannot leave it beside this run's snapshots and checkpoint.
  if (root && !resume) fs::remove(o.out_dir / "summary.json", ec);
  const std::string banner =
      std::string("# mesorock ") + kVersion + " (" + kGitCommit + "), scene " + scene.path.string();
  auto open_series = [&](CsvSeries& s, const std::string& header, int precision) {
    s.open(outputs.stage(s.path), s.path);
    if (resume && s.resumed)
      s << resume->record.text(s.path.filename().string());  // the rows so far, with header
    else
      s << header;
    if (precision > 0) s.set_precision(precision);
  };
  CsvSeries thermo{o.out_dir / "thermo.csv"};
  LeakRecord leaks;  // the leak invariant at every thermo row (runs with a solid grid)
  const std::uint64_t thermo_every = scene.output.thermo_every;
  if (thermo_every > 0 && root)
    open_series(thermo,
                banner +
                    ", reduced units (rc = m = kBT = 1); stress = kinetic + pair virial per "
                    "volume\nstep,time,stage,temperature,pressure,sxx,syy,szz,sxy,sxz,syz,px,py,"
                    "pz" +
                    (scene.model.solid.mask ? ",solid_inside,solid_max_depth" : "") + "\n",
                10);
  std::vector<RegionRun> regions = make_regions(scene);
  CsvSeries region_rows{o.out_dir / "regions.csv"}, saturation_rows{o.out_dir / "saturation.csv"},
      pressure_rows{o.out_dir / "region_pressure.csv"};
  bool any_saturation = false, any_pressure = false;
  for (const auto& r : regions) any_saturation = any_saturation || r.saturation_type >= 0;
  for (const auto& r : regions) any_pressure = any_pressure || r.spec->pressure;
  if (!regions.empty() && root) {
    open_series(region_rows,
                banner +
                    ", reduced units; flow_rate_a = sum v_a / L_a over the region (m = 1)\n"
                    "step,time,stage,region,type,count,number_density,flow_rate_x,flow_rate_y,"
                    "flow_rate_z\n",
                10);
    if (any_saturation)
      open_series(saturation_rows,
                  banner +
                      ": saturation = share of the saturation_of type among the region's counted "
                      "types; recovery = 1 - saturation\n"
                      "step,time,stage,region,saturation,recovery,counted\n",
                  10);
    if (any_pressure)
      open_series(pressure_rows,
                  banner +
                      ": stress of the region's counted types = (sum of their m v v + half of "
                      "each of their pair virials) / region volume; pressure = trace / 3\n"
                      "step,time,stage,region,pressure,sxx,syy,szz,sxy,sxz,syz\n",
                  10);
  }
  // injection.csv: particles moved by each injection/ejection boundary, at every thermo row.
  CsvSeries injection_rows{o.out_dir / "injection.csv"};
  if (!scene.model.injections.empty() && thermo_every > 0 && root)
    open_series(injection_rows,
                banner +
                    ": injected = particles moved from the outlet box to the inlet box so far; "
                    "missed = events that found no particle to eject\n"
                    "step,time,stage,boundary,type,injected,missed\n",
                0);
  // The engine counts from its start; a resumed run adds what was counted before the checkpoint
  // (the picks themselves depend only on the seed, the step and the ids: they continue exactly).
  std::vector<double> injected_before(scene.model.injections.size(), 0.0),
      missed_before(scene.model.injections.size(), 0.0);
  if (resume && !scene.model.injections.empty()) {
    injected_before = resume->record.series("injection.injected");
    missed_before = resume->record.series("injection.missed");
    if (injected_before.size() != scene.model.injections.size() ||
        missed_before.size() != scene.model.injections.size())
      throw IoError(resume->record.file + ": injection counters do not match the scene's");
  }
  auto injection_totals = [&]() {
    std::vector<sim::InjectionCounts> counts = sim->injections();  // collective
    for (size_t k = 0; k < counts.size() && k < injected_before.size(); ++k) {
      counts[k].injected += static_cast<std::uint64_t>(injected_before[k]);
      counts[k].missed += static_cast<std::uint64_t>(missed_before[k]);
    }
    return counts;
  };
  auto write_injection_rows = [&](std::uint64_t step, double t, const std::string& stage) {
    if (scene.model.injections.empty() || thermo_every == 0) return;
    const auto counts = injection_totals();
    if (!injection_rows.is_open()) return;
    for (size_t k = 0; k < counts.size(); ++k)
      injection_rows
          << step << "," << t << "," << stage << "," << k + 1 << ","
          << scene.model.types[static_cast<size_t>(scene.model.injections[k].inject_type)].name
          << "," << counts[k].injected << "," << counts[k].missed << "\n";
  };
  // slabs.csv: the rigid slabs at every thermo row.
  CsvSeries slab_rows{o.out_dir / "slabs.csv"};
  if (!scene.model.rigid_slabs.empty() && thermo_every > 0 && root)
    open_series(slab_rows,
                banner +
                    ": rigid slabs; position = mean coordinate of the slab's particles along its "
                    "axis; force = pair forces + applied (pressure x cross-section)\n"
                    "step,time,stage,slab,axis,position,velocity,force,applied_force\n",
                10);
  // balance.csv: a decomposed run's load balance at every thermo row (rank costs, max/mean). It
  // starts afresh on --resume (the rank count may differ).
  CsvSeries balance_rows{o.out_dir / "balance.csv", false};
  std::vector<double> imbalance_series;
  if (sim->ranks() > 1 && thermo_every > 0 && root) {
    std::string columns = "step,time,stage,imbalance";
    for (int r = 0; r < sim->ranks(); ++r) columns += ",cost_rank" + std::to_string(r);
    open_series(balance_rows,
                banner + ": " + sim->decomposition_report() +
                    "; cost = sum over a rank's particles of neighbours x (1 frozen, 4.5 "
                    "mobile); imbalance = max / mean cost\n" +
                    columns + "\n",
                8);
  }
  auto write_balance_rows = [&](std::uint64_t step, double t, const std::string& stage) {
    if (sim->ranks() < 2 || thermo_every == 0) return;
    const std::vector<double> cost = sim->rank_costs();  // collective
    double sum = 0, max = 0;
    for (double c : cost) sum += c, max = std::max(max, c);
    const double imbalance = sum > 0 ? max * static_cast<double>(cost.size()) / sum : 1.0;
    imbalance_series.push_back(imbalance);
    if (!balance_rows.is_open()) return;
    balance_rows << step << "," << t << "," << stage << "," << imbalance;
    for (double c : cost) balance_rows << "," << c;
    balance_rows << "\n";
  };
  CsvSeries* const all_series[] = {&thermo,         &region_rows, &saturation_rows, &pressure_rows,
                                   &injection_rows, &slab_rows,   &balance_rows};
  auto write_slab_rows = [&](std::uint64_t step, double t, const std::string& stage) {
    if (scene.model.rigid_slabs.empty() || thermo_every == 0) return;
    const auto slabs = sim->rigid_slabs();  // collective
    if (!slab_rows.is_open()) return;
    for (const auto& r : slabs)
      slab_rows << step << "," << t << "," << stage << "," << r.type << ","
                << "xyz"[r.axis] << "," << r.position << "," << r.velocity << "," << r.force << ","
                << r.applied_force << "\n";
  };
  std::vector<BinnedRun> binned;
  for (const auto& p : scene.output.profiles) binned.push_back(make_binned(scene, p));
  if (scene.output.fields) binned.push_back(make_binned(scene, *scene.output.fields));
  ScalarSeries series;

  double time = 0;
  double earlier_run_seconds = 0;  // spent before the checkpoint this run resumed from
  if (resume) {
    const RunRecord& rec = resume->record;
    time = rec.number("time");
    earlier_run_seconds = rec.number("run_seconds");
    for (auto& [name, v] : series.named()) *v = rec.series(name);
    for (auto& b : binned) rec.get_binned("binned." + b.spec.name, b.average);
    const nlohmann::json last = nlohmann::json::parse(rec.text("regions.last"));
    for (size_t k = 0; k < regions.size() && k < last.size(); ++k) regions[k].last = last[k];
  }
  nlohmann::json parameters = {{"provenance", provenance}, {"threads", o.sim.threads}};
  parameters["checkpoint_every"] = checkpoint_every;
  std::uint64_t total_steps = 0;
  const auto t_run = Clock::now();
  // Everything the outputs need to continue from this step (all outputs of it are written).
  auto save_checkpoint = [&]() {
    RunRecord rec;
    for (CsvSeries* s : all_series)
      if (s->is_open() && s->resumed) rec.texts[s->path.filename().string()] = s->text_so_far();
    rec.numbers["time"] = {time};
    rec.numbers["run_seconds"] = {earlier_run_seconds +
                                  std::chrono::duration<double>(Clock::now() - t_run).count()};
    for (auto& [name, v] : series.named()) rec.numbers[name] = *v;
    for (const auto& b : binned) rec.put_binned("binned." + b.spec.name, b.average);
    nlohmann::json last = nlohmann::json::array();
    for (const auto& r : regions) last.push_back(r.last);
    rec.texts["regions.last"] = last.dump();
    if (!scene.model.injections.empty()) {
      std::vector<double> injected, missed;
      for (const auto& c : injection_totals()) {
        injected.push_back(static_cast<double>(c.injected));
        missed.push_back(static_cast<double>(c.missed));
      }
      rec.numbers["injection.injected"] = injected;
      rec.numbers["injection.missed"] = missed;
    }
    // Several ranks: every rank's particles are gathered (collective); rank 0 writes the file,
    // which resumes on any number of ranks.
    sim::SimulationState state = sim->state();
    if (root)
      write_run_checkpoint(checkpoint_file, std::move(state), scene, parameters.dump(), rec);
  };
  // Steps of a stage begin at this step; its time at this time (resume skips what was done).
  const std::uint64_t start_step = sim->step();
  std::uint64_t stage_begin = 0;
  double stage_time = 0;
  double seconds_per_step = 0;  // measured on the last chunk of steps
  try {
    if (!regions.empty() && !resume)
      sample_regions(*sim, scene, regions, sim->step(), time, scene.stages.front().name,
                     region_rows, saturation_rows, pressure_rows);
    for (const auto& stage : scene.stages) {
      sim->set_dt(stage.dt);
      const bool averaged = stage_is_averaged(scene, stage.name);
      std::uint64_t done =
          start_step > stage_begin ? std::min(stage.steps, start_step - stage_begin) : 0;
      const std::uint64_t done_before = done;
      const auto t_stage = Clock::now();
      // Progress about every hundredth of the stage; outputs at their own multiples of the step.
      const std::uint64_t progress_every = std::max<std::uint64_t>(1, stage.steps / 100);
      while (done < stage.steps) {
        const std::uint64_t step = sim->step();
        std::uint64_t n = std::min(stage.steps - done, progress_every - done % progress_every);
        auto until_next = [&](std::uint64_t every) {
          if (every > 0) n = std::min(n, every - step % every);
        };
        until_next(thermo_every);
        until_next(scene.output.snapshot_every);
        if (averaged)
          for (const auto& b : binned) until_next(b.spec.every);
        for (const auto& r : regions) until_next(r.spec->every);
        until_next(checkpoint_every);
        // Ctrl-C is answered between chunks: at most 1,000 steps and about a second of work
        // (a 4 M particle CPU run takes 7 s a step; 1,000 of them ignored Ctrl-C for hours). The
        // chunking changes no result: the engines step one step at a time either way.
        if (seconds_per_step > 0)
          n = std::min<std::uint64_t>(
              n, static_cast<std::uint64_t>(std::clamp(1.0 / seconds_per_step, 1.0, 1000.0)));
        n = std::min<std::uint64_t>(n, 1000);
        const auto t_chunk = Clock::now();
        sim->run(n);
        seconds_per_step =
            std::chrono::duration<double>(Clock::now() - t_chunk).count() / static_cast<double>(n);
        done += n;
        // From the stage's start, so that the time does not depend on how the stage was chunked.
        time = stage_time + static_cast<double>(done) * stage.dt;
        const std::uint64_t now = sim->step();
        if (thermo_every > 0 && now % thermo_every == 0) {
          const double T = sim->kinetic_temperature();
          const auto st = sim->stress();
          const auto p = sim->momentum();
          if (!std::isfinite(T) || !std::isfinite(st.pressure()))
            throw NumericalError("step " + std::to_string(now) +
                                 ": temperature or pressure is not finite (dt = " +
                                 std::to_string(stage.dt) + " may be too large)");
          const auto total = st.total();
          thermo << now << "," << time << "," << stage.name << "," << T << "," << st.pressure();
          for (double v : total) thermo << "," << v;
          thermo << "," << p[0] << "," << p[1] << "," << p[2];
          if (scene.model.solid.mask) {  // the leak invariant (throws past its limit)
            leaks.check(*sim, now);
            thermo << "," << leaks.last_inside << "," << leaks.last_depth;
          }
          thermo << "\n";
          if (averaged) series.add(T, st);
          write_slab_rows(now, time, stage.name);
          write_injection_rows(now, time, stage.name);
          write_balance_rows(now, time, stage.name);
        }
        if (scene.output.snapshot_every > 0 && now % scene.output.snapshot_every == 0) {
          const fs::path dir = o.out_dir / "snapshots";
          const sim::ParticleSet snapshot = sim->particles();  // collective
          if (root) {
            fs::create_directories(dir, ec);
            if (ec) throw IoError(dir.string() + ": cannot create folder: " + ec.message());
            particle_meta.step = now;
            particle_meta.time = time;
            // The pair appears together (a snapshot is complete in itself; a failure later
            // in the run leaves it, and the checkpoint, in place).
            StagedOutputs pair = StagedOutputs::files();
            const fs::path h5 = dir / (step_name(now) + ".h5");
            pair.write(h5, [&](const fs::path& p) {
              sim::write_particle_file(p, snapshot, particle_meta);
            });
            pair.write(dir / (step_name(now) + ".xmf"), [&](const fs::path& p) {
              sim::write_particle_xdmf(p, h5, sim->size(), time);
            });
            pair.commit();
          }
        }
        if (averaged)
          for (auto& b : binned)
            if (now % b.spec.every == 0) b.average.add(sim->bin_sums(b.average.grid()));
        sample_regions(*sim, scene, regions, now, time, stage.name, region_rows, saturation_rows,
                       pressure_rows);
        const int signal = interrupt_requested();
        if (checkpoint_every > 0 && now % checkpoint_every == 0) save_checkpoint();
        if (signal) {
          // One rank: a checkpoint of this step. Several: their signals need not arrive at one
          // step, so each stops where it is (mpirun ends the rest) without a checkpoint.
          if (sim->ranks() == 1 && !(checkpoint_every > 0 && now % checkpoint_every == 0))
            save_checkpoint();
          if (progress && isatty(STDERR_FILENO)) std::cerr << "\n";
          const std::string what = std::string(signal == SIGINT ? "Ctrl-C" : "SIGTERM") +
                                   " at step " + std::to_string(now);
          if (sim->ranks() > 1) {
            const bool kept = fs::exists(checkpoint_file);  // a periodic one (or the resumed one)
            throw Interrupted(what + " (several ranks: no checkpoint of this step" +
                              (kept ? "; the last periodic one is in " + checkpoint_file.string() +
                                          ", continue with --resume)"
                                    : ")"));
          }
          throw Interrupted(what + "; checkpoint written to " + checkpoint_file.string() +
                            "; continue with: rockflow run " + scene.path.string() + " --out " +
                            o.out_dir.string() + " --resume");
        }
        if (progress) {
          const double el = std::chrono::duration<double>(Clock::now() - t_stage).count();
          const std::uint64_t here = done - done_before;  // steps run in this session
          const double rate = el > 0 ? sim->size() * static_cast<double>(here) / el / 1e6 : 0;
          const double eta = here > 0 ? el * static_cast<double>(stage.steps - done) / here : 0;
          // On a terminal one line is redrawn; in a log, a line per tenth of the stage.
          const bool tty = isatty(STDERR_FILENO);
          const std::uint64_t tenth = std::max<std::uint64_t>(1, stage.steps / 10);
          if ((tty && done % progress_every == 0) || done == stage.steps ||
              (done / tenth) != ((done - n) / tenth))
            std::cerr << (tty ? "\r" : "") << "  stage " << stage.name << ": " << done << "/"
                      << stage.steps << " steps, " << std::setprecision(3) << rate << " MPS/s, ETA "
                      << std::setprecision(3) << eta << " s" << (tty ? "   " : "\n") << std::flush;
        }
      }
      total_steps += stage.steps;
      stage_begin += stage.steps;
      stage_time += static_cast<double>(stage.steps) * stage.dt;
      if (progress && isatty(STDERR_FILENO) && done > done_before) std::cerr << "\n";
    }
  } catch (...) {
    // The staged outputs are discarded with `outputs`; a checkpoint already written stays.
    throw;
  }
  const double run_seconds =
      earlier_run_seconds + std::chrono::duration<double>(Clock::now() - t_run).count();
  for (CsvSeries* s : all_series) s->close();  // the last rows reach the disk here (checked)

  if (scene.output.final_snapshot) {
    particle_meta.step = sim->step();
    particle_meta.time = time;
    const sim::ParticleSet last = sim->particles();  // collective
    if (root) {
      const fs::path h5 = o.out_dir / "final.h5";
      outputs.write(h5,
                    [&](const fs::path& p) { sim::write_particle_file(p, last, particle_meta); });
      outputs.write(o.out_dir / "final.xmf",
                    [&](const fs::path& p) { sim::write_particle_xdmf(p, h5, sim->size(), time); });
    }
  }

  const std::optional<sim::UnitSystem> units =
      scene.units.nm_per_rc > 0 ? std::optional<sim::UnitSystem>(unit_system_of(scene.units))
                                : std::nullopt;
  nlohmann::json binned_json = nlohmann::json::object();
  for (const auto& b : binned) {
    ObservableOutputMeta meta;
    meta.step = sim->step();
    meta.time = time;
    meta.provenance_json = provenance.dump();
    meta.units = units;
    if (root) write_binned_outputs(outputs, o.out_dir, b.spec, b.average, meta);
    binned_json[b.spec.name] = {
        {"samples", b.average.samples()}, {"blocks", b.average.blocks()}, {"every", b.spec.every}};
  }

  const double T = sim->kinetic_temperature();
  nlohmann::json summary = {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"scene_file", scene.path.string()},
      {"scene_name", scene.name},
      {"backend", sim->backend_name()},
      {"precision", sim::to_string(scene.model.precision)},
      {"pass", sim->pass_name()},
      {"density_kernel", scene.model.conservative == sim::ConservativeKind::MDPD
                             ? sim::to_string(scene.model.density_kernel)
                             : "none"},
      {"particles", sim->size()},
      {"steps", total_steps},
      {"simulated_time", time},
      {"wall_seconds", std::chrono::duration<double>(Clock::now() - t_start).count()},
      {"run_seconds", run_seconds},
      {"mps",
       run_seconds > 0 ? sim->size() * static_cast<double>(total_steps) / run_seconds / 1e6 : 0.0},
      {"final_temperature", T},
      {"averages", series.temperature.empty() ? nlohmann::json(nullptr) : series.to_json()},
      {"binned_outputs", binned_json},
      {"units", units_json(units)},
      {"scene", scene.source_text}};
  if (!scene.model.rigid_slabs.empty()) {
    nlohmann::json sj = nlohmann::json::array();
    for (const auto& r : sim->rigid_slabs())
      sj.push_back({{"type", r.type},
                    {"axis", std::string(1, "xyz"[r.axis])},
                    {"position", r.position},
                    {"velocity", r.velocity},
                    {"force", r.force},
                    {"applied_force", r.applied_force},
                    {"particles", r.mass}});
    summary["slabs"] = sj;
  }
  if (sim->ranks() > 1) {
    double mean = 0, max = 0;
    for (double v : imbalance_series) mean += v, max = std::max(max, v);
    if (!imbalance_series.empty()) mean /= static_cast<double>(imbalance_series.size());
    summary["decomposition"] = {{"ranks", sim->ranks()},
                                {"regions", sim->decomposition_report()},
                                {"imbalance_mean", mean},
                                {"imbalance_max", max},
                                {"file", "balance.csv"}};
  }
  if (!scene.model.injections.empty()) {
    nlohmann::json ij = nlohmann::json::array();
    const auto counts = injection_totals();
    for (size_t k = 0; k < counts.size(); ++k) {
      const sim::InjectionSpec& q = scene.model.injections[k];
      ij.push_back({{"type", scene.model.types[static_cast<size_t>(q.inject_type)].name},
                    {"every", q.every},
                    {"particles_per_event", q.per_event},
                    {"particles_per_step", static_cast<double>(q.per_event) / q.every},
                    {"injected", counts[k].injected},
                    {"missed_events", counts[k].missed}});
    }
    summary["injection"] = ij;
  }
  if (!regions.empty()) {
    nlohmann::json rj = nlohmann::json::object();
    for (const auto& r : regions) rj[r.spec->name] = r.last;
    summary["regions"] = {{"file", "regions.csv"}, {"last_sample", rj}};
    if (any_saturation) summary["regions"]["saturation_file"] = "saturation.csv";
    if (any_pressure) summary["regions"]["pressure_file"] = "region_pressure.csv";
  }
  if (scene.model.wall_model.enabled) {
    const sim::WallModelSpec& w = scene.model.wall_model;
    summary["walls"] = {{"model", "li2018"},
                        {"wall_density", w.wall_density},
                        {"penetration_threshold", w.penetration_threshold},
                        {"reflection", sim::to_string(w.reflection)},
                        {"slip_factor", w.slip_factor},
                        {"max_dissipation_factor", w.max_dissipation_factor},
                        {"corrections", sim->wall_corrections()}};
  }
  if (scene.model.solid.mask) {
    leaks.check(*sim, sim->step());
    summary["solid"] = solid_json(scene.model.solid, leaks);
  }
  if (resume) summary["resumed_from_step"] = resume->state.step;
  if (checkpoint_every > 0) summary["checkpoint_every"] = checkpoint_every;
  if (root) {
    outputs.write_text(o.out_dir / "summary.json", summary.dump(2) + "\n");
    outputs.commit();
  }
  // The run is complete: its outputs hold the final state, and the checkpoint is spent.
  if (root) fs::remove(checkpoint_file, ec);
  if (progress)
    std::cerr << "rockflow: done: " << total_steps << " steps in " << std::setprecision(3)
              << run_seconds << " s; outputs in " << o.out_dir.string()
              << " (summary.json, thermo.csv, final.xmf opens in ParaView)\n";
}

}  // namespace mesorock::pipeline
