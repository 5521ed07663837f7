// The checks of make_simulation's inputs, one per spec of the model, in the order they run: the
// first problem found is the one reported (ConfigError).
#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "sim/engine_factory.h"
#include "sim/terms.h"

namespace mesorock::sim {

namespace {

void check_finite(double v, const std::string& what) {
  if (!std::isfinite(v)) throw ConfigError(what + " is not a finite number");
}

// The types, the model's scalars, the time step and the pair table.
void check_types_and_pairs(const Model& m, double dt) {
  if (m.ntypes() < 1) throw ConfigError("model has no particle types");
  if (m.ntypes() > 32) throw ConfigError("at most 32 particle types are supported");
  if (m.pairs.size() != static_cast<size_t>(m.ntypes() * m.ntypes()))
    throw ConfigError("pair table size does not match the number of types");
  check_finite(dt, "dt");
  if (!(dt > 0)) throw ConfigError("dt must be positive");
  check_finite(m.rd, "rd");
  if (!(m.rd > 0 && m.rd <= 1)) throw ConfigError("rd must be in (0, 1] (units of rc)");
  check_finite(m.kBT, "kBT");
  if (!(m.kBT > 0)) throw ConfigError("kBT must be positive");
  if (m.body_force_axis < 0 || m.body_force_axis > 2)
    throw ConfigError("body force axis must be 0, 1 or 2 (x, y, z)");
  check_finite(m.lambda, "lambda");
  if (!(m.lambda >= 0 && m.lambda <= 1)) throw ConfigError("lambda must be in [0, 1]");
  for (int a = 0; a < m.ntypes(); ++a) {
    for (int b = 0; b < m.ntypes(); ++b) {
      const PairSpec& q = m.pair(a, b);
      const PairSpec& r = m.pair(b, a);
      if (q.A != r.A || q.B != r.B || q.gamma != r.gamma)
        throw ConfigError("pair table is not symmetric for types " + m.types[a].name + ", " +
                          m.types[b].name);
      check_finite(q.A, "A");
      check_finite(q.B, "B");
      check_finite(q.gamma, "gamma");
      if (q.gamma < 0) throw ConfigError("gamma must be >= 0");
      check_pair_terms(m, q);
    }
  }
}

// SolidSpec: the grid, its stop depth, and how it meets the periodic box edges.
void check_solid_grid(const SolidSpec& solid, const BoxSpec& box) {
  if (!solid.mask) return;
  const SolidMask& g = *solid.mask;
  g.check("solid grid");
  if (g.dims[0] > 1 << 24 || g.dims[1] > 1 << 24 || g.dims[2] > 1 << 24)
    throw ConfigError("solid grid: at most 2^24 voxels along an axis");
  check_finite(solid.stop_depth, "solid stop depth");
  if (!(solid.stop_depth > 0) || solid.stop_depth > 4)
    throw ConfigError("solid stop depth must be in (0, 4] rc");
  // The view wraps the grid along a periodic axis exactly when the grid spans that axis.
  const SolidView<double> view = solid_view_of<double>(solid, box);
  for (int a = 0; a < 3; ++a)
    if (box.periodic[a] && !view.periodic[a] &&
        g.origin[a] + g.dims[a] * g.voxel[a] > box.lo[a] + box.length(a) * (1 + 1e-6))
      throw ConfigError(
          "solid grid: it extends past the box along a periodic axis without spanning it");
}

void check_box(const BoxSpec& box) {
  for (int a = 0; a < 3; ++a) {
    check_finite(box.lo[a], "box lo");
    check_finite(box.hi[a], "box hi");
    const double len = box.length(a);
    if (!(len > 0)) throw ConfigError("box hi must exceed lo on every axis");
    // Minimum image needs L >= 2 rc, else a pair would interact through two images.
    if (box.periodic[a] && len < 2.0)
      throw ConfigError("a periodic box edge must be at least 2 rc long");
  }
}

void check_virtual_walls(const Model& m, const BoxSpec& box) {
  if (m.virtual_walls.size() > static_cast<size_t>(kMaxVirtualWalls))
    throw ConfigError("at most " + std::to_string(kMaxVirtualWalls) + " virtual walls");
  for (size_t k = 0; k < m.virtual_walls.size(); ++k) {
    const VirtualWallSpec& w = m.virtual_walls[k];
    const std::string name = "virtual wall " + std::to_string(k + 1);
    if (w.axis < 0 || w.axis > 2) throw ConfigError(name + ": axis must be 0, 1 or 2");
    check_finite(w.position, name + " position");
    const double lo = box.lo[static_cast<size_t>(w.axis)], hi = box.hi[static_cast<size_t>(w.axis)];
    if (!(w.position > lo && w.position < hi))
      throw ConfigError(name + ": position must lie inside the box");
    if (w.types == 0) throw ConfigError(name + ": blocks no type");
  }
}

// RigidSlabSpec: a mobile type of its own, listed once, with particles.
void check_rigid_slabs(const Model& m, const ParticleSet& p) {
  if (m.rigid_slabs.size() > static_cast<size_t>(kMaxRigidSlabs))
    throw ConfigError("at most " + std::to_string(kMaxRigidSlabs) + " rigid slabs");
  for (size_t k = 0; k < m.rigid_slabs.size(); ++k) {
    validate_rigid_slab(m, k);
    const int type = m.rigid_slabs[k].type;
    if (std::count(p.type.begin(), p.type.end(), type) == 0)
      throw ConfigError("slabs[" + std::to_string(k) + "].type: type \"" +
                        m.types[static_cast<size_t>(type)].name + "\" has no particles");
  }
}

void check_injections(const Model& m, const BoxSpec& box) {
  if (m.injections.size() > static_cast<size_t>(kMaxInjections))
    throw ConfigError("at most " + std::to_string(kMaxInjections) + " injection boundaries");
  for (size_t k = 0; k < m.injections.size(); ++k) validate_injection(m, box, k);
}

// Particle k's problem, as a ConfigError.
[[noreturn]] void refuse_particle(const ParticleSet& p, size_t i, const std::string& problem) {
  std::ostringstream s;
  s << "particle " << p.id[i] << problem;
  throw ConfigError(s.str());
}

// The particles: equal array lengths, known types, finite, inside the box, outside the solid
// grid's solid voxels and on the open side of every virtual wall still standing at `step`.
void check_particles(const Model& m, const BoxSpec& box, const ParticleSet& p, std::uint64_t step) {
  const size_t n = p.size();
  if (p.y.size() != n || p.z.size() != n || p.vx.size() != n || p.vy.size() != n ||
      p.vz.size() != n || p.type.size() != n || p.id.size() != n)
    throw ConfigError("particle arrays have different lengths");
  if (n > static_cast<size_t>(2147483647)) throw ConfigError("too many particles for one rank");
  const SolidView<double> solid = solid_view_of<double>(m.solid, box);
  auto is_slab = [&](int t) {
    for (const RigidSlabSpec& r : m.rigid_slabs)
      if (r.type == t) return true;
    return false;
  };
  for (size_t i = 0; i < n; ++i) {
    if (p.type[i] < 0 || p.type[i] >= m.ntypes()) {
      std::ostringstream s;
      s << " has type " << p.type[i] << " outside 0.." << m.ntypes() - 1;
      refuse_particle(p, i, s.str());
    }
    const double c[6] = {p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i]};
    for (double v : c)
      if (!std::isfinite(v)) refuse_particle(p, i, " has a non-finite position or velocity");
    for (int a = 0; a < 3; ++a)
      if (c[a] < box.lo[a] || c[a] > box.hi[a]) refuse_particle(p, i, " lies outside the box");
    if (m.solid.mask && !m.types[static_cast<size_t>(p.type[i])].frozen &&
        solid.in_solid(c[0], c[1], c[2]) && !is_slab(p.type[i])) {
      std::ostringstream s;
      s << " (type " << m.types[static_cast<size_t>(p.type[i])].name
        << ") starts inside a solid voxel of the solid grid, at (" << c[0] << ", " << c[1] << ", "
        << c[2] << ")";
      refuse_particle(p, i, s.str());
    }
    for (size_t k = 0; k < m.virtual_walls.size(); ++k) {
      const VirtualWallSpec& w = m.virtual_walls[k];
      if (w.until_step <= step || !((w.types >> p.type[i]) & 1u)) continue;
      const double d = c[w.axis] - w.position;
      if (w.keep_below ? d >= 0 : d < 0)
        refuse_particle(p, i,
                        " starts on the blocked side of virtual wall " + std::to_string(k + 1));
    }
  }
}

}  // namespace

// The messages name the scene keys (pipeline/scene.cpp prefixes its file name): the scene reader
// checks its [[injection]] blocks through this function.
void validate_wall_model(const Model& m) {
  if (!m.wall_model.enabled) return;
  const WallModelSpec& w = m.wall_model;
  auto refuse = [](const std::string& key, const std::string& problem) {
    throw ConfigError("walls." + key + ": " + problem);
  };
  if (!(w.wall_density > 0) || !std::isfinite(w.wall_density))
    refuse("wall_density",
           "must be positive and finite (got " + shortest_number_text(w.wall_density) + ")");
  if (!(w.penetration_threshold > 0 && w.penetration_threshold < 1))
    refuse("penetration_threshold",
           "must be in (0, 1) (got " + shortest_number_text(w.penetration_threshold) + ")");
  if (!(w.slip_factor >= 0 && w.slip_factor <= 1))
    refuse("slip_factor",
           "must be in [0, 1], 1 = no slip (got " + shortest_number_text(w.slip_factor) + ")");
  if (!(w.max_dissipation_factor >= 1) || !std::isfinite(w.max_dissipation_factor))
    refuse("max_dissipation_factor",
           "must be >= 1 and finite (got " + shortest_number_text(w.max_dissipation_factor) + ")");
  const std::uint32_t mask = m.wall_mask();
  for (int t = 0; t < m.ntypes() && t < 32; ++t)
    if (((mask >> t) & 1u) && !m.types[static_cast<size_t>(t)].frozen)
      refuse("types", "type \"" + m.types[static_cast<size_t>(t)].name +
                          "\" is not frozen (walls must be frozen)");
  if (mask == 0) refuse("types", "no frozen type to act as wall (give types or freeze a type)");
  if (!m.thermostat)
    refuse("model", "needs model.thermostat = true (no slip is imposed by the dissipation)");
  if (m.body_force_profile == BodyForceProfile::Reversed)
    refuse("model", "is not available with model.body_force_profile = \"reversed\"");
}

void validate_rigid_slab(const Model& m, size_t k) {
  const RigidSlabSpec& r = m.rigid_slabs.at(k);
  const std::string key = "slabs[" + std::to_string(k) + "].";
  auto refuse = [&](const std::string& what, const std::string& problem) {
    throw ConfigError(key + what + ": " + problem);
  };
  if (r.type < 0 || r.type >= m.ntypes())
    refuse("type", "type index " + std::to_string(r.type) + " out of range");
  const std::string name = "\"" + m.types[static_cast<size_t>(r.type)].name + "\"";
  if (m.types[static_cast<size_t>(r.type)].frozen)
    refuse("type", "type " + name + " is frozen (a slab moves)");
  if (m.wall_model.enabled && ((m.wall_mask() >> r.type) & 1u))
    refuse("type", "type " + name + " is a wall of the wall model (a slab moves)");
  for (size_t q = 0; q < k; ++q)
    if (m.rigid_slabs[q].type == r.type) refuse("type", name + " is already a slab");
  if (r.axis < 0 || r.axis > 2)
    refuse("axis", "must be 0, 1 or 2 (got " + std::to_string(r.axis) + ")");
  if (!std::isfinite(r.applied_pressure))
    refuse("pressure", "must be finite (got " + shortest_number_text(r.applied_pressure) + ")");
}

void validate_injection(const Model& m, const BoxSpec& box, size_t k) {
  const InjectionSpec& q = m.injections.at(k);
  const std::string key = "injection[" + std::to_string(k) + "].";
  auto refuse = [&](const std::string& what, const std::string& problem) {
    throw ConfigError(key + what + ": " + problem);
  };
  auto type_name = [&](int t) { return "type \"" + m.types[static_cast<size_t>(t)].name + "\""; };
  if (q.inject_type < 0 || q.inject_type >= m.ntypes())
    refuse("type", "type index " + std::to_string(q.inject_type) + " out of range");
  if (!m.is_mobile(q.inject_type))
    refuse("type", type_name(q.inject_type) + " is frozen or a slab (must be mobile)");
  if (q.eject_types == 0) refuse("eject_types", "must name at least one type");
  for (int t = 0; t < 32; ++t) {
    if (!((q.eject_types >> t) & 1u)) continue;
    if (t >= m.ntypes()) refuse("eject_types", "type index " + std::to_string(t) + " out of range");
    if (!m.is_mobile(t)) refuse("eject_types", type_name(t) + " is frozen or a slab");
  }
  // NaN corners fail hi > lo, infinite ones the box.
  bool overlap = true;
  for (size_t a = 0; a < 3; ++a) {
    for (auto [lo, hi, what] : {std::tuple{q.inlet_lo[a], q.inlet_hi[a], "inlet_hi"},
                                std::tuple{q.outlet_lo[a], q.outlet_hi[a], "outlet_hi"}}) {
      if (!(hi > lo))
        refuse(std::string(what) + "[" + std::to_string(a) + "]",
               "must be greater than the lo corner");
      if (lo < box.lo[a] || hi > box.hi[a])
        refuse(what, "the box must lie inside the simulation box");
    }
    overlap = overlap && q.inlet_lo[a] < q.outlet_hi[a] && q.outlet_lo[a] < q.inlet_hi[a];
  }
  if (overlap) refuse("outlet_lo", "the inlet and outlet boxes overlap");
  if (q.every < 1) refuse("every", "must be >= 1 (got " + std::to_string(q.every) + ")");
  if (q.per_event < 1 || q.per_event > 1024)
    refuse("particles", "must be in 1..1024 (got " + std::to_string(q.per_event) + ")");
  if (!(q.stop_step > q.start_step))
    refuse("stop_step",
           "must be greater than start_step (got " + std::to_string(q.stop_step) + ")");
}

// step: the step the particles are at (a virtual wall that was lifted before it checks nothing).
void validate_inputs(const Model& m, const BoxSpec& box, const ParticleSet& p, double dt,
                     std::uint64_t step) {
  check_types_and_pairs(m, dt);
  check_solid_grid(m.solid, box);
  check_box(box);
  validate_wall_model(m);
  check_virtual_walls(m, box);
  check_rigid_slabs(m, p);
  check_injections(m, box);
  check_particles(m, box, p, step);
}

}  // namespace mesorock::sim
