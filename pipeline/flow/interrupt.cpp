#include "pipeline/flow/interrupt.h"

#include <csignal>

#include "mesorock/errors.h"

namespace mesorock::pipeline {

namespace {
volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) {
  g_signal = sig;
  std::signal(sig, SIG_DFL);  // a second Ctrl-C ends the process at once
}
}  // namespace

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
