// The watchdog's CPU pass (sim/watchdog.h watchdog_scan) alone: nanoseconds per particle on one
// thread over 200,000 particles, in single and double precision. Divide by a step's time per
// particle (1 / `rockflow bench` MPS/s, in microseconds) for its share of a step.
//   bench_watchdog [repetitions]   (default 200)
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "sim/kernels.h"
#include "sim/watchdog.h"

namespace ms = mesorock::sim;

template <class Real>
double nanoseconds_per_particle(int n, int repetitions) {
  std::vector<Real> x(n, 1), y(n, 2), z(n, 3), vx(n, 0.5), vy(n, -0.3), vz(n, 1.1), fx(n, 3),
      fy(n, -2), fz(n, 1);
  std::vector<std::int32_t> type(n, 0);
  std::vector<std::int64_t> id(n);
  for (int i = 0; i < n; ++i) id[static_cast<size_t>(i)] = i;
  ms::StepView<Real> v;
  v.n = n;
  v.x = x.data(), v.y = y.data(), v.z = z.data();
  v.vx = vx.data(), v.vy = vy.data(), v.vz = vz.data();
  v.fx = fx.data(), v.fy = fy.data(), v.fz = fz.data();
  v.type = type.data();
  v.id = id.data();
  v.dt = Real(0.01);
  const ms::WatchdogOptions options;
  ms::watchdog_scan(v, options);  // warm-up
  const auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < repetitions; ++r) ms::watchdog_scan(v, options);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s / repetitions / n * 1e9;
}

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::atoi(argv[1]) : 200;
  omp_set_num_threads(1);
  for (int k = 0; k < 3; ++k)
    std::printf(
        "watchdog pass, 1 thread, 200,000 particles: %.2f ns/particle single, %.2f double\n",
        nanoseconds_per_particle<float>(200000, repetitions),
        nanoseconds_per_particle<double>(200000, repetitions));
  return 0;
}
