#include "sim/ensemble.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <string>
#include <thread>
#include <vector>

#include "mesorock/errors.h"
#include "sim/simulation.h"

namespace mesorock::sim {

void run_ensemble(int count, const std::function<void(int member)>& job, int max_threads) {
  if (count < 0) throw ConfigError("ensemble: member count " + std::to_string(count) + " < 0");
  if (count == 0) return;
  const int threads = max_threads > 0 ? std::min(count, max_threads) : count;
  std::vector<std::exception_ptr> failed(static_cast<size_t>(count));
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int k = next++; k < count; k = next++) {
      try {
        job(k);
      } catch (...) {
        failed[static_cast<size_t>(k)] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(threads - 1));
  try {
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  } catch (...) {  // no more threads to be had: the ones started and this one do the work
  }
  worker();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

int ensemble_lanes(int members, double particles, int requested) {
  if (requested != 0) return requested;
  if (members <= 1 || members * particles <= kTwoLanesUpTo) return 0;  // each chooses itself
  return particles > kTwoLanesUpTo ? 1 : 2;
}

SimulationOptions ensemble_member_options(SimulationOptions o, int members, double particles) {
  if (members > 1 && o.backend == BackendKind::CPU && o.threads <= 0)
    o.threads = std::max(1, omp_get_max_threads() / members);
  o.lanes_per_particle = ensemble_lanes(members, particles, o.lanes_per_particle);
  return o;
}

}  // namespace mesorock::sim
