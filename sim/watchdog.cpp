#include "sim/watchdog.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "mesorock/errors.h"
#include "sim/kernels.h"

namespace mesorock::sim {

namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// "(x, y, z)": where the particle was after the failing step.
std::string where(const WatchdogHit& hit) {
  return "(" + number(hit.position[0]) + ", " + number(hit.position[1]) + ", " +
         number(hit.position[2]) + ")";
}

}  // namespace

void validate_watchdog_options(const WatchdogOptions& o) {
  if (!(o.runaway_displacement > 0) || !std::isfinite(o.runaway_displacement))
    throw ConfigError("watchdog: the runaway displacement must be a positive number of rc (got " +
                      number(o.runaway_displacement) + ")");
  if (o.poll_steps < 1)
    throw ConfigError("watchdog: poll steps must be at least 1 (got " +
                      std::to_string(o.poll_steps) + ")");
}

double watchdog_speed_limit(const WatchdogOptions& o, double dt) {
  return o.runaway_displacement / dt;
}

bool first_watchdog_hit(const WatchdogRecord& r, WatchdogHit& hit) {
  if (r.first_step == ~0ull || r.count == 0) return false;
  const unsigned int n = r.count < kWatchdogSlots ? r.count : kWatchdogSlots;
  hit = r.slots[0];
  for (unsigned int k = 1; k < n; ++k)
    if (r.slots[k].id < hit.id) hit = r.slots[k];
  return true;
}

std::string watchdog_message(const WatchdogHit& hit, const WatchdogOptions& o, double dt) {
  std::string s =
      "step " + std::to_string(hit.step) + ": particle " + std::to_string(hit.id) + ": ";
  const std::string advice = "; dt = " + number(dt) + " may be too large for these forces";
  switch (hit.quantity) {
    case kWatchdogForce:
      return s + "force is not finite (|f| = " + number(hit.value) + ")" + advice;
    case kWatchdogVelocity:
      if (!std::isfinite(hit.value))
        return s + "velocity is not finite (" + number(hit.value) + ")" + advice;
      return s + "velocity " + number(hit.value) + " exceeds the runaway limit " +
             number(watchdog_speed_limit(o, dt)) + " (" + number(o.runaway_displacement) +
             " rc per step at dt = " + number(dt) + ") at " + where(hit) +
             "; dt may be too large for these forces";
    case kWatchdogPosition:
      return s + "position is not finite (" + number(hit.value) + ")" + advice;
    case kWatchdogSolid:
      return s + "fluid leaked into the solid: at " + where(hit) + ", " + number(hit.value) +
             " rc inside a solid voxel, deeper than the stop depth (the solid grid's bounce "
             "did not hold it back, or it is off)";
    default:
      return s + "unknown watchdog quantity " + std::to_string(hit.quantity);
  }
}

template <class Real>
void watchdog_scan(const StepView<Real>& v, const WatchdogOptions& o) {
  const double limit = watchdog_speed_limit(o, static_cast<double>(v.dt));
  // Squared in double first: a limit beyond the float range becomes +inf, which passes all.
  const Real max_speed2 = static_cast<Real>(limit * limit);
  WatchdogHit found;
  bool any = false;
  const int n = v.n;
#pragma omp parallel
  {
    WatchdogHit mine;
    bool hit = false;
#pragma omp for schedule(static) nowait
    for (int i = 0; i < n; ++i) {
      double value = 0;
      const int q = watchdog_check(v, i, max_speed2, value);
      if (q == kWatchdogOk || (hit && v.id[i] >= mine.id)) continue;
      mine = WatchdogHit{v.step, v.id[i], q, value};
      mine.position[0] = double(v.x[i]);
      mine.position[1] = double(v.y[i]);
      mine.position[2] = double(v.z[i]);
      hit = true;
    }
    if (hit) {
#pragma omp critical
      if (!any || mine.id < found.id) {
        found = mine;
        any = true;
      }
    }
  }
  if (any) throw NumericalError(watchdog_message(found, o, static_cast<double>(v.dt)));
}

template void watchdog_scan<float>(const StepView<float>&, const WatchdogOptions&);
template void watchdog_scan<double>(const StepView<double>&, const WatchdogOptions&);

}  // namespace mesorock::sim
