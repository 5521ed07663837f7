#include "pipeline/flow/progress.h"

#include <unistd.h>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace mesorock::pipeline {

namespace {
bool g_line_drawn = false;  // a redrawn progress line is on the terminal now

std::string duration_text(double s) {
  std::ostringstream o;
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 120) {
    o << static_cast<int>(std::lround(s)) << " s";
  } else if (s < 7200) {
    o << static_cast<int>(std::lround(s / 60)) << " min";
  } else {
    o << std::setprecision(3) << s / 3600 << " h";
  }
  return o.str();
}
}  // namespace

ProgressMeter::ProgressMeter(std::string label, std::ostream& out, bool enabled)
    : label_(std::move(label)),
      out_(out),
      enabled_(enabled),
      tty_(&out == &std::cerr && isatty(STDERR_FILENO)),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

void ProgressMeter::set_total(double particle_steps) {
  std::lock_guard<std::mutex> lock(mutex_);
  total_ = particle_steps;
}

void ProgressMeter::add_total(double particle_steps) {
  std::lock_guard<std::mutex> lock(mutex_);
  total_ += particle_steps;
}

void ProgressMeter::set_phase(const std::string& phase) {
  std::lock_guard<std::mutex> lock(mutex_);
  phase_ = phase;
  draw(false);
}

double ProgressMeter::seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressMeter::advance(std::uint64_t steps, std::size_t particles) {
  std::lock_guard<std::mutex> lock(mutex_);
  done_ += static_cast<double>(steps) * static_cast<double>(particles);
  draw(false);
}

void ProgressMeter::draw(bool force) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_draw_).count();
  const int tenth = total_ > 0 ? static_cast<int>(10 * std::min(1.0, done_ / total_)) : -1;
  // Terminal: at most 5 redraws a second. Log: each new tenth, or every 30 s without a total.
  const bool due = tty_ ? since > 0.2 : (total_ > 0 ? tenth != last_tenth_ : since > 30);
  if (!force && !due) return;
  last_draw_ = now;
  last_tenth_ = tenth;
  const double el = seconds();
  std::ostringstream line;
  line << label_ << ": ";
  if (total_ > 0) {
    const double frac = std::min(1.0, done_ / total_);
    if (tty_) {
      const int width = 20, filled = static_cast<int>(frac * width);
      line << "[" << std::string(static_cast<size_t>(filled), '#')
           << std::string(static_cast<size_t>(width - filled), '.') << "] ";
    }
    line << static_cast<int>(100 * frac) << "%, ";
  }
  line << std::setprecision(3) << done_ / 1e6 << " M particle-steps, "
       << (el > 0 ? done_ / el / 1e6 : 0.0) << " MPS/s, " << duration_text(el);
  if (total_ > 0 && done_ > 0)
    line << ", ETA " << duration_text(el * std::max(0.0, total_ - done_) / done_);
  if (!phase_.empty()) line << " | " << phase_;
  if (tty_) {
    out_ << "\r" << line.str() << "\033[K" << std::flush;
    g_line_drawn = true;
  } else {
    out_ << line.str() << "\n" << std::flush;
  }
}

void ProgressMeter::finish(const std::string& result) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!enabled_) return;
  clear_progress_line(out_);
  const double el = seconds();
  out_ << label_ << ": " << (result.empty() ? "done" : result) << ": " << std::setprecision(4)
       << done_ / 1e6 << " M particle-steps in " << duration_text(el) << " ("
       << std::setprecision(3) << (el > 0 ? done_ / el / 1e6 : 0.0) << " MPS/s)\n"
       << std::flush;
}

void clear_progress_line(std::ostream& out) {
  if (!g_line_drawn) return;
  out << "\r\033[K" << std::flush;
  g_line_drawn = false;
}

}  // namespace mesorock::pipeline
