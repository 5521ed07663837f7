#pragma once
// The run library: a Runner owns a simulation's stages, the chunked step loop with progress,
// Ctrl-C and checkpoints, and calls its RunOutputs (thermo.csv, snapshots, binned averages,
// regions, ...) when they are due (HOOMD-blue's Analyzer and Trigger, Mirheo's plugins). Every
// output writes through the run's StagedOutputs, so the files of a run appear together, summary
// last, or not at all (docs/stability.md); each output saves and restores what it needs in the
// checkpoint record, so a resumed run continues every file seamlessly.
//
// A new output is one RunOutput subclass (pipeline/flow/run_outputs.h) and one line where the
// outputs are listed (make_scene_outputs); the step loop does not change.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mesorock/checked_text_file.h"
#include "mesorock/staged_outputs.h"
#include "pipeline/flow/checkpoint_io.h"
#include "pipeline/flow/run_scene.h"
#include "pipeline/scene.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

// Where the run stands when an output is called.
struct RunPoint {
  std::uint64_t step = 0;
  double time = 0;
  const StageSpec* stage = nullptr;  // the stage being run (the first one before any step)
  bool averaged = false;             // the stage's samples enter the run's averages
};

// What the outputs of one run share.
struct RunContext {
  const Scene& scene;
  sim::Simulation& sim;
  std::filesystem::path out_dir;
  bool root = true;                    // rank 0 of a decomposed run: the one that writes files
  const RunRecord* resumed = nullptr;  // the checkpoint's record when the run resumed
  StagedOutputs* staged = nullptr;     // the run's files, which take their final names together
  std::string banner;                  // "# mesorock VERSION (COMMIT), scene FILE"
  nlohmann::json provenance;           // scene, seed, backend, pass
};

// A CSV series of the run (thermo.csv, regions.csv, ...): it grows under its staged name with
// every write checked; each checkpoint records its text so far, and --resume starts it again from
// that text. It takes its final name with the run's other outputs.
struct CsvSeries : CheckedTextFile {
  explicit CsvSeries(std::filesystem::path final_path, bool resumed_from_checkpoint = true)
      : path(std::move(final_path)), resumed(resumed_from_checkpoint) {}
  std::filesystem::path path;
  bool resumed;  // false: the file starts afresh on --resume and is not in the checkpoint

  // Opens the series on rank 0: with `header` on a fresh run, with the checkpoint's rows (header
  // included) on a resumed one. `precision` > 0 sets the digits of the numbers.
  void open_in(const RunContext& run, const std::string& header, int precision);
  // The rows written so far (flushed first), for the checkpoint record.
  std::string text_so_far();
  // Its text so far into the checkpoint record (when open and resumable).
  void save(RunRecord& record);
};

constexpr std::uint64_t kNeverDue = std::numeric_limits<std::uint64_t>::max();

// Steps from `step` to the next multiple of `every` (kNeverDue when every is 0).
inline std::uint64_t steps_to_multiple(std::uint64_t step, std::uint64_t every) {
  return every > 0 ? every - step % every : kNeverDue;
}
inline bool is_multiple(std::uint64_t step, std::uint64_t every) {
  return every > 0 && step % every == 0;
}

// One output of a run. The runner calls, in this order: begin (fresh runs, before the first
// step), after every chunk of steps sample, at checkpoints save, at the end finish then
// summarize. An output restores itself from RunContext::resumed when it is built.
class RunOutput {
 public:
  virtual ~RunOutput() = default;
  // What summary.json's time split calls it ("thermo", "regions", ...).
  virtual std::string name() const = 0;

  // Steps from at.step to this output's next sample (at least 1), or kNeverDue. The runner never
  // steps past it, so that sample() sees the step it is due at.
  virtual std::uint64_t steps_to_next(const RunPoint& at) const = 0;
  virtual void begin(const RunPoint&) {}
  // Called after every chunk of steps: sample if due at at.step.
  virtual void sample(const RunPoint& at) = 0;
  virtual void save(RunRecord&) {}
  // The run is complete: close series, write end-of-run files (staged).
  virtual void finish(const RunPoint&) {}
  virtual void summarize(nlohmann::json&) {}
  // Lines for the user at the end of the run (after summarize), e.g. whether a flow was steady.
  virtual std::vector<std::string> report() const { return {}; }
};

// Runs a scene's stages with its outputs. Construct with a simulation made for the scene (fresh
// or resumed from `resume`), add the outputs, run(), then finish() writes summary.json last and
// gives every file its final name.
class Runner {
 public:
  // `started`: when the command began (summary.json's wall_seconds counts the set-up too).
  Runner(const Scene& scene, sim::Simulation& sim, const RunOptions& options,
         const ResumePoint* resume, std::chrono::steady_clock::time_point started);
  RunContext& context() { return context_; }
  void add(std::unique_ptr<RunOutput> output) {
    outputs_.push_back(std::move(output));
    output_seconds_.push_back(0);
  }

  void run();
  // Writes the outputs' end-of-run files and summary.json, and commits them together.
  void finish();

 private:
  void run_stage(const StageSpec& stage, std::uint64_t done);
  std::uint64_t next_chunk(const StageSpec& stage, std::uint64_t done, bool averaged) const;
  void after_chunk(const RunPoint& at);
  void save_checkpoint();
  [[noreturn]] void stop_on_signal(int signal, std::uint64_t step);
  void report_progress(const StageSpec& stage, std::uint64_t done, std::uint64_t done_before,
                       std::uint64_t chunk, std::chrono::steady_clock::time_point since) const;
  nlohmann::json base_summary(double run_seconds) const;
  double run_seconds() const;
  double mobile_particles();

  const Scene& scene_;
  sim::Simulation& sim_;
  RunOptions options_;
  const ResumePoint* resume_;
  StagedOutputs staged_;
  RunContext context_;
  std::vector<std::unique_ptr<RunOutput>> outputs_;
  std::filesystem::path checkpoint_file_;
  std::uint64_t checkpoint_every_ = 0;
  std::string input_files_;  // named_files_record of the scene, saved with every checkpoint
  bool progress_ = false;
  std::chrono::steady_clock::time_point t_start_, t_run_;
  double earlier_run_seconds_ = 0;  // spent before the checkpoint this run resumed from
  double time_ = 0;
  double stage_time_ = 0;          // simulated time at the start of the current stage
  std::uint64_t total_steps_ = 0;  // steps of the stages run through (all of each)
  double seconds_per_step_ = 0;    // measured on the last chunk of steps
  // Where this process's run time went: stepping, each output's samples (by outputs_ index) and
  // the checkpoints. summary.json's "time_split".
  double step_seconds_ = 0, checkpoint_seconds_ = 0;
  std::vector<double> output_seconds_;
};

}  // namespace mesorock::pipeline
