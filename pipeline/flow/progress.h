#pragma once
// A progress line for long commands (`rockflow validate`, `rockflow sweep`): work done of the
// total in particle-steps, MPS/s (million particle-steps per second), elapsed time and ETA, and
// what the command is doing now. On a terminal one line is redrawn; in a log, a line about every
// tenth of the work (every 30 s while the total is unknown). Fed by SimulationOptions::on_run;
// safe to feed from several threads at once (the points of `rockflow sweep --side-by-side`).
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <mutex>
#include <string>

namespace mesorock::pipeline {

class ProgressMeter {
 public:
  // out: where the line goes (std::cerr); enabled = false prints nothing.
  ProgressMeter(std::string label, std::ostream& out, bool enabled = true);
  // Expected total work in particle-steps (0 = unknown: no ETA).
  void set_total(double particle_steps);
  void add_total(double particle_steps);
  // What the command is doing now (shown after the numbers).
  void set_phase(const std::string& phase);
  // `steps` steps of `particles` particles were just run.
  void advance(std::uint64_t steps, std::size_t particles);
  // The closing line: work, time, mean MPS/s.
  void finish(const std::string& result = "");

  double work() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return done_;
  }
  double seconds() const;

 private:
  void draw(bool force);  // with mutex_ held
  mutable std::mutex mutex_;
  std::string label_;
  std::ostream& out_;
  bool enabled_, tty_;
  double total_ = 0, done_ = 0;
  std::string phase_;
  std::chrono::steady_clock::time_point start_, last_draw_;
  int last_tenth_ = -1;
};

// On a terminal, erases a progress line that is being redrawn, so that the next message starts
// on a clean line (does nothing in a log or when no line is drawn).
void clear_progress_line(std::ostream& out);

}  // namespace mesorock::pipeline
