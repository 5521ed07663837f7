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

// For commands whose outputs all appear at the end (rockflow sweep, rockprep run), which poll no
// flag: SIGINT or SIGTERM prints "TOOL: interrupted: SIGNAL: <kept>" on one line and ends the
// process at once with exit 130 (SIGTERM ended them with 143 and no word). What they staged stays
// under temporary names, which the next command on the folder removes (mesorock/output_lock.h).
void exit_on_interrupt(const std::string& tool, const std::string& kept);

}  // namespace mesorock::pipeline
