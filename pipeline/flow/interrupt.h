#pragma once
// Ctrl-C (SIGINT) and SIGTERM for long commands. The first signal only sets a flag that the run
// loop polls between chunks of steps: it then writes a checkpoint and stops cleanly (exit code
// 130). A second signal ends the process at once (the default action is restored).
namespace mesorock::pipeline {

void install_interrupt_handlers();
// The signal that asked to stop (SIGINT or SIGTERM), or 0.
int interrupt_requested();

}  // namespace mesorock::pipeline
