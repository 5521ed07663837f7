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

// SimulationOptions::lanes_per_particle for each of `members` systems of `particles` stepped side
// by side: `requested` when set; else, once the members together are more than kTwoLanesUpTo
// particles, two threads per particle (one for members above kTwoLanesUpTo). The CUDA engine's
// own choice looks at one system only: 64 systems of 20,000 ran at 368 MPS/s with 8 lanes each;
// with 1, 2 and 4 lanes at 465, 481 and 454 (H200, docs/benchmarks.md). Two lanes shorten each
// member's chain of small kernels without crowding the device.
int ensemble_lanes(int members, double particles, int requested);

// `options` for each of `members` systems of `particles` stepped side by side: on the CPU the
// members share the cores (threads split among them unless set), on the GPU ensemble_lanes.
struct SimulationOptions;
SimulationOptions ensemble_member_options(SimulationOptions options, int members, double particles);

}  // namespace mesorock::sim
