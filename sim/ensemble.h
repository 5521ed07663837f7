#pragma once
// Independent simulations stepped side by side: the sweep's points, calibration boxes, tile
// sets, study rows. Each member runs on a host thread of its own. On the GPU every thread's work
// goes to its own default stream (sim/CMakeLists.txt: --default-stream per-thread), so the
// members' kernels overlap on the device while each member, with graphs (SimulationOptions::
// graphs), launches a whole run of steps at once; on the CPU the members share the cores. A
// member shares nothing with another (its own model, seed and engine), so it computes every bit
// that it computes alone (tests/unit/sim/test_ensemble.cpp).
#include <functional>

namespace mesorock::sim {

// Runs job(k) for every k in [0, count), up to max_threads at a time (all at once when
// max_threads <= 0), and returns when all are done. A job that throws does not stop the others;
// the exception of the lowest failed k is rethrown at the end. A negative count is a
// ConfigError.
void run_ensemble(int count, const std::function<void(int member)>& job, int max_threads = 0);

}  // namespace mesorock::sim
