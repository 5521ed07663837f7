#pragma once
// Ctrl-C (SIGINT) and SIGTERM for long commands. The first signal only sets a flag that the run
// loop polls between chunks of steps: it then writes a checkpoint and stops cleanly (exit code
// 130). A second signal ends the process at once (the default action is restored).
#include <string>

namespace mesorock::pipeline {

void install_interrupt_handlers();
// The signal that asked to stop (SIGINT or SIGTERM), or 0.
int interrupt_requested();
// Throws Interrupted ("Ctrl-C <when>", exit 130) when a signal asked to stop. For set-up, which
// writes nothing: scene.cpp between [[init]] blocks, and SimulationOptions::interrupt_check
// between the solver's set-up passes (Ctrl-C during the set-up of 4 M particles took 37 s).
void throw_if_interrupted(const std::string& when);

}  // namespace mesorock::pipeline
