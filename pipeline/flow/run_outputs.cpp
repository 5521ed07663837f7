#include "pipeline/flow/run_outputs.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "pipeline/flow/darcy_fit.h"
#include "pipeline/flow/leak_invariant.h"
#include "pipeline/flow/observable_outputs.h"
#include "pipeline/flow/statistics.h"
#include "sim/particle_io.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

namespace {

const char* const kStressNames[6] = {"xx", "yy", "zz", "xy", "xz", "yz"};

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

// thermo.csv every thermo_every steps: temperature, pressure, stress tensor, momentum and, with a
// solid grid, the leak invariant; the averaged stages' rows feed summary.json's averages.
class ThermoOutput final : public RunOutput {
 public:
  std::string name() const override { return "thermo"; }
  explicit ThermoOutput(RunContext& run) : run_(run), every_(run.scene.output.thermo_every) {
    if (every_ > 0)
      file_.open_in(run,
                    run.banner +
                        ", reduced units (rc = m = kBT = 1); stress = kinetic + pair virial per "
                        "volume\nstep,time,stage,temperature,pressure,sxx,syy,szz,sxy,sxz,syz,px,"
                        "py,pz" +
                        (run.scene.model.solid.mask ? ",solid_inside,solid_max_depth" : "") + "\n",
                    10);
    if (run.resumed)
      for (auto& [name, v] : series_.named()) *v = run.resumed->series(name);
  }
  std::uint64_t steps_to_next(const RunPoint& at) const override {
    return steps_to_multiple(at.step, every_);
  }
  void sample(const RunPoint& at) override {
    if (!is_multiple(at.step, every_)) return;
    sim::Simulation& sim = run_.sim;
    const double T = sim.kinetic_temperature();
    const auto st = sim.stress();
    const auto p = sim.momentum();
    if (!std::isfinite(T) || !std::isfinite(st.pressure()))
      throw NumericalError("step " + std::to_string(at.step) +
                           ": temperature or pressure is not finite (dt = " +
                           std::to_string(at.stage->dt) + " may be too large)");
    file_ << at.step << "," << at.time << "," << at.stage->name << "," << T << "," << st.pressure();
    for (double v : st.total()) file_ << "," << v;
    file_ << "," << p[0] << "," << p[1] << "," << p[2];
    if (run_.scene.model.solid.mask) {  // the leak invariant (throws past its limit)
      leaks_.check(sim, at.step);
      file_ << "," << leaks_.last_inside << "," << leaks_.last_depth;
    }
    file_ << "\n";
    if (at.averaged) series_.add(T, st);
  }
  void save(RunRecord& record) override {
    file_.save(record);
    for (auto& [name, v] : series_.named()) record.numbers[name] = *v;
  }
  void finish(const RunPoint&) override { file_.close(); }
  void summarize(nlohmann::json& summary) override {
    if (!series_.temperature.empty()) summary["averages"] = series_.to_json();
    if (run_.scene.model.solid.mask) {
      leaks_.check(run_.sim, run_.sim.step());
      summary["solid"] = solid_json(run_.scene.model.solid, leaks_);
    }
  }

 private:
  RunContext& run_;
  std::uint64_t every_;
  CsvSeries file_{run_.out_dir / "thermo.csv"};
  LeakRecord leaks_;  // the leak invariant at every thermo row (runs with a solid grid)
  ScalarSeries series_;
};

// A series written at every thermo row by an output that reports one feature of the model.
class ThermoRowOutput : public RunOutput {
 public:
  ThermoRowOutput(RunContext& run, const char* file, bool resumable = true)
      : run_(run), every_(run.scene.output.thermo_every), file_(run.out_dir / file, resumable) {}
  std::uint64_t steps_to_next(const RunPoint&) const override { return kNeverDue; }
  void sample(const RunPoint& at) override {
    if (is_multiple(at.step, every_)) write_rows(at);
  }
  void save(RunRecord& record) override { file_.save(record); }
  void finish(const RunPoint&) override { file_.close(); }

 protected:
  virtual void write_rows(const RunPoint& at) = 0;
  void open(const std::string& header, int precision) {
    if (every_ > 0) file_.open_in(run_, run_.banner + header, precision);
  }
  RunContext& run_;
  std::uint64_t every_;
  CsvSeries file_;
};

// slabs.csv: the rigid slabs at every thermo row.
class SlabOutput final : public ThermoRowOutput {
 public:
  std::string name() const override { return "slabs"; }
  explicit SlabOutput(RunContext& run) : ThermoRowOutput(run, "slabs.csv") {
    open(
        ": rigid slabs; position = mean coordinate of the slab's particles along its axis; force "
        "= pair forces + applied (pressure x cross-section)\n"
        "step,time,stage,slab,axis,position,velocity,force,applied_force\n",
        10);
  }
  void summarize(nlohmann::json& summary) override {
    nlohmann::json sj = nlohmann::json::array();
    for (const auto& r : run_.sim.rigid_slabs())
      sj.push_back({{"type", r.type},
                    {"axis", std::string(1, "xyz"[r.axis])},
                    {"position", r.position},
                    {"velocity", r.velocity},
                    {"force", r.force},
                    {"applied_force", r.applied_force},
                    {"particles", r.mass}});
    summary["slabs"] = sj;
  }

 private:
  void write_rows(const RunPoint& at) override {
    const auto slabs = run_.sim.rigid_slabs();  // collective
    for (const auto& r : slabs)
      file_ << at.step << "," << at.time << "," << at.stage->name << "," << r.type << ","
            << "xyz"[r.axis] << "," << r.position << "," << r.velocity << "," << r.force << ","
            << r.applied_force << "\n";
  }
};

// injection.csv: particles moved by each injection/ejection boundary, at every thermo row.
class InjectionOutput final : public ThermoRowOutput {
 public:
  std::string name() const override { return "injection"; }
  explicit InjectionOutput(RunContext& run)
      : ThermoRowOutput(run, "injection.csv"),
        injected_before_(run.scene.model.injections.size(), 0.0),
        missed_before_(run.scene.model.injections.size(), 0.0) {
    open(
        ": injected = particles moved from the outlet box to the inlet box so far; missed = "
        "events that found no particle to eject\n"
        "step,time,stage,boundary,type,injected,missed\n",
        0);
    // The engine counts from its start; a resumed run adds what was counted before the
    // checkpoint (the picks themselves depend only on the seed, the step and the ids: they
    // continue exactly).
    if (run.resumed) {
      injected_before_ = run.resumed->series("injection.injected");
      missed_before_ = run.resumed->series("injection.missed");
      if (injected_before_.size() != run.scene.model.injections.size() ||
          missed_before_.size() != run.scene.model.injections.size())
        throw IoError(run.resumed->file + ": injection counters do not match the scene's");
    }
  }
  void save(RunRecord& record) override {
    file_.save(record);
    std::vector<double> injected, missed;
    for (const auto& c : totals()) {
      injected.push_back(static_cast<double>(c.injected));
      missed.push_back(static_cast<double>(c.missed));
    }
    record.numbers["injection.injected"] = injected;
    record.numbers["injection.missed"] = missed;
  }
  void summarize(nlohmann::json& summary) override {
    nlohmann::json ij = nlohmann::json::array();
    const auto counts = totals();
    for (size_t k = 0; k < counts.size(); ++k) {
      const sim::InjectionSpec& q = run_.scene.model.injections[k];
      ij.push_back({{"type", type_name(q.inject_type)},
                    {"every", q.every},
                    {"particles_per_event", q.per_event},
                    {"particles_per_step", static_cast<double>(q.per_event) / q.every},
                    {"injected", counts[k].injected},
                    {"missed_events", counts[k].missed}});
    }
    summary["injection"] = ij;
  }

 private:
  std::vector<sim::InjectionCounts> totals() {
    std::vector<sim::InjectionCounts> counts = run_.sim.injections();  // collective
    for (size_t k = 0; k < counts.size() && k < injected_before_.size(); ++k) {
      counts[k].injected += static_cast<std::uint64_t>(injected_before_[k]);
      counts[k].missed += static_cast<std::uint64_t>(missed_before_[k]);
    }
    return counts;
  }
  const std::string& type_name(int t) const {
    return run_.scene.model.types[static_cast<size_t>(t)].name;
  }
  void write_rows(const RunPoint& at) override {
    const auto counts = totals();
    if (!file_.is_open()) return;
    for (size_t k = 0; k < counts.size(); ++k)
      file_ << at.step << "," << at.time << "," << at.stage->name << "," << k + 1 << ","
            << type_name(run_.scene.model.injections[k].inject_type) << "," << counts[k].injected
            << "," << counts[k].missed << "\n";
  }
  std::vector<double> injected_before_, missed_before_;
};

// balance.csv: a decomposed run's load balance at every thermo row (rank costs, max/mean). It
// starts afresh on --resume (the rank count may differ).
class BalanceOutput final : public ThermoRowOutput {
 public:
  std::string name() const override { return "balance"; }
  explicit BalanceOutput(RunContext& run) : ThermoRowOutput(run, "balance.csv", false) {
    std::string columns = "step,time,stage,imbalance";
    for (int r = 0; r < run.sim.ranks(); ++r) columns += ",cost_rank" + std::to_string(r);
    open(": " + run.sim.decomposition_report() +
             "; cost = sum over a rank's particles of neighbours x (1 frozen, 4.5 mobile); "
             "imbalance = max / mean cost\n" +
             columns + "\n",
         8);
  }
  void summarize(nlohmann::json& summary) override {
    double mean = 0, max = 0;
    for (double v : imbalance_) mean += v, max = std::max(max, v);
    if (!imbalance_.empty()) mean /= static_cast<double>(imbalance_.size());
    summary["decomposition"] = {{"ranks", run_.sim.ranks()},
                                {"regions", run_.sim.decomposition_report()},
                                {"imbalance_mean", mean},
                                {"imbalance_max", max},
                                {"file", "balance.csv"}};
  }

 private:
  void write_rows(const RunPoint& at) override {
    const std::vector<double> cost = run_.sim.rank_costs();  // collective
    double sum = 0, max = 0;
    for (double c : cost) sum += c, max = std::max(max, c);
    const double imbalance = sum > 0 ? max * static_cast<double>(cost.size()) / sum : 1.0;
    imbalance_.push_back(imbalance);
    file_ << at.step << "," << at.time << "," << at.stage->name << "," << imbalance;
    for (double c : cost) file_ << "," << c;
    file_ << "\n";
  }
  std::vector<double> imbalance_;
};

sim::ParticleFileMeta particle_meta_of(const RunContext& run, std::uint64_t step, double time) {
  sim::ParticleFileMeta meta;
  for (const auto& t : run.scene.model.types) meta.type_names.push_back(t.name);
  meta.box = run.scene.box;
  meta.created_by = "rockflow run";
  meta.provenance_json = run.provenance.dump();
  meta.length_unit = "rc";
  meta.step = step;
  meta.time = time;
  return meta;
}

std::string step_name(std::uint64_t step) {
  std::ostringstream s;
  s << "step_" << std::setw(9) << std::setfill('0') << step;
  return s.str();
}

// snapshots/step_N.h5 + .xmf every snapshot_every steps. Each pair appears together and is
// complete in itself: a failure later in the run leaves it, and the checkpoint, in place.
class SnapshotOutput final : public RunOutput {
 public:
  std::string name() const override { return "snapshots"; }
  explicit SnapshotOutput(RunContext& run) : run_(run), every_(run.scene.output.snapshot_every) {}
  std::uint64_t steps_to_next(const RunPoint& at) const override {
    return steps_to_multiple(at.step, every_);
  }
  void sample(const RunPoint& at) override {
    if (!is_multiple(at.step, every_)) return;
    const fs::path dir = run_.out_dir / "snapshots";
    const sim::ParticleSet snapshot = run_.sim.particles();  // collective
    if (!run_.root) return;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw IoError(dir.string() + ": cannot create folder: " + ec.message());
    const sim::ParticleFileMeta meta = particle_meta_of(run_, at.step, at.time);
    StagedOutputs pair = StagedOutputs::files();
    const fs::path h5 = dir / (step_name(at.step) + ".h5");
    pair.write(h5, [&](const fs::path& p) { sim::write_particle_file(p, snapshot, meta); });
    pair.write(dir / (step_name(at.step) + ".xmf"), [&](const fs::path& p) {
      sim::write_particle_xdmf(p, h5, run_.sim.size(), at.time);
    });
    pair.commit();
  }

 private:
  RunContext& run_;
  std::uint64_t every_;
};

// final.h5 + final.xmf: the particles at the end.
class FinalSnapshotOutput final : public RunOutput {
 public:
  std::string name() const override { return "final snapshot"; }
  explicit FinalSnapshotOutput(RunContext& run) : run_(run) {}
  std::uint64_t steps_to_next(const RunPoint&) const override { return kNeverDue; }
  void sample(const RunPoint&) override {}
  void finish(const RunPoint& end) override {
    const sim::ParticleFileMeta meta = particle_meta_of(run_, end.step, end.time);
    const sim::ParticleSet last = run_.sim.particles();  // collective
    if (!run_.root) return;
    const fs::path h5 = run_.out_dir / "final.h5";
    run_.staged->write(h5, [&](const fs::path& p) { sim::write_particle_file(p, last, meta); });
    run_.staged->write(run_.out_dir / "final.xmf", [&](const fs::path& p) {
      sim::write_particle_xdmf(p, h5, run_.sim.size(), end.time);
    });
  }

 private:
  RunContext& run_;
};

// The types a binned observable counts: the named ones, or every mobile type.
std::uint32_t type_mask_for(const Scene& scene, const std::vector<std::string>& names) {
  if (names.empty()) return scene.model.mobile_mask();
  std::uint32_t mask = 0;
  for (const auto& n : names) mask |= 1u << scene.model.type_index(n);
  return mask;
}

sim::BinGrid bin_grid_of(const Scene& scene, const BinnedOutputSpec& spec) {
  sim::BinGrid g;
  g.cells = spec.cells;
  g.lo = scene.box.lo;
  g.hi = scene.box.hi;
  g.type_mask = type_mask_for(scene, spec.types);
  return g;
}

// A time-averaged profile or field: sampled in the averaged stages, written at the end.
class BinnedOutput final : public RunOutput {
 public:
  std::string name() const override { return spec_.name; }
  BinnedOutput(RunContext& run, const BinnedOutputSpec& spec)
      : run_(run), spec_(spec), average_(bin_grid_of(run.scene, spec)) {
    if (run.resumed) run.resumed->get_binned(key(), average_);
  }
  std::uint64_t steps_to_next(const RunPoint& at) const override {
    return at.averaged ? steps_to_multiple(at.step, spec_.every) : kNeverDue;
  }
  void sample(const RunPoint& at) override {
    if (at.averaged && is_multiple(at.step, spec_.every))
      average_.add(run_.sim.bin_sums(average_.grid()));
  }
  void save(RunRecord& record) override { record.put_binned(key(), average_); }
  void finish(const RunPoint& end) override {
    ObservableOutputMeta meta;
    meta.step = end.step;
    meta.time = end.time;
    meta.provenance_json = run_.provenance.dump();
    if (run_.scene.units.nm_per_rc > 0) meta.units = unit_system_of(run_.scene.units);
    if (run_.root) write_binned_outputs(*run_.staged, run_.out_dir, spec_, average_, meta);
  }
  void summarize(nlohmann::json& summary) override {
    summary["binned_outputs"][spec_.name] = {
        {"samples", average_.samples()}, {"blocks", average_.blocks()}, {"every", spec_.every}};
  }

 private:
  std::string key() const { return "binned." + spec_.name; }
  RunContext& run_;
  const BinnedOutputSpec& spec_;
  sim::BinnedAverage average_;
};

// A region of [[output.regions]] being sampled: one single-bin grid per counted type.
struct RegionRun {
  const RegionOutputSpec* spec = nullptr;
  std::vector<int> types;
  int saturation_type = -1;  // index into types, or -1
  sim::BinGrid grid;
  nlohmann::json last = nlohmann::json::object();  // the last sample, for summary.json
  // The averaged stages' flow rates: flow[type index][axis], a value per sample.
  std::vector<std::array<std::vector<double>, 3>> flow;
};

// The steady test of a region's flow rate (rockflow sweep's rule, halves_agree): 10 blocks, the
// last 5 and the 5 before agreeing within 5% or their noise.
constexpr size_t kSteadyWindowBlocks = 5;
constexpr double kSteadyTolerance = 0.05;

// [[output.regions]]: regions.csv, and saturation.csv and region_pressure.csv when a region asks.
class RegionsOutput final : public RunOutput {
 public:
  std::string name() const override { return "regions"; }
  explicit RegionsOutput(RunContext& run);
  std::uint64_t steps_to_next(const RunPoint& at) const override {
    std::uint64_t n = kNeverDue;
    for (const auto& r : regions_) n = std::min(n, steps_to_multiple(at.step, r.spec->every));
    return n;
  }
  void begin(const RunPoint& at) override { sample(at); }
  void sample(const RunPoint& at) override;
  void save(RunRecord& record) override {
    for (CsvSeries* f : {&rows_, &saturation_, &pressure_}) f->save(record);
    nlohmann::json last = nlohmann::json::array();
    for (const auto& r : regions_) last.push_back(r.last);
    record.texts["regions.last"] = last.dump();
    for (size_t i = 0; i < regions_.size(); ++i)
      for (size_t k = 0; k < regions_[i].flow.size(); ++k)
        for (size_t a = 0; a < 3; ++a) record.numbers[flow_key(i, k, a)] = regions_[i].flow[k][a];
  }
  void finish(const RunPoint&) override {
    for (CsvSeries* f : {&rows_, &saturation_, &pressure_}) f->close();
  }
  void summarize(nlohmann::json& summary) override {
    nlohmann::json rj = nlohmann::json::object(), averages = nlohmann::json::object();
    for (const auto& r : regions_) {
      rj[r.spec->name] = r.last;
      if (!r.flow.empty() && !r.flow[0][0].empty()) averages[r.spec->name] = flow_averages(r);
    }
    summary["regions"] = {{"file", "regions.csv"}, {"last_sample", rj}};
    if (!averages.empty()) summary["regions"]["averages"] = averages;
    if (any_saturation_) summary["regions"]["saturation_file"] = "saturation.csv";
    if (any_pressure_) summary["regions"]["pressure_file"] = "region_pressure.csv";
  }
  std::vector<std::string> report() const override;

 private:
  static std::string flow_key(size_t region, size_t type, size_t axis) {
    return "regions." + std::to_string(region) + "." + std::to_string(type) + ".flow_rate_" +
           "xyz"[axis];
  }
  nlohmann::json flow_averages(const RegionRun& r) const;
  void sample_region(RegionRun& r, const RunPoint& at);
  RunContext& run_;
  std::vector<RegionRun> regions_;
  bool any_saturation_ = false, any_pressure_ = false;
  CsvSeries rows_{run_.out_dir / "regions.csv"}, saturation_{run_.out_dir / "saturation.csv"},
      pressure_{run_.out_dir / "region_pressure.csv"};
};

RegionsOutput::RegionsOutput(RunContext& run) : run_(run) {
  for (const auto& spec : run.scene.output.regions) {
    RegionRun r;
    r.spec = &spec;
    for (const auto& name : spec.types) {
      if (name == spec.saturation_of) r.saturation_type = static_cast<int>(r.types.size());
      r.types.push_back(run.scene.model.type_index(name));
    }
    r.grid.lo = spec.lo;
    r.grid.hi = spec.hi;
    any_saturation_ = any_saturation_ || r.saturation_type >= 0;
    any_pressure_ = any_pressure_ || spec.pressure;
    r.flow.resize(r.types.size());
    regions_.push_back(std::move(r));
  }
  rows_.open_in(run,
                run.banner +
                    ", reduced units; flow_rate_a = sum v_a / L_a over the region (m = 1)\n"
                    "step,time,stage,region,type,count,number_density,flow_rate_x,flow_rate_y,"
                    "flow_rate_z\n",
                10);
  if (any_saturation_)
    saturation_.open_in(run,
                        run.banner +
                            ": saturation = share of the saturation_of type among the region's "
                            "counted types; recovery = 1 - saturation\n"
                            "step,time,stage,region,saturation,recovery,counted\n",
                        10);
  if (any_pressure_)
    pressure_.open_in(run,
                      run.banner +
                          ": stress of the region's counted types = (sum of their m v v + half of "
                          "each of their pair virials) / region volume; pressure = trace / 3\n"
                          "step,time,stage,region,pressure,sxx,syy,szz,sxy,sxz,syz\n",
                      10);
  if (run.resumed) {
    const nlohmann::json last = nlohmann::json::parse(run.resumed->text("regions.last"), nullptr,
                                                      /*allow_exceptions=*/false);
    if (!last.is_array())
      throw IoError(run.resumed->file + ": /run/text/regions.last: not a JSON array (damaged)");
    for (size_t k = 0; k < regions_.size() && k < last.size(); ++k) regions_[k].last = last[k];
    // A checkpoint of an earlier version holds no flow series: the averages start afresh.
    for (size_t i = 0; i < regions_.size(); ++i)
      for (size_t k = 0; k < regions_[i].flow.size(); ++k)
        for (size_t a = 0; a < 3; ++a)
          if (run.resumed->numbers.count(flow_key(i, k, a)))
            regions_[i].flow[k][a] = run.resumed->series(flow_key(i, k, a));
  }
}

void RegionsOutput::sample(const RunPoint& at) {
  for (auto& r : regions_)
    if (is_multiple(at.step, r.spec->every)) sample_region(r, at);  // each its own interval
}

// A regions.csv row per counted type with the count, the number density and the mass flow rate
// along each axis, Q_a = sum v_a / L_a (m = 1; for a thin slab across an axis, the flow rate
// through that plane); a saturation.csv row when the region names saturation_of: S = n_type /
// n_counted and the recovery 1 - S; a region_pressure.csv row when it asks for its pressure.
void RegionsOutput::sample_region(RegionRun& r, const RunPoint& at) {
  sim::Simulation& sim = run_.sim;
  double counted = 0, of_type = 0;
  const double volume = r.grid.bin_volume();
  nlohmann::json per_type = nlohmann::json::object();
  for (size_t k = 0; k < r.types.size(); ++k) {
    r.grid.type_mask = 1u << r.types[k];
    const std::vector<double> sums = sim.bin_sums(r.grid);
    const double n = sums[sim::kBinCount];
    double q[3];
    for (int a = 0; a < 3; ++a) q[a] = sums[static_cast<size_t>(sim::kBinVx + a)] / r.grid.width(a);
    const std::string& name = run_.scene.model.types[static_cast<size_t>(r.types[k])].name;
    rows_ << at.step << "," << at.time << "," << at.stage->name << "," << r.spec->name << ","
          << name << "," << n << "," << n / volume << "," << q[0] << "," << q[1] << "," << q[2]
          << "\n";
    per_type[name] = {{"count", n}, {"flow_rate", {q[0], q[1], q[2]}}};
    if (at.averaged)
      for (size_t a = 0; a < 3; ++a) r.flow[k][a].push_back(q[a]);
    counted += n;
    if (static_cast<int>(k) == r.saturation_type) of_type = n;
  }
  r.last = {{"step", at.step}, {"types", per_type}};
  if (r.spec->pressure) {
    sim::RegionSelection sel;
    sel.lo = r.spec->lo;
    sel.hi = r.spec->hi;
    sel.type_mask = 0;
    for (int t : r.types) sel.type_mask |= 1u << t;
    const sim::StressSample st = sim.region_stress(sel);
    pressure_ << at.step << "," << at.time << "," << at.stage->name << "," << r.spec->name << ","
              << st.pressure();
    for (double v : st.total()) pressure_ << "," << v;
    pressure_ << "\n";
    r.last["pressure"] = st.pressure();
  }
  if (r.saturation_type >= 0) {
    const double sat = counted > 0 ? of_type / counted : 0.0;
    saturation_ << at.step << "," << at.time << "," << at.stage->name << "," << r.spec->name << ","
                << sat << "," << 1.0 - sat << "," << counted << "\n";
    r.last["saturation"] = sat;
    r.last["recovery"] = 1.0 - sat;
  }
}

// The axes along which a region's counted types are driven (a body force on any of them).
std::vector<size_t> driven_axes(const sim::Model& model, const std::vector<int>& types) {
  std::vector<size_t> axes;
  for (size_t a = 0; a < 3; ++a)
    for (int t : types)
      if (model.types[static_cast<size_t>(t)].body_force[a] != 0) {
        axes.push_back(a);
        break;
      }
  return axes;
}

// The counted types' flow rates summed, sample by sample.
std::vector<double> total_flow(const RegionRun& r, size_t axis) {
  std::vector<double> sum(r.flow[0][axis].size(), 0.0);
  for (const auto& f : r.flow)
    for (size_t j = 0; j < sum.size(); ++j) sum[j] += f[axis][j];
  return sum;
}

// Was a flow rate's series steady? rockflow sweep's two tests on its 10 block means (the latest
// samples that fill them): the halves agree (WindowPair::agree) and the least-squares trend across
// the blocks is within Student's t_99 of its error. `change`: that trend over the blocks, relative
// to their mean. Fewer than 10 samples are not judged.
struct FlowVerdict {
  bool judged = false, steady = false;
  WindowPair halves;
  Trend trend;
  double change = 0, change_error = 0;
};

FlowVerdict flow_verdict(const std::vector<double>& q) {
  FlowVerdict v;
  const std::vector<double> b = block_means(q, 2 * kSteadyWindowBlocks, true);
  if (b.empty()) return v;
  v.judged = true;
  v.halves = last_two_windows(b, kSteadyWindowBlocks);
  v.trend = trend_of(b, 0, b.size());
  const double mean = mean_of(b, 0, b.size()), span = static_cast<double>(b.size() - 1);
  if (mean != 0) {
    v.change = v.trend.slope * span / mean;
    v.change_error = std::abs(v.trend.slope_error * span / mean);
  }
  v.steady = v.halves.agree(kSteadyTolerance) && !v.trend.significant();
  return v;
}

// A region's summed flow rate along one of its driven axes, averaged and judged.
struct DrivenFlow {
  size_t axis = 0;
  size_t samples = 0;
  MeanWithError mean;
  FlowVerdict verdict;
};

std::vector<DrivenFlow> driven_flows(const sim::Model& model, const RegionRun& r) {
  std::vector<DrivenFlow> out;
  if (r.flow.empty() || r.flow[0][0].empty()) return out;
  for (size_t a : driven_axes(model, r.types)) {
    const std::vector<double> q = total_flow(r, a);
    out.push_back({a, q.size(), block_average(q), flow_verdict(q)});
  }
  return out;
}

nlohmann::json RegionsOutput::flow_averages(const RegionRun& r) const {
  const sim::Model& model = run_.scene.model;
  nlohmann::json j = {{"samples", r.flow[0][0].size()}, {"every", r.spec->every}};
  for (size_t k = 0; k < r.types.size(); ++k)
    for (size_t a = 0; a < 3; ++a)
      j["types"][model.types[static_cast<size_t>(r.types[k])].name]["flow_rate"][a] =
          mean_json(block_average(r.flow[k][a]));
  for (size_t a = 0; a < 3; ++a) j["flow_rate"][a] = mean_json(block_average(total_flow(r, a)));
  nlohmann::json steady = nlohmann::json::object();
  for (const DrivenFlow& f : driven_flows(model, r)) {
    const FlowVerdict& v = f.verdict;
    nlohmann::json& s = steady[std::string(1, "xyz"[f.axis])];
    s = {{"judged", v.judged}, {"steady", v.steady}};
    if (!v.judged) continue;
    s["first_half_mean"] = v.halves.first;
    s["second_half_mean"] = v.halves.second;
    s["halves_noise"] = v.halves.noise;
    s["change"] = v.change;
    s["change_error"] = v.change_error;
    s["trend_significant"] = v.trend.significant();
  }
  if (!steady.empty()) {
    j["steady"] = steady;
    j["steady_rule"] =
        "the counted types' flow rate along each driven axis, its samples in the averaged stages "
        "cut into 10 blocks: steady when the means of the last 5 and the 5 before agree within "
        "5% or two combined standard errors (halves_noise), and the least-squares trend across "
        "the blocks is within Student's t_99 standard errors (rockflow sweep's tests); change: "
        "that trend over the blocks relative to their mean";
  }
  return j;
}

// A line per region and driven axis: the averaged flow rate and whether it was steady.
std::vector<std::string> RegionsOutput::report() const {
  std::vector<std::string> lines;
  for (const auto& r : regions_)
    for (const DrivenFlow& f : driven_flows(run_.scene.model, r)) {
      const FlowVerdict& v = f.verdict;
      std::string line = "region " + r.spec->name + ": flow rate along " + "xyz"[f.axis] + " " +
                         fmt(f.mean.mean) + " +- " + fmt(f.mean.error, 2) + " (" +
                         std::to_string(f.samples) + " samples of the averaged stages); ";
      if (!v.judged) {
        lines.push_back(line + "too few samples to judge whether it was steady (at least " +
                        std::to_string(2 * kSteadyWindowBlocks) + ")");
        continue;
      }
      const std::string change = "its trend over them " +
                                 std::to_string(std::lround(100 * v.change)) + "% +- " +
                                 std::to_string(std::lround(100 * v.change_error)) + "%";
      if (v.steady)
        line += (v.halves.within(kSteadyTolerance)
                     ? "steady: its two halves agree within 5%, "
                     : "no change beyond the noise (a longer stage tells closer): ") +
                change;
      else
        line += "still changing: its halves " + fmt(v.halves.first) + " and " +
                fmt(v.halves.second) + ", " + change +
                "; a longer stage shows whether it settles (its [[run]] steps)";
      lines.push_back(line);
    }
  return lines;
}

}  // namespace

std::vector<std::unique_ptr<RunOutput>> make_scene_outputs(RunContext& run) {
  const Scene& scene = run.scene;
  std::vector<std::unique_ptr<RunOutput>> out;
  out.push_back(std::make_unique<ThermoOutput>(run));
  if (!scene.model.rigid_slabs.empty()) out.push_back(std::make_unique<SlabOutput>(run));
  if (!scene.model.injections.empty()) out.push_back(std::make_unique<InjectionOutput>(run));
  if (run.sim.ranks() > 1) out.push_back(std::make_unique<BalanceOutput>(run));
  if (scene.output.snapshot_every > 0) out.push_back(std::make_unique<SnapshotOutput>(run));
  for (const auto& p : scene.output.profiles) out.push_back(std::make_unique<BinnedOutput>(run, p));
  if (scene.output.fields) out.push_back(std::make_unique<BinnedOutput>(run, *scene.output.fields));
  if (!scene.output.regions.empty()) out.push_back(std::make_unique<RegionsOutput>(run));
  if (scene.output.final_snapshot) out.push_back(std::make_unique<FinalSnapshotOutput>(run));
  return out;
}

}  // namespace mesorock::pipeline
