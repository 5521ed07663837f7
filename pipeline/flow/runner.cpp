#include "pipeline/flow/runner.h"

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/flow/interrupt.h"
#include "pipeline/flow/observable_outputs.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void CsvSeries::open_in(const RunContext& run, const std::string& header, int precision) {
  if (!run.root) return;
  open(run.staged->stage(path), path);
  if (run.resumed && resumed)
    *this << run.resumed->text(path.filename().string());  // the rows so far, with header
  else
    *this << header;
  if (precision > 0) set_precision(precision);
}

std::string CsvSeries::text_so_far() {
  flush();
  std::ifstream in(temporary(), std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  if (!in.good() && !in.eof())
    throw IoError(path.string() + ": cannot read back for the checkpoint");
  return s.str();
}

void CsvSeries::save(RunRecord& record) {
  if (is_open() && resumed) record.texts[path.filename().string()] = text_so_far();
}

Runner::Runner(const Scene& scene, sim::Simulation& sim, const RunOptions& options,
               const ResumePoint* resume, Clock::time_point started)
    : scene_(scene),
      sim_(sim),
      options_(options),
      resume_(resume),
      staged_(StagedOutputs::files()),
      context_{scene, sim, options.out_dir, true, nullptr, nullptr, {}, {}},
      checkpoint_file_(checkpoint_path(options.out_dir)),
      checkpoint_every_(options.checkpoint_every.value_or(scene.output.checkpoint_every)),
      t_start_(started) {
  if (scene.stages.empty()) throw ConfigError(scene.path.string() + ": run: no stages");
  // A decomposed run (mpirun): every rank takes part in every step and every observable (they
  // are collective); rank 0 alone writes files and progress.
  context_.root = sim.rank() == 0;
  context_.resumed = resume ? &resume->record : nullptr;
  context_.staged = &staged_;
  context_.banner =
      std::string("# mesorock ") + kVersion + " (" + kGitCommit + "), scene " + scene.path.string();
  context_.provenance = {{"scene", scene.path.string()},
                         {"seed", scene.model.seed},
                         {"backend", sim.backend_name()},
                         {"pass", sim.pass_name()}};
  progress_ = options.progress && context_.root;
  std::error_code ec;
  if (context_.root) fs::create_directories(options.out_dir, ec);
  if (ec)
    throw IoError(options.out_dir.string() + ": cannot create output folder: " + ec.message());
  if (progress_)
    std::cerr << "rockflow: " << scene.path.string() << ": " << sim.size() << " particles, "
              << sim.pass_name() << ", backend " << sim.backend_name() << ", "
              << sim::to_string(scene.model.precision) << " precision"
              << (resume ? ", resumed at step " + std::to_string(sim.step()) : std::string())
              << "\n";
  // A fresh run replaces the folder's outputs: the last run's completion record goes now, so a
  // failure cannot leave it beside this run's snapshots and checkpoint.
  if (context_.root && !resume) fs::remove(options.out_dir / "summary.json", ec);
  // The files the scene names, hashed once: every checkpoint records them (compared on resume).
  input_files_ = resume ? resume->record.input_files : named_files_record(scene);
  if (resume) {
    time_ = resume->record.number("time");
    earlier_run_seconds_ = resume->record.number("run_seconds");
  }
}

// Mobile particles now: one bin over the box (and a margin) counting the mobile types, summed
// where the particles live (collective).
double Runner::mobile_particles() {
  sim::BinGrid whole;
  for (size_t a = 0; a < 3; ++a) {
    whole.lo[a] = scene_.box.lo[a] - 1;
    whole.hi[a] = scene_.box.hi[a] + 1;
  }
  whole.type_mask = scene_.model.mobile_mask();
  return sim_.bin_sums(whole)[sim::kBinCount];
}

namespace {

// Progress about every hundredth of a stage.
std::uint64_t progress_interval(const StageSpec& stage) {
  return std::max<std::uint64_t>(1, stage.steps / 100);
}

}  // namespace

double Runner::run_seconds() const {
  return earlier_run_seconds_ + std::chrono::duration<double>(Clock::now() - t_run_).count();
}

void Runner::run() {
  t_run_ = Clock::now();
  const std::uint64_t start_step = sim_.step();
  if (!resume_) {
    const StageSpec& first = scene_.stages.front();
    const RunPoint at{start_step, time_, &first, stage_is_averaged(scene_, first.name)};
    for (auto& o : outputs_) o->begin(at);
  }
  // Steps of a stage begin at this step (a resumed run skips what was done).
  std::uint64_t stage_begin = 0;
  for (const auto& stage : scene_.stages) {
    run_stage(stage,
              start_step > stage_begin ? std::min(stage.steps, start_step - stage_begin) : 0);
    total_steps_ += stage.steps;
    stage_begin += stage.steps;
    stage_time_ += static_cast<double>(stage.steps) * stage.dt;
  }
}

void Runner::run_stage(const StageSpec& stage, std::uint64_t done) {
  sim_.set_dt(stage.dt);
  const bool averaged = stage_is_averaged(scene_, stage.name);
  const std::uint64_t done_before = done;
  const auto t_stage = Clock::now();
  while (done < stage.steps) {
    const std::uint64_t n = next_chunk(stage, done, averaged);
    const auto t_chunk = Clock::now();
    sim_.run(n);
    const double chunk_seconds = std::chrono::duration<double>(Clock::now() - t_chunk).count();
    step_seconds_ += chunk_seconds;
    seconds_per_step_ = chunk_seconds / static_cast<double>(n);
    done += n;
    // From the stage's start, so that the time does not depend on how the stage was chunked.
    time_ = stage_time_ + static_cast<double>(done) * stage.dt;
    after_chunk(RunPoint{sim_.step(), time_, &stage, averaged});
    if (progress_) report_progress(stage, done, done_before, n, t_stage);
  }
  if (progress_ && isatty(STDERR_FILENO) && done > done_before) std::cerr << "\n";
}

// The steps to run before the next output, checkpoint or progress line is due. Ctrl-C is
// answered between chunks: at most 1,000 steps and about a second of work (a 4 M particle CPU run
// takes 7 s a step; 1,000 of them ignored Ctrl-C for hours). The chunking changes no result: the
// engines step one step at a time either way.
std::uint64_t Runner::next_chunk(const StageSpec& stage, std::uint64_t done, bool averaged) const {
  const std::uint64_t progress_every = progress_interval(stage);
  std::uint64_t n = std::min(stage.steps - done, progress_every - done % progress_every);
  const RunPoint at{sim_.step(), time_, &stage, averaged};
  for (const auto& o : outputs_) n = std::min(n, o->steps_to_next(at));
  n = std::min(n, steps_to_multiple(at.step, checkpoint_every_));
  if (seconds_per_step_ > 0)
    n = std::min<std::uint64_t>(
        n, static_cast<std::uint64_t>(std::clamp(1.0 / seconds_per_step_, 1.0, 1000.0)));
  return std::min<std::uint64_t>(n, 1000);
}

void Runner::after_chunk(const RunPoint& at) {
  for (size_t k = 0; k < outputs_.size(); ++k) {
    const auto t = Clock::now();
    outputs_[k]->sample(at);
    output_seconds_[k] += std::chrono::duration<double>(Clock::now() - t).count();
  }
  const int signal = interrupt_requested();
  const bool checkpoint_due = is_multiple(at.step, checkpoint_every_);
  if (checkpoint_due) {
    const auto t = Clock::now();
    save_checkpoint();
    checkpoint_seconds_ += std::chrono::duration<double>(Clock::now() - t).count();
  }
  if (!signal) return;
  // One rank: a checkpoint of this step. Several: their signals need not arrive at one step, so
  // each stops where it is (mpirun ends the rest) without a checkpoint.
  if (sim_.ranks() == 1 && !checkpoint_due) save_checkpoint();
  if (progress_ && isatty(STDERR_FILENO)) std::cerr << "\n";
  stop_on_signal(signal, at.step);
}

void Runner::stop_on_signal(int signal, std::uint64_t step) {
  const std::string what =
      std::string(signal == SIGINT ? "Ctrl-C" : "SIGTERM") + " at step " + std::to_string(step);
  if (sim_.ranks() > 1) {
    const bool kept = fs::exists(checkpoint_file_);  // a periodic one (or the resumed one)
    throw Interrupted(what + " (several ranks: no checkpoint of this step" +
                      (kept ? "; the last periodic one is in " + checkpoint_file_.string() +
                                  ", continue with --resume)"
                            : ")"));
  }
  throw Interrupted(what + "; checkpoint written to " + checkpoint_file_.string() +
                    "; continue with: rockflow run " + scene_.path.string() + " --out " +
                    options_.out_dir.string() + " --resume");
}

// Everything the outputs need to continue from this step (all outputs of it are written).
void Runner::save_checkpoint() {
  RunRecord record;
  record.input_files = input_files_;
  record.numbers["time"] = {time_};
  record.numbers["run_seconds"] = {run_seconds()};
  for (auto& o : outputs_) o->save(record);
  nlohmann::json parameters = {{"provenance", context_.provenance},
                               {"threads", options_.sim.threads}};
  parameters["checkpoint_every"] = checkpoint_every_;
  // Several ranks: every rank's particles are gathered (collective); rank 0 writes the file,
  // which resumes on any number of ranks.
  sim::SimulationState state = sim_.state();
  if (context_.root)
    write_run_checkpoint(checkpoint_file_, std::move(state), scene_, parameters.dump(), record);
}

void Runner::report_progress(const StageSpec& stage, std::uint64_t done, std::uint64_t done_before,
                             std::uint64_t chunk, Clock::time_point since) const {
  const double el = std::chrono::duration<double>(Clock::now() - since).count();
  const std::uint64_t here = done - done_before;  // steps run in this session
  const double rate = el > 0 ? sim_.size() * static_cast<double>(here) / el / 1e6 : 0;
  const double eta = here > 0 ? el * static_cast<double>(stage.steps - done) / here : 0;
  // On a terminal one line is redrawn; in a log, a line per tenth of the stage.
  const bool tty = isatty(STDERR_FILENO);
  const std::uint64_t progress_every = progress_interval(stage);
  const std::uint64_t tenth = std::max<std::uint64_t>(1, stage.steps / 10);
  if ((tty && done % progress_every == 0) || done == stage.steps ||
      (done / tenth) != ((done - chunk) / tenth))
    std::cerr << (tty ? "\r" : "") << "  stage " << stage.name << ": " << done << "/" << stage.steps
              << " steps, " << std::setprecision(3) << rate << " MPS/s, ETA "
              << std::setprecision(3) << eta << " s" << (tty ? "   " : "\n") << std::flush;
}

nlohmann::json Runner::base_summary(double seconds) const {
  const sim::Model& model = scene_.model;
  const std::optional<sim::UnitSystem> units =
      scene_.units.nm_per_rc > 0 ? std::optional<sim::UnitSystem>(unit_system_of(scene_.units))
                                 : std::nullopt;
  nlohmann::json summary = {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"scene_file", scene_.path.string()},
      {"scene_name", scene_.name},
      {"backend", sim_.backend_name()},
      {"precision", sim::to_string(model.precision)},
      {"pass", sim_.pass_name()},
      {"density_kernel", model.conservative == sim::ConservativeKind::MDPD
                             ? sim::to_string(model.density_kernel)
                             : "none"},
      {"particles", sim_.size()},
      {"steps", total_steps_},
      {"simulated_time", time_},
      {"wall_seconds", std::chrono::duration<double>(Clock::now() - t_start_).count()},
      {"run_seconds", seconds},
      {"mps", seconds > 0 ? sim_.size() * static_cast<double>(total_steps_) / seconds / 1e6 : 0.0},
      {"averages", nullptr},
      {"binned_outputs", nlohmann::json::object()},
      {"units", units_json(units)},
      {"scene", scene_.source_text}};
  if (model.wall_model.enabled) {
    const sim::WallModelSpec& w = model.wall_model;
    summary["walls"] = {{"model", "li2018"},
                        {"wall_density", w.wall_density},
                        {"penetration_threshold", w.penetration_threshold},
                        {"reflection", sim::to_string(w.reflection)},
                        {"slip_factor", w.slip_factor},
                        {"max_dissipation_factor", w.max_dissipation_factor},
                        {"corrections", sim_.wall_corrections()}};
  }
  if (resume_) summary["resumed_from_step"] = resume_->state.step;
  if (checkpoint_every_ > 0) summary["checkpoint_every"] = checkpoint_every_;
  return summary;
}

void Runner::finish() {
  const double seconds = run_seconds();
  const StageSpec& last = scene_.stages.back();
  const RunPoint end{sim_.step(), time_, &last, stage_is_averaged(scene_, last.name)};
  for (auto& o : outputs_) o->finish(end);
  const double T = sim_.kinetic_temperature();  // collective, like the outputs' summaries
  nlohmann::json summary = base_summary(seconds);
  summary["final_temperature"] = T;
  // The fluid's throughput beside MPS/s: frozen walls count as particles but do not move.
  const double mobile = mobile_particles();
  const double mobile_mps =
      seconds > 0 ? mobile * static_cast<double>(total_steps_) / seconds / 1e6 : 0.0;
  summary["mobile_particles"] = mobile;
  summary["mobile_mps"] = mobile_mps;
  // Frozen particles no step meets (SimulationOptions::buried_part): deep in a thick wall shell.
  summary["buried_particles"] = sim_.buried_particles();
  // Where the run's time went (this process's share of a resumed run): what the outputs cost
  // beside the steps tells a user which output to sample less often.
  nlohmann::json outputs = nlohmann::json::object();
  double output_total = 0;
  for (size_t k = 0; k < output_seconds_.size(); ++k) {
    if (output_seconds_[k] <= 0) continue;
    outputs[outputs_[k]->name()] = output_seconds_[k];
    output_total += output_seconds_[k];
  }
  summary["time_split"] = {{"steps_seconds", step_seconds_},
                           {"outputs_seconds", output_total},
                           {"outputs", outputs},
                           {"checkpoints_seconds", checkpoint_seconds_}};
  const std::string profile = sim_.profile_report();  // empty unless --profile on the GPU
  if (!profile.empty()) summary["profile"] = profile;
  for (auto& o : outputs_) o->summarize(summary);
  std::error_code ec;
  if (context_.root) {
    staged_.write_text(options_.out_dir / "summary.json", summary.dump(2) + "\n");
    staged_.commit();
    // The run is complete: its outputs hold the final state, and the checkpoint is spent.
    fs::remove(checkpoint_file_, ec);
  }
  if (progress_) {
    std::cerr << "rockflow: done: " << total_steps_ << " steps in " << std::setprecision(3)
              << seconds << " s (" << summary["mps"].get<double>() << " MPS/s, " << mobile_mps
              << " million mobile-particle-steps/s; stepping " << step_seconds_ << " s, outputs "
              << output_total << " s";
    if (checkpoint_seconds_ > 0) std::cerr << ", checkpoints " << checkpoint_seconds_ << " s";
    std::cerr << "); outputs in " << options_.out_dir.string() << " (summary.json"
              << (scene_.output.thermo_every > 0 ? ", thermo.csv" : "")
              << (scene_.output.final_snapshot ? ", final.xmf opens in ParaView" : "") << ")\n";
  }
  if (progress_ && !profile.empty()) std::cerr << "rockflow: " << profile << "\n";
  if (progress_)
    for (const auto& o : outputs_)
      for (const std::string& line : o->report()) std::cerr << "rockflow: " << line << "\n";
}

}  // namespace mesorock::pipeline
