#include "pipeline/flow/interrupt.h"

#include <unistd.h>

#include <csignal>

#include "mesorock/errors.h"

namespace mesorock::pipeline {

namespace {
volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) {
  g_signal = sig;
  std::signal(sig, SIG_DFL);  // a second Ctrl-C ends the process at once
}
// The two lines exit_on_interrupt prints, made before its handler is installed (the handler may
// only write and exit).
std::string g_line_int, g_line_term;

extern "C" void exit_now(int sig) {
  const std::string& line = sig == SIGINT ? g_line_int : g_line_term;
  [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, line.data(), line.size());
  ::_exit(130);
}
}  // namespace

void exit_on_interrupt(const std::string& tool, const std::string& kept) {
  g_line_int = tool + ": interrupted: Ctrl-C: " + kept + "\n";
  g_line_term = tool + ": interrupted: SIGTERM: " + kept + "\n";
  std::signal(SIGINT, exit_now);
  std::signal(SIGTERM, exit_now);
}

void install_interrupt_handlers() {
  g_signal = 0;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

int interrupt_requested() {
  return g_signal;
}

void throw_if_interrupted(const std::string& when) {
  if (const int sig = g_signal)
    throw Interrupted(std::string(sig == SIGINT ? "Ctrl-C" : "SIGTERM") + " " + when);
}

}  // namespace mesorock::pipeline
