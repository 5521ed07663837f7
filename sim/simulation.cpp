#include "sim/simulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "mesorock/errors.h"
#include "sim/domain/communicator.h"
#include "sim/domain/distributed.h"
#include "sim/engine_cpu.h"
#include "sim/engine_factory.h"
#include "sim/host_reductions.h"
#include "sim/state.h"
#include "sim/state_snapshot.h"
#include "sim/terms.h"
#include "sim/wall_model.h"
#if defined(MESOROCK_HAVE_CUDA)
#include "sim/cuda/engine_cuda.h"
#endif

namespace mesorock::sim {

namespace {

// Entries of the wall model's kappa(phi) table over phi in [0, 1/2] (linear interpolation between
// them; kappa varies smoothly except near phi = 1/2, where the cap takes over).
constexpr int kKappaEntries = 256;

void check_finite(double v, const std::string& what) {
  if (!std::isfinite(v)) throw ConfigError(what + " is not a finite number");
}

// Whether the solid grid spans the box edge along axis a (then its indices wrap on a periodic
// axis): same start and length to a millionth of the edge.
bool grid_spans_axis(const SolidMask& g, const BoxSpec& box, int a) {
  const auto k = static_cast<size_t>(a);
  const double len = box.length(a), tol = 1e-6 * len;
  return std::abs(g.origin[k] - box.lo[k]) <= tol &&
         std::abs(static_cast<double>(g.dims[k]) * g.voxel[k] - len) <= tol;
}

}  // namespace

template <class Real>
SolidView<Real> solid_view_of(const SolidSpec& spec, const BoxSpec& box) {
  SolidView<Real> v;
  if (!spec.mask) return v;
  const SolidMask& g = *spec.mask;
  v.solid = g.solid.data();
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<size_t>(a);
    v.dims[a] = static_cast<int>(g.dims[k]);
    v.origin[a] = static_cast<Real>(g.origin[k]);
    v.voxel[a] = static_cast<Real>(g.voxel[k]);
    v.inv_voxel[a] = static_cast<Real>(1.0 / g.voxel[k]);
    v.periodic[a] = box.periodic[k] && grid_spans_axis(g, box, a);
    // Far enough that every depth up to the stop depth is found exactly.
    v.reach[a] = static_cast<int>(std::ceil(spec.stop_depth / g.voxel[k])) + 1;
  }
  v.bounce = spec.bounce;
  v.stop_depth = static_cast<Real>(spec.stop_depth);
  return v;
}
template SolidView<float> solid_view_of<float>(const SolidSpec&, const BoxSpec&);
template SolidView<double> solid_view_of<double>(const SolidSpec&, const BoxSpec&);

// step: the step the particles are at (a virtual wall that was lifted before it checks nothing).
void validate_inputs(const Model& m, const BoxSpec& box, const ParticleSet& p, double dt,
                     std::uint64_t step) {
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
      if (m.conservative == ConservativeKind::DPD && q.B != 0)
        throw ConfigError("B is only meaningful for the mdpd conservative force");
    }
  }
  if (m.solid.mask) {
    const SolidMask& g = *m.solid.mask;
    g.check("solid grid");
    if (g.dims[0] > 1 << 24 || g.dims[1] > 1 << 24 || g.dims[2] > 1 << 24)
      throw ConfigError("solid grid: at most 2^24 voxels along an axis");
    check_finite(m.solid.stop_depth, "solid stop depth");
    if (!(m.solid.stop_depth > 0) || m.solid.stop_depth > 4)
      throw ConfigError("solid stop depth must be in (0, 4] rc");
    for (int a = 0; a < 3; ++a)
      if (box.periodic[a] && !grid_spans_axis(g, box, a) &&
          g.origin[a] + g.dims[a] * g.voxel[a] > box.lo[a] + box.length(a) * (1 + 1e-6))
        throw ConfigError(
            "solid grid: it extends past the box along a periodic axis without spanning it");
  }
  for (int a = 0; a < 3; ++a) {
    check_finite(box.lo[a], "box lo");
    check_finite(box.hi[a], "box hi");
    const double len = box.length(a);
    if (!(len > 0)) throw ConfigError("box hi must exceed lo on every axis");
    // Minimum image needs L >= 2 rc, else a pair would interact through two images.
    if (box.periodic[a] && len < 2.0)
      throw ConfigError("a periodic box edge must be at least 2 rc long");
  }
  if (m.wall_model.enabled) {
    const WallModelSpec& w = m.wall_model;
    check_finite(w.wall_density, "wall model wall density");
    if (!(w.wall_density > 0)) throw ConfigError("wall model wall density must be positive");
    check_finite(w.penetration_threshold, "wall model penetration threshold");
    if (!(w.penetration_threshold > 0 && w.penetration_threshold < 1))
      throw ConfigError("wall model penetration threshold must be in (0, 1)");
    check_finite(w.slip_factor, "wall model slip factor");
    if (!(w.slip_factor >= 0 && w.slip_factor <= 1))
      throw ConfigError("wall model slip factor must be in [0, 1] (1 = no slip)");
    check_finite(w.max_dissipation_factor, "wall model max dissipation factor");
    if (!(w.max_dissipation_factor >= 1))
      throw ConfigError("wall model max dissipation factor must be at least 1");
    const std::uint32_t mask = m.wall_mask();
    if (mask == 0)
      throw ConfigError("the wall model needs wall particles: no type is frozen or named as wall");
    for (int t = 0; t < m.ntypes(); ++t)
      if (((mask >> t) & 1u) && !m.types[t].frozen)
        throw ConfigError("wall type " + m.types[t].name +
                          " is not frozen (the wall model supports frozen walls only)");
    if (!m.thermostat)
      throw ConfigError(
          "the wall model needs the thermostat (its no-slip condition is a dissipation)");
  }
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
  if (m.rigid_slabs.size() > static_cast<size_t>(kMaxRigidSlabs))
    throw ConfigError("at most " + std::to_string(kMaxRigidSlabs) + " rigid slabs");
  for (size_t k = 0; k < m.rigid_slabs.size(); ++k) {
    const RigidSlabSpec& r = m.rigid_slabs[k];
    if (r.type < 0 || r.type >= m.ntypes()) throw ConfigError("rigid slab of an unknown type");
    const std::string name = "rigid slab " + m.types[static_cast<size_t>(r.type)].name;
    if (m.types[static_cast<size_t>(r.type)].frozen)
      throw ConfigError(name + ": a slab type must not be frozen (it moves as a rigid body)");
    if (m.wall_model.enabled && ((m.wall_mask() >> r.type) & 1u))
      throw ConfigError(name + ": a slab type cannot also be a wall of the wall model");
    if (r.axis < 0 || r.axis > 2) throw ConfigError(name + ": axis must be 0, 1 or 2");
    check_finite(r.applied_pressure, name + " applied pressure");
    for (size_t q = 0; q < k; ++q)
      if (m.rigid_slabs[q].type == r.type) throw ConfigError(name + ": listed twice");
    if (std::count(p.type.begin(), p.type.end(), r.type) == 0)
      throw ConfigError(name + ": the slab has no particles");
  }
  if (m.injections.size() > static_cast<size_t>(kMaxInjections))
    throw ConfigError("at most " + std::to_string(kMaxInjections) + " injection boundaries");
  for (size_t k = 0; k < m.injections.size(); ++k) {
    const InjectionSpec& q = m.injections[k];
    const std::string name = "injection " + std::to_string(k + 1);
    if (q.inject_type < 0 || q.inject_type >= m.ntypes())
      throw ConfigError(name + ": injected type out of range");
    if (!m.is_mobile(q.inject_type))
      throw ConfigError(name + ": the injected type must be mobile (not frozen, not a slab)");
    if (q.eject_types == 0) throw ConfigError(name + ": no type may be ejected");
    for (int t = 0; t < 32; ++t) {
      if (!((q.eject_types >> t) & 1u)) continue;
      if (t >= m.ntypes()) throw ConfigError(name + ": ejected type out of range");
      if (!m.is_mobile(t))
        throw ConfigError(name + ": ejected type " + m.types[static_cast<size_t>(t)].name +
                          " must be mobile (not frozen, not a slab)");
    }
    bool overlap = true;
    for (int a = 0; a < 3; ++a) {
      for (double c : {q.inlet_lo[a], q.inlet_hi[a], q.outlet_lo[a], q.outlet_hi[a]}) {
        check_finite(c, name + " inlet/outlet corner");
        if (c < box.lo[a] || c > box.hi[a])
          throw ConfigError(name + ": inlet and outlet must lie inside the box");
      }
      if (!(q.inlet_hi[a] > q.inlet_lo[a]) || !(q.outlet_hi[a] > q.outlet_lo[a]))
        throw ConfigError(name + ": inlet and outlet need hi > lo on every axis");
      overlap = overlap && q.inlet_lo[a] < q.outlet_hi[a] && q.outlet_lo[a] < q.inlet_hi[a];
    }
    if (overlap) throw ConfigError(name + ": inlet and outlet boxes overlap");
    if (q.every < 1) throw ConfigError(name + ": every must be at least 1 step");
    if (q.per_event < 1 || q.per_event > 1024)
      throw ConfigError(name + ": particles per event must be 1 to 1024");
    if (!(q.stop_step > q.start_step)) throw ConfigError(name + ": stop step must follow start");
  }
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
      s << "particle " << p.id[i] << " has type " << p.type[i] << " outside 0.." << m.ntypes() - 1;
      throw ConfigError(s.str());
    }
    const double c[6] = {p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i]};
    for (double v : c)
      if (!std::isfinite(v)) {
        std::ostringstream s;
        s << "particle " << p.id[i] << " has a non-finite position or velocity";
        throw ConfigError(s.str());
      }
    for (int a = 0; a < 3; ++a) {
      if (c[a] < box.lo[a] || c[a] > box.hi[a]) {
        std::ostringstream s;
        s << "particle " << p.id[i] << " lies outside the box";
        throw ConfigError(s.str());
      }
    }
    if (m.solid.mask && !m.types[static_cast<size_t>(p.type[i])].frozen &&
        solid.in_solid(c[0], c[1], c[2]) && !is_slab(p.type[i])) {
      std::ostringstream s;
      s << "particle " << p.id[i] << " (type " << m.types[static_cast<size_t>(p.type[i])].name
        << ") starts inside a solid voxel of the solid grid, at (" << c[0] << ", " << c[1] << ", "
        << c[2] << ")";
      throw ConfigError(s.str());
    }
    for (size_t k = 0; k < m.virtual_walls.size(); ++k) {
      const VirtualWallSpec& w = m.virtual_walls[k];
      if (w.until_step <= step || !((w.types >> p.type[i]) & 1u)) continue;
      const double d = c[w.axis] - w.position;
      if (w.keep_below ? d >= 0 : d < 0) {
        std::ostringstream s;
        s << "particle " << p.id[i] << " starts on the blocked side of virtual wall " << k + 1;
        throw ConfigError(s.str());
      }
    }
  }
}

template <class Real>
void init_host_state(HostState<Real>& s, const Model& model, const BoxSpec& box,
                     const ParticleSet& p, double dt, const SimulationOptions& opt) {
  if (opt.cells_per_cutoff < 1 || opt.cells_per_cutoff > 4)
    throw ConfigError("cells per cutoff must be 1 to 4 (got " +
                      std::to_string(opt.cells_per_cutoff) + ")");
  validate_watchdog_options(opt.watchdog);
  if (opt.reorder_every < 1 || opt.reorder_every > 1000)
    throw ConfigError("reorder interval must be 1 to 1000 steps (got " +
                      std::to_string(opt.reorder_every) + ")");
  if (!(opt.skin >= 0 && opt.skin <= 1))
    throw ConfigError("skin must be in [0, 1] rc (got " + std::to_string(opt.skin) + ")");
  if (opt.reorder_every > 1 && !(opt.skin > 0))
    throw ConfigError("a reorder interval above 1 needs a skin > 0 (particles move between sorts)");
  if (opt.reorder_every > 1 && opt.comm && (opt.comm->size() > 1 || opt.decomposition.force))
    throw ConfigError("a decomposed run re-sorts every step (its exchange changes the storage)");
  s.reorder_every = opt.reorder_every;
  s.skin = static_cast<Real>(opt.skin);
  const int nt = model.ntypes();
  s.ntypes = nt;
  s.table.resize(static_cast<size_t>(nt * nt));
  for (int a = 0; a < nt; ++a)
    for (int b = 0; b < nt; ++b) {
      const PairSpec& q = model.pair(a, b);
      PairParams<Real>& t = s.table[static_cast<size_t>(a * nt + b)];
      t.A = static_cast<Real>(q.A);
      t.B = static_cast<Real>(q.B);
      t.gamma = static_cast<Real>(q.gamma);
      t.sigma = static_cast<Real>(std::sqrt(2.0 * q.gamma * model.kBT));
    }
  s.body_force.resize(static_cast<size_t>(3 * nt));
  for (int t = 0; t < nt; ++t)
    for (int a = 0; a < 3; ++a)
      s.body_force[static_cast<size_t>(3 * t + a)] =
          static_cast<Real>(model.types[t].body_force[a]);
  s.frozen_mask = model.frozen_mask();
  for (int a = 0; a < 3; ++a) {
    s.box.lo[a] = static_cast<Real>(box.lo[a]);
    s.box.length[a] = static_cast<Real>(box.length(a));
    s.box.periodic[a] = box.periodic[a];
  }
  s.grid = CellGrid<Real>::make(s.box, static_cast<Real>(1 + opt.skin), opt.cells_per_cutoff);
  if (model.wall_model.enabled) {
    const WallModelSpec& w = model.wall_model;
    s.walls.wall_mask = model.wall_mask();
    s.walls.phi_c = static_cast<Real>(w.penetration_threshold);
    s.walls.reflection = w.reflection;
    s.walls.inv_wall_density = static_cast<Real>(1.0 / w.wall_density);
    s.walls.slip_factor = static_cast<Real>(w.slip_factor);
    s.walls.phi_max = Real(0.5);
    const std::vector<double> table = tabulate_kappa(kKappaEntries, 0.5, w.max_dissipation_factor);
    s.walls.entries = kKappaEntries;
    s.kappa.assign(table.begin(), table.end());
    s.bvf.assign(p.size(), Real(0));
  }
  s.solid = solid_view_of<Real>(model.solid, box);
  s.virtual_walls.count = static_cast<int>(model.virtual_walls.size());
  for (size_t k = 0; k < model.virtual_walls.size(); ++k) {
    const VirtualWallSpec& w = model.virtual_walls[k];
    s.virtual_walls.axis[k] = w.axis;
    s.virtual_walls.position[k] = static_cast<Real>(w.position);
    s.virtual_walls.type_mask[k] = w.types;
    s.virtual_walls.keep_below[k] = w.keep_below;
    s.virtual_walls.until_step[k] = w.until_step;
  }
  for (const RigidSlabSpec& r : model.rigid_slabs) {
    const int k = s.slabs.count++;
    s.slabs.mask |= 1u << r.type;
    s.slabs.type[k] = r.type;
    s.slabs.axis[k] = r.axis;
    RigidSlabBody b;
    b.type = r.type;
    b.axis = r.axis;
    double area = 1;
    for (int a = 0; a < 3; ++a)
      if (a != r.axis) area *= box.length(a);
    b.applied_force = r.applied_pressure * area;
    b.mass = static_cast<double>(std::count(p.type.begin(), p.type.end(), r.type));
    s.slab_bodies.push_back(b);
  }
  for (size_t k = 0; k < model.injections.size(); ++k) {
    const InjectionSpec& q = model.injections[k];
    InjectionPlan<Real> plan;
    plan.view.inject_type = q.inject_type;
    plan.view.eject_types = q.eject_types;
    for (int a = 0; a < 3; ++a) {
      plan.view.inlet_lo[a] = static_cast<Real>(q.inlet_lo[a]);
      plan.view.inlet_hi[a] = static_cast<Real>(q.inlet_hi[a]);
      plan.view.outlet_lo[a] = static_cast<Real>(q.outlet_lo[a]);
      plan.view.outlet_hi[a] = static_cast<Real>(q.outlet_hi[a]);
    }
    plan.view.sqrt_kBT = static_cast<Real>(std::sqrt(model.kBT));
    plan.view.seed = model.seed;
    plan.view.index = static_cast<int>(k);
    plan.every = q.every;
    plan.start_step = q.start_step;
    plan.stop_step = q.stop_step;
    plan.per_event = q.per_event;
    s.injections.push_back(plan);
  }
  s.slab_half_velocity.assign(s.slab_bodies.size(), Real(0));
  s.slab_velocity.assign(s.slab_bodies.size(), Real(0));
  s.body_force_axis = model.body_force_axis;
  s.body_force_midplane =
      static_cast<Real>(0.5 * (box.lo[static_cast<size_t>(model.body_force_axis)] +
                               box.hi[static_cast<size_t>(model.body_force_axis)]));
  s.rd = static_cast<Real>(model.rd);
  s.dt = static_cast<Real>(dt);
  s.lambda = static_cast<Real>(model.lambda);
  s.seed = model.seed;
  s.step = 0;
  const size_t n = p.size();
  auto conv = [&](const std::vector<double>& in, std::vector<Real>& out) {
    out.resize(n);
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<Real>(in[i]);
  };
  conv(p.x, s.x);
  conv(p.y, s.y);
  conv(p.z, s.z);
  conv(p.vx, s.vx);
  conv(p.vy, s.vy);
  conv(p.vz, s.vz);
  // A position exactly on the upper face of a periodic box belongs at the lower face.
  for (size_t i = 0; i < n; ++i) {
    Real* c[3] = {&s.x[i], &s.y[i], &s.z[i]};
    for (int a = 0; a < 3; ++a) {
      const Real hi = s.box.lo[a] + s.box.length[a];
      if (*c[a] >= hi) *c[a] = s.box.periodic[a] ? s.box.lo[a] : std::nextafter(hi, s.box.lo[a]);
      if (*c[a] < s.box.lo[a]) *c[a] = s.box.lo[a];
    }
  }
  s.type = p.type;
  s.id = p.id;
  // A mobile particle in the pore in double precision may round into the solid voxel next to
  // it in single (a packed particle sits just inside its voxel's face): move it back by the
  // fewest ulps, so the solid grid's invariant (no mobile particle inside) holds from step 0.
  if (s.solid.enabled()) {
    const std::uint32_t skip = s.frozen_mask | s.slabs.mask;
    for (size_t i = 0; i < n; ++i) {
      if (((skip >> s.type[i]) & 1u) || !s.solid.in_solid(s.x[i], s.y[i], s.z[i])) continue;
      Real* c[3] = {&s.x[i], &s.y[i], &s.z[i]};
      bool fixed = false;
      for (int k = 1; k <= 16 && !fixed; ++k)
        for (int a = 0; a < 3 && !fixed; ++a)
          for (const Real toward :
               {-std::numeric_limits<Real>::infinity(), std::numeric_limits<Real>::infinity()}) {
            const Real keep = *c[a];
            for (int u = 0; u < k; ++u) *c[a] = std::nextafter(*c[a], toward);
            if (!s.solid.in_solid(s.x[i], s.y[i], s.z[i])) {
              fixed = true;
              break;
            }
            *c[a] = keep;
          }
      if (!fixed)
        throw ConfigError("particle " + std::to_string(p.id[i]) +
                          " lies inside a solid voxel of the solid grid in " +
                          (sizeof(Real) == 4 ? "single" : "double") + " precision");
    }
  }
  // Shared by every engine: original order, zeroed forces and densities, and v~ = v only when
  // the thermostat needs it (an unused observable or term owns no memory).
  s.origin.resize(n);
  for (size_t i = 0; i < n; ++i) s.origin[i] = static_cast<std::int32_t>(i);
  for (auto* a : {&s.fx, &s.fy, &s.fz, &s.rho}) a->assign(n, Real(0));
  if (model.thermostat) {
    s.vex = s.vx;
    s.vey = s.vy;
    s.vez = s.vz;
  }
}

template <class Real>
std::unique_ptr<Engine<Real>> make_engine(const Model& model, const SimulationOptions& opt) {
  if (opt.backend == BackendKind::CPU) return make_cpu_engine<Real>(model, opt.threads);
#if defined(MESOROCK_HAVE_CUDA)
  return make_cuda_engine<Real>(model, opt.device, opt.profile);
#else
  throw DeviceError(cuda_unavailable_reason());
#endif
}

template std::unique_ptr<Engine<float>> make_engine<float>(const Model&, const SimulationOptions&);
template std::unique_ptr<Engine<double>> make_engine<double>(const Model&,
                                                             const SimulationOptions&);
template void init_host_state<float>(HostState<float>&, const Model&, const BoxSpec&,
                                     const ParticleSet&, double, const SimulationOptions&);
template void init_host_state<double>(HostState<double>&, const Model&, const BoxSpec&,
                                      const ParticleSet&, double, const SimulationOptions&);

namespace {

template <class Real>
class SimulationImpl final : public Simulation {
 public:
  // resume: a saved state of a run of this model (else the run starts from p at step 0).
  SimulationImpl(const Model& model, const BoxSpec& box, const ParticleSet& p, double dt,
                 const SimulationOptions& opt, const SimulationState* resume = nullptr)
      : model_(model), box_(box), dt_(dt), on_run_(opt.on_run) {
    const auto poll = [&opt] {
      if (opt.interrupt_check) opt.interrupt_check();
    };
    init_host_state(state_, model, box, p, dt, opt);
    poll();
    HostState<Real>& s = state_;
    dispatch_terms(model, [&](auto terms) { pass_name_ = term_set_name<decltype(terms)>(); });
    engine_ = make_engine<Real>(model, opt);
    engine_->set_interrupt_check(opt.interrupt_check);
    if (resume) {
      load_state(s, *resume);
      poll();
      engine_->restore(s, resume->wall_corrections);
    } else {
      engine_->initialize(s);
    }
    engine_->set_interrupt_check({});
    poll();
    engine_->set_watchdog(opt.watchdog);
    // The initial forces may live only on the device: the next read downloads them.
    host_current_ = false;
  }

  void run(std::uint64_t steps) override {
    engine_->advance(steps);
    host_current_ = false;
    if (on_run_) on_run_(steps, size());
  }
  void set_dt(double dt) override {
    if (!(dt > 0) || !std::isfinite(dt)) throw ConfigError("dt must be a positive number");
    dt_ = dt;
    engine_->set_dt(static_cast<Real>(dt));
  }
  double dt() const override { return dt_; }
  std::uint64_t step() const override { return engine_->step(); }
  size_t size() const override { return static_cast<size_t>(state_.size()); }

  ParticleSet particles() override {
    sync();
    ParticleSet p;
    p.x = in_original_order(state_.x);
    p.y = in_original_order(state_.y);
    p.z = in_original_order(state_.z);
    p.vx = in_original_order(state_.vx);
    p.vy = in_original_order(state_.vy);
    p.vz = in_original_order(state_.vz);
    p.type = in_original_order<std::int32_t, std::int32_t>(state_.type);
    p.id = in_original_order<std::int64_t, std::int64_t>(state_.id);
    return p;
  }

  std::vector<double> densities() override {
    sync();
    return in_original_order(state_.rho);
  }

  std::vector<double> boundary_volume_fractions() override {
    if (state_.bvf.empty()) return {};
    sync();
    return in_original_order(state_.bvf);
  }

  std::uint64_t wall_corrections() const override { return engine_->wall_corrections(); }

  std::vector<RigidSlabState> rigid_slabs() override {
    sync();
    std::vector<RigidSlabState> out;
    for (const RigidSlabBody& b : state_.slab_bodies) {
      RigidSlabState r;
      r.type = model_.types[static_cast<size_t>(b.type)].name;
      r.axis = b.axis;
      r.velocity = b.velocity;
      r.force = b.force;
      r.applied_force = b.applied_force;
      r.mass = b.mass;
      const std::vector<Real>& pos = b.axis == 0 ? state_.x : (b.axis == 1 ? state_.y : state_.z);
      double sum = 0;
      for (int i = 0; i < state_.size(); ++i)
        if (state_.type[i] == b.type) sum += pos[i];
      r.position = b.mass > 0 ? sum / b.mass : 0;
      out.push_back(r);
    }
    return out;
  }

  std::array<std::vector<double>, 3> forces() override {
    sync();
    return {in_original_order(state_.fx), in_original_order(state_.fy),
            in_original_order(state_.fz)};
  }

  double kinetic_temperature() override {
    sync();
    const MobileSums m = mobile_sums(state_, [](int) { return true; });
    return m.count > 0 ? m.v2 / (3.0 * m.count) : 0.0;
  }

  std::array<double, 3> momentum() override {
    sync();
    return mobile_sums(state_, [](int) { return true; }).p;
  }

  StressSample stress() override { return stress_of(VirialRegion<Real>{}, box_.volume()); }

  StressSample region_stress(const RegionSelection& r) override {
    double volume = 1;
    const VirialRegion<Real> region = virial_region_of<Real>(r, &volume);
    return stress_of(region, volume);
  }

  std::vector<InjectionCounts> injections() override { return engine_->injection_counts(); }

  SolidIntrusion solid_intrusion() override {
    if (!state_.solid.enabled()) return {};
    sync();
    return solid_intrusion_of(state_, [](int) { return true; });
  }

 private:
  StressSample stress_of(const VirialRegion<Real>& region, double volume) {
    sync();
    StressSample out;
    out.volume = volume;
    const double inv_v = 1.0 / out.volume;
    const std::array<double, 6> kinetic = kinetic_stress_sums(state_, region);
    const VirialSums w = engine_->virial(region);
    for (int c = 0; c < 6; ++c) {
      out.kinetic[c] = kinetic[c] * inv_v;
      out.conservative[c] = w.conservative[c] * inv_v;
      out.dissipative[c] = w.dissipative[c] * inv_v;
      out.random[c] = w.random[c] * inv_v;
    }
    return out;
  }

 public:
  std::vector<double> bin_sums(const BinGrid& grid) override {
    check_bin_grid(grid);
    std::vector<double> sums;
    engine_->bin_sums(grid, sums);
    return sums;
  }

  const Model& model() const override { return model_; }
  const BoxSpec& box() const override { return box_; }
  std::string backend_name() const override { return engine_->name(); }
  std::string pass_name() const override { return pass_name_; }
  std::size_t device_bytes() const override { return engine_->device_bytes(); }
  std::string profile_report() const override { return engine_->profile_report(); }
  SimulationState state() override {
    sync();
    SimulationState out = save_state(state_);
    out.dt = dt_;
    out.wall_corrections = engine_->wall_corrections();
    return out;
  }

 private:
  // Storage is sorted by cell; callers see particles in the order they were given.
  template <class In, class Out = double>
  std::vector<Out> in_original_order(const std::vector<In>& a) const {
    std::vector<Out> out(a.size());
    for (size_t k = 0; k < a.size(); ++k)
      out[static_cast<size_t>(state_.origin[k])] = static_cast<Out>(a[k]);
    return out;
  }

  void sync() {
    if (!host_current_) {
      engine_->download(state_);
      host_current_ = true;
    }
  }

  Model model_;
  BoxSpec box_;
  double dt_;
  HostState<Real> state_;
  std::unique_ptr<Engine<Real>> engine_;
  std::string pass_name_;
  bool host_current_ = false;
  std::function<void(std::uint64_t, std::size_t)> on_run_;
};

}  // namespace

std::unique_ptr<Simulation> make_simulation(const Model& model, const BoxSpec& box,
                                            const ParticleSet& particles, double dt,
                                            const SimulationOptions& options) {
  validate_inputs(model, box, particles, dt);
  if (options.interrupt_check) options.interrupt_check();
  if (options.comm && (options.comm->size() > 1 || options.decomposition.force))
    return make_distributed_simulation(model, box, particles, dt, options);
  if (options.backend == BackendKind::CUDA) {
    const std::string why = cuda_unavailable_reason();
    if (!why.empty()) throw DeviceError(why);
  }
  if (model.precision == Precision::Single)
    return std::make_unique<SimulationImpl<float>>(model, box, particles, dt, options);
  return std::make_unique<SimulationImpl<double>>(model, box, particles, dt, options);
}

std::unique_ptr<Simulation> resume_simulation(const Model& model, const BoxSpec& box,
                                              const SimulationState& state,
                                              const SimulationOptions& options) {
  state.check();
  state.check_fits(model);  // on the whole state: every rank of a decomposed resume agrees
  validate_inputs(model, box, state.particles(), state.dt, state.step);
  if (options.interrupt_check) options.interrupt_check();
  if (options.comm && (options.comm->size() > 1 || options.decomposition.force))
    return resume_distributed_simulation(model, box, state, options);
  if (options.backend == BackendKind::CUDA) {
    const std::string why = cuda_unavailable_reason();
    if (!why.empty()) throw DeviceError(why);
  }
  if (model.precision == Precision::Single)
    return std::make_unique<SimulationImpl<float>>(model, box, state.particles(), state.dt, options,
                                                   &state);
  return std::make_unique<SimulationImpl<double>>(model, box, state.particles(), state.dt, options,
                                                  &state);
}

#if !defined(MESOROCK_HAVE_CUDA)
std::string cuda_unavailable_reason() {
  return "backend cuda: this build has no CUDA backend (nvcc was not found when it was "
         "configured); use --backend cpu";
}
#endif

}  // namespace mesorock::sim
