#pragma once
// The leak invariant of a run with a solid grid (sim/solid_grid.h, docs/walls.md): at every
// output row, the mobile particles inside solid voxels (past the no-slip surface, into a grain)
// are counted and the deepest is named. run, sweep and the validation cases keep one record
// each; more particles inside than [solid] stop_count stops the run like the watchdog (exit 3),
// naming the particle and where it is. (A particle deeper than stop_depth is stopped by the
// watchdog itself, at the step it gets there.)
#include <array>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "mesorock/errors.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

struct LeakRecord {
  bool available = false;
  std::uint64_t checks = 0;       // rows at which it was counted
  std::uint64_t last_inside = 0;  // at the last check
  double last_depth = 0;          // the deepest at the last check, rc
  std::uint64_t max_inside = 0;   // the most at any check
  double max_depth = 0;           // the deepest particle at any check, rc
  std::int64_t deepest_id = -1;
  std::array<double, 3> deepest_position{0, 0, 0};
  std::uint64_t deepest_step = 0;

  // Counts now; throws NumericalError when more than spec.stop_count are inside.
  void check(sim::Simulation& sim, std::uint64_t step) {
    const sim::SolidIntrusion s = sim.solid_intrusion();
    if (!s.available) return;
    LeakRecord now;
    now.available = true;
    now.checks = 1;
    now.last_inside = now.max_inside = s.inside;
    now.last_depth = now.max_depth = s.max_depth;
    now.deepest_id = s.deepest_id;
    now.deepest_position = s.deepest_position;
    now.deepest_step = step;
    merge(now);
    const std::uint64_t limit = sim.model().solid.stop_count;
    if (s.inside > limit)
      throw NumericalError("step " + std::to_string(step) +
                           ": fluid leaked into the solid: " + std::to_string(s.inside) +
                           " mobile particles inside solid voxels (limit " + std::to_string(limit) +
                           "); the deepest, particle " + std::to_string(s.deepest_id) + ", is " +
                           number(s.max_depth) + " rc deep at (" + number(s.deepest_position[0]) +
                           ", " + number(s.deepest_position[1]) + ", " +
                           number(s.deepest_position[2]) + ")");
  }

  // Folds in another record (later in time): the sweep's total over its points.
  void merge(const LeakRecord& o) {
    if (!o.available) return;
    available = true;
    checks += o.checks;
    last_inside = o.last_inside;
    last_depth = o.last_depth;
    if (o.max_inside > max_inside) max_inside = o.max_inside;
    if (o.deepest_id >= 0 && (deepest_id < 0 || o.max_depth > max_depth)) {
      max_depth = o.max_depth;
      deepest_id = o.deepest_id;
      deepest_position = o.deepest_position;
      deepest_step = o.deepest_step;
    }
  }

  nlohmann::json json() const {
    nlohmann::json j = {{"checks", checks},
                        {"inside_last", last_inside},
                        {"inside_max", max_inside},
                        {"max_depth_rc", max_depth}};
    if (deepest_id >= 0)
      j["deepest"] = {{"id", deepest_id}, {"step", deepest_step}, {"position", deepest_position}};
    return j;
  }

 private:
  static std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return buf;
  }
};

// What summary.json and sweep.json say of the solid grid and its invariant.
inline nlohmann::json solid_json(const sim::SolidSpec& spec, const LeakRecord& record) {
  nlohmann::json j = nlohmann::json::object();
  if (!spec.mask) return j;
  const sim::SolidMask& m = *spec.mask;
  j = {{"voxels", m.dims},
       {"voxel_rc", m.voxel},
       {"origin_rc", m.origin},
       {"porosity", m.porosity()},
       {"bounce", spec.bounce},
       {"stop_depth_rc", spec.stop_depth},
       {"stop_count", spec.stop_count},
       {"invariant", record.json()}};
  return j;
}

}  // namespace mesorock::pipeline
