#pragma once
// HostState <-> SimulationState (sim/checkpoint.h). Internal to sim/: simulation.cpp saves a run's
// state and loads it into a freshly built HostState (whose parameters, tables and box came from
// the same model) on resume.
#include <algorithm>

#include "mesorock/errors.h"
#include "sim/checkpoint.h"
#include "sim/state.h"

namespace mesorock::sim {

template <class Real>
SimulationState save_state(const HostState<Real>& s) {
  SimulationState out;
  out.precision = std::is_same_v<Real, float> ? Precision::Single : Precision::Double;
  out.step = s.step;
  out.dt = static_cast<double>(s.dt);
  auto widen = [](const std::vector<Real>& in) {
    return std::vector<double>(in.begin(), in.end());
  };
  const std::vector<Real>* in[14] = {&s.x,   &s.y,   &s.z,  &s.vx, &s.vy, &s.vz,  &s.vex,
                                     &s.vey, &s.vez, &s.fx, &s.fy, &s.fz, &s.rho, &s.bvf};
  std::vector<double>* to[14] = {&out.x,   &out.y,   &out.z,  &out.vx, &out.vy, &out.vz,  &out.vex,
                                 &out.vey, &out.vez, &out.fx, &out.fy, &out.fz, &out.rho, &out.bvf};
  for (int a = 0; a < 14; ++a) *to[a] = widen(*in[a]);
  out.type = s.type;
  out.origin = s.origin;
  out.id = s.id;
  out.slabs = s.slab_bodies;
  return out;
}

// Loads `saved` into `s`, which was built from the same model, box and particles (in original
// order): the per-particle arrays are replaced by the saved storage order. That the state fits
// the model (precision, thermostat, wall model, slabs) is checked once by resume_simulation
// (SimulationState::check_fits), on the whole state.
template <class Real>
void load_state(HostState<Real>& s, const SimulationState& saved) {
  saved.check();
  if (saved.size() != static_cast<size_t>(s.size()))
    throw ConfigError("state: " + std::to_string(saved.size()) + " particles, the model has " +
                      std::to_string(s.size()));
  auto narrow = [](const std::vector<double>& in, std::vector<Real>& out) {
    out.resize(in.size());
    std::transform(in.begin(), in.end(), out.begin(),
                   [](double v) { return static_cast<Real>(v); });
  };
  const std::vector<double>* in[14] = {&saved.x,  &saved.y,   &saved.z,   &saved.vx,  &saved.vy,
                                       &saved.vz, &saved.vex, &saved.vey, &saved.vez, &saved.fx,
                                       &saved.fy, &saved.fz,  &saved.rho, &saved.bvf};
  std::vector<Real>* to[14] = {&s.x,   &s.y,   &s.z,  &s.vx, &s.vy, &s.vz,  &s.vex,
                               &s.vey, &s.vez, &s.fx, &s.fy, &s.fz, &s.rho, &s.bvf};
  for (int a = 0; a < 14; ++a) narrow(*in[a], *to[a]);
  s.type = saved.type;
  s.origin = saved.origin;
  s.id = saved.id;
  s.step = saved.step;
  s.dt = static_cast<Real>(saved.dt);
  for (size_t k = 0; k < saved.slabs.size(); ++k) {
    const RigidSlabBody& b = saved.slabs[k];
    s.slab_bodies[k] = b;
    s.slab_half_velocity[k] = static_cast<Real>(b.half_velocity);
    s.slab_velocity[k] = static_cast<Real>(b.velocity);
  }
}

}  // namespace mesorock::sim
