#pragma once
// The numerical watchdog: after every step each mobile particle's force, velocity and position are
// checked, and the first step with a non-finite value or a runaway velocity stops the run with a
// NumericalError naming the step, the particle and the quantity, before any output can see it:
//   "step 1234: particle 5678: velocity 3.1e+05 exceeds the runaway limit 100 (1 rc per step at
//    dt = 0.01); dt may be too large for these forces"
// A runaway particle is one faster than runaway_displacement / dt: it would cross more than that
// many cutoffs in one step, which no resolved trajectory does (thermal speeds are about 1.7) and
// which would carry it through a wall.
//
// One kernel body (watchdog_check) serves both backends. The CPU engine runs it in an OpenMP loop
// after each step and throws at once (watchdog_scan). The CUDA engine runs it as a kernel whose
// hits go into a WatchdogRecord in device memory; the host reads that record only every
// poll_steps steps (an asynchronous copy to pinned memory) and at the end of every run() call, so
// the GPU never waits for the host within a run. Costs are measured with `rockflow bench
// --watchdog compare` (docs/benchmarks.md).
#include <cstdint>
#include <string>

#include "sim/hd.h"

namespace mesorock::sim {

template <class Real>
struct StepView;  // sim/kernels.h

struct WatchdogOptions {
  bool enabled = true;
  // Runaway limit as a distance per step (rc): speeds above runaway_displacement / dt are errors.
  double runaway_displacement = 1.0;
  // CUDA: steps between the host's reads of the device record (it is also read when run() ends).
  int poll_steps = 100;
};

// Throws ConfigError unless the options make sense.
void validate_watchdog_options(const WatchdogOptions& o);

enum WatchdogQuantity : int {
  kWatchdogOk = 0,
  kWatchdogForce = 1,     // a force component is not finite
  kWatchdogVelocity = 2,  // |v| is not finite or above the runaway limit
  kWatchdogPosition = 3,  // a coordinate is not finite
  kWatchdogSolid = 4,     // deeper inside the solid grid than its stop depth (sim/solid_grid.h)
};

struct WatchdogHit {
  std::uint64_t step = 0;
  std::int64_t id = 0;
  int quantity = kWatchdogOk;
  double value = 0;  // |f|, |v|, the first non-finite coordinate or the depth in the solid
  double position[3] = {0, 0, 0};
};

// The device's record of hits. Only the first failing step records; its hits fill the slots in
// any order and the host reports the one with the smallest particle id (the CPU's choice too).
// When more hits than slots come in one step (a whole box blowing up), min_id still holds the
// smallest id, and a one-block kernel right after the check puts that particle's hit in slot 0.
constexpr int kWatchdogSlots = 32;
struct WatchdogRecord {
  unsigned long long first_step = ~0ull;  // all ones: no hit yet
  unsigned int count = 0;                 // hits of the first failing step (may exceed the slots)
  unsigned int resolved = 0;              // slot 0 holds the min_id hit (count > slots only)
  unsigned long long min_id = ~0ull;      // the smallest id among the first failing step's hits
  WatchdogHit slots[kWatchdogSlots];
};

// x * 0 is 0 for every finite x and NaN for an infinite or NaN one (IEEE; no fast-math here).
template <class Real>
MESO_HD MESO_INLINE bool all_finite(Real a, Real b, Real c) {
  return a * Real(0) + b * Real(0) + c * Real(0) == Real(0);
}

template <class Real>
MESO_HD MESO_INLINE double norm_as_double(Real a, Real b, Real c) {
  return sqrt(double(a) * double(a) + double(b) * double(b) + double(c) * double(c));
}

// The kernel body: what is wrong with particle i after a full step (kWatchdogOk if nothing), and
// the offending value. Forces first: a non-finite force is the cause of a non-finite velocity.
template <class Real>
MESO_HD MESO_INLINE int watchdog_check(const StepView<Real>& v, int i, Real max_speed2,
                                       double& value) {
  if (v.frozen(i)) return kWatchdogOk;
  const Real fx = v.fx[i], fy = v.fy[i], fz = v.fz[i];
  if (!all_finite(fx, fy, fz)) {
    value = norm_as_double(fx, fy, fz);
    return kWatchdogForce;
  }
  const Real ux = v.vx[i], uy = v.vy[i], uz = v.vz[i];
  if (!(ux * ux + uy * uy + uz * uz <= max_speed2)) {  // also true for NaN
    value = norm_as_double(ux, uy, uz);
    return kWatchdogVelocity;
  }
  const Real x = v.x[i], y = v.y[i], z = v.z[i];
  if (!all_finite(x, y, z)) {
    value = !all_finite(x, x, x) ? double(x) : (!all_finite(y, y, y) ? double(y) : double(z));
    return kWatchdogPosition;
  }
  // The leak invariant's stop (a fluid particle deep inside a grain): one byte read per particle
  // unless it is inside a solid voxel.
  if (v.solid.enabled() && !v.slabs.is_slab(v.type[i])) {
    const Real d = v.solid.depth(x, y, z);
    if (d > v.solid.stop_depth) {
      value = double(d);
      return kWatchdogSolid;
    }
  }
  return kWatchdogOk;
}

#if defined(__CUDACC__)
// Device side of a hit: steps after the first failing one record nothing.
__device__ inline void watchdog_record(WatchdogRecord* r, std::uint64_t step, std::int64_t id,
                                       int quantity, double value, double x, double y, double z) {
  const unsigned long long s = static_cast<unsigned long long>(step);
  if (atomicMin(&r->first_step, s) < s) return;
  atomicMin(&r->min_id, static_cast<unsigned long long>(id));
  const unsigned int slot = atomicAdd(&r->count, 1u);
  if (slot < static_cast<unsigned int>(kWatchdogSlots)) {
    WatchdogHit& h = r->slots[slot];
    h.step = step;
    h.id = id;
    h.quantity = quantity;
    h.value = value;
    h.position[0] = x;
    h.position[1] = y;
    h.position[2] = z;
  }
}
#endif

// Host side.
// The speed limit of a step of length dt.
double watchdog_speed_limit(const WatchdogOptions& o, double dt);
// The hit to report from a device record (false when it holds none).
bool first_watchdog_hit(const WatchdogRecord& r, WatchdogHit& hit);
// The one-line diagnostic of a hit.
std::string watchdog_message(const WatchdogHit& hit, const WatchdogOptions& o, double dt);
// CPU backend: runs watchdog_check over every particle (OpenMP) and throws NumericalError with
// the message of the hit with the smallest id, if any.
template <class Real>
void watchdog_scan(const StepView<Real>& v, const WatchdogOptions& o);

}  // namespace mesorock::sim
