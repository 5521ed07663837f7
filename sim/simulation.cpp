#include "sim/simulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "mesorock/errors.h"
#include "sim/domain/communicator.h"
#include "sim/domain/domain.h"
#include "sim/engine_cpu.h"
#include "sim/engine_factory.h"
#include "sim/host_reductions.h"
#include "sim/state.h"
#include "sim/state_snapshot.h"
#include "sim/stepper.h"
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

}  // namespace

template <class Real>
void init_host_state(HostState<Real>& s, const Model& model, const BoxSpec& box,
                     const ParticleSet& p, double dt, const SimulationOptions& opt) {
  if (opt.cells_per_cutoff < 1 || opt.cells_per_cutoff > 4)
    throw ConfigError("cells per cutoff must be 1 to 4 (got " +
                      std::to_string(opt.cells_per_cutoff) + ")");
  validate_watchdog_options(opt.watchdog);
  const int lanes = opt.lanes_per_particle;
  if (lanes != 0 && lanes != 1 && lanes != 2 && lanes != 4 && lanes != 8)
    throw ConfigError("lanes per particle must be 0 (by the particle count), 1, 2, 4 or 8 (got " +
                      std::to_string(lanes) + ")");
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
    for (int b = 0; b < nt; ++b)
      s.table[static_cast<size_t>(a * nt + b)] = pair_params<Real>(model, model.pair(a, b));
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
  s.size_left_to_grid();  // the walls and the solid, set above, decide whether it exists
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
  if (opt.backend == BackendKind::CPU)
    return make_cpu_engine<Real>(model,
                                 CpuEngineOptions{opt.threads, opt.frozen_part, opt.buried_part});
#if defined(MESOROCK_HAVE_CUDA)
  return make_cuda_engine<Real>(
      model,
      CudaEngineOptions{opt.device, opt.profile, opt.frozen_part, opt.buried_part, opt.graphs,
                        opt.lanes_per_particle, opt.penetration_mask, opt.frozen_density_list});
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

// The Domain of a run on one rank: the whole box, no hooks, reductions over itself.
template <class Real>
class OneRank final : public Domain<Real> {
 public:
  explicit OneRank(RankSolver<Real>& solver) : solver_(solver), self_(make_self_communicator()) {}
  bool decomposed() const override { return false; }
  Communicator& comm() const override { return *self_; }
  StepHooks<Real>* hooks() override { return &serial_; }
  void init_state(const Model& model, const BoxSpec& box, const ParticleSet& p, double dt,
                  const SimulationOptions& opt, const SimulationState* resume) override {
    init_host_state(solver_.host, model, box, p, dt, opt);
    if (resume) load_state(solver_.host, *resume);
  }
  // Storage is sorted by cell; origin is each particle's index in the caller's order.
  std::size_t original_index(std::int32_t origin, std::int64_t) const override {
    return static_cast<std::size_t>(origin);
  }

 private:
  RankSolver<Real>& solver_;
  std::shared_ptr<Communicator> self_;
  SerialHooks<Real> serial_;  // no ghosts, no migration; each reduction returns its argument
};

// The Simulation of one rank or many: this rank's solver and the Domain that says how the box is
// shared. Observables are sums over this rank's own particles, reduced over the ranks.
template <class Real>
class SimulationImpl final : public Simulation {
 public:
  // resume: a saved state of a run of this model whose particles are p (in the original order
  // when decomposed: SimulationState::in_original_order); else the run starts from p at step 0.
  SimulationImpl(const Model& model, const BoxSpec& box, const ParticleSet& p, double dt,
                 const SimulationOptions& opt, bool decomposed,
                 const SimulationState* resume = nullptr)
      : model_(model),
        box_(box),
        dt_(dt),
        total_(p.size()),
        on_run_(opt.on_run),
        domain_(decomposed ? make_decomposed_domain<Real>(solver_, opt)
                           : std::make_unique<OneRank<Real>>(solver_)) {
    // A decomposed set-up is collective: a rank that stopped alone would leave the others waiting.
    const std::function<void()> interrupt_check =
        decomposed ? std::function<void()>{} : opt.interrupt_check;
    const auto poll = [&interrupt_check] {
      if (interrupt_check) interrupt_check();
    };
    domain_->init_state(model, box, p, dt, opt, resume);
    poll();
    dispatch_terms(model, [&](auto terms) { pass_name_ = term_set_name<decltype(terms)>(); });
    solver_.engine = make_engine<Real>(model, opt);
    Engine<Real>& engine = *solver_.engine;
    engine.set_interrupt_check(interrupt_check);
    if (resume) {
      // The run's wall-correction count goes to rank 0 alone (wall_corrections() sums them).
      engine.restore(solver_.host, rank() == 0 ? resume->wall_corrections : 0, *domain_->hooks());
    } else {
      engine.initialize(solver_.host, *domain_->hooks());
    }
    engine.set_interrupt_check({});
    poll();
    engine.set_watchdog(opt.watchdog);
    // The initial forces may live only on the device: the next read downloads them.
    solver_.host_current = false;
    domain_->started();
  }

  void run(std::uint64_t steps) override {
    while (steps > 0) {
      domain_->before_steps();
      const std::uint64_t n = domain_->steps_in_one_go(steps);
      solver_.engine->advance(n);
      steps -= n;
      solver_.host_current = false;
      domain_->after_steps();
      if (on_run_) on_run_(n, total_);
    }
  }
  void set_dt(double dt) override {
    if (!(dt > 0) || !std::isfinite(dt)) throw ConfigError("dt must be a positive number");
    dt_ = dt;
    solver_.engine->set_dt(static_cast<Real>(dt));
  }
  double dt() const override { return dt_; }
  std::uint64_t step() const override { return solver_.engine->step(); }
  size_t size() const override { return total_; }

  ParticleSet particles() override {
    struct Rec {
      double x[3], v[3];
      std::int32_t type, origin;
      std::int64_t id;
    };
    const HostState<Real>& s = solver_.host;
    std::vector<Rec> mine;
    solver_.for_owned([&](int i) {
      mine.push_back({{double(s.x[i]), double(s.y[i]), double(s.z[i])},
                      {double(s.vx[i]), double(s.vy[i]), double(s.vz[i])},
                      s.type[i],
                      s.origin[i],
                      s.id[i]});
    });
    ParticleSet p;
    for (auto* a : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz}) a->resize(total_);
    p.type.resize(total_);
    p.id.resize(total_);
    for (const Rec& r : all_ranks(std::move(mine))) {
      const size_t k = domain_->original_index(r.origin, r.id);
      p.x[k] = r.x[0], p.y[k] = r.x[1], p.z[k] = r.x[2];
      p.vx[k] = r.v[0], p.vy[k] = r.v[1], p.vz[k] = r.v[2];
      p.type[k] = r.type;
      p.id[k] = r.id;
    }
    return p;
  }
  std::vector<double> densities() override { return gather_field(solver_.host.rho); }
  std::vector<double> boundary_volume_fractions() override {
    if (!model_.wall_model.enabled) return {};
    return gather_field(solver_.host.bvf);
  }
  std::array<std::vector<double>, 3> forces() override {
    const HostState<Real>& s = solver_.host;
    return {gather_field(s.fx), gather_field(s.fy), gather_field(s.fz)};
  }
  std::uint64_t wall_corrections() const override {
    std::uint64_t c = solver_.engine->wall_corrections();
    comm().sum(&c, 1);
    return c;
  }
  std::vector<RigidSlabState> rigid_slabs() override;
  double kinetic_temperature() override {
    const std::vector<double> s = mobile_bin();
    const double count = s[kBinCount];
    return count > 0 ? (s[kBinVxx] + s[kBinVyy] + s[kBinVzz]) / (3.0 * count) : 0.0;
  }
  std::array<double, 3> momentum() override {
    const std::vector<double> s = mobile_bin();
    return {s[kBinVx], s[kBinVy], s[kBinVz]};
  }
  SolidIntrusion solid_intrusion() override;
  StressSample stress() override { return stress_of(VirialRegion<Real>{}, box_.volume()); }
  StressSample region_stress(const RegionSelection& r) override {
    double volume = 1;
    const VirialRegion<Real> region = virial_region_of<Real>(r, &volume);
    return stress_of(region, volume);
  }
  std::vector<InjectionCounts> injections() override {
    std::vector<InjectionCounts> c = solver_.engine->injection_counts();
    std::vector<std::uint64_t> injected(c.size());
    for (size_t k = 0; k < c.size(); ++k) injected[k] = c[k].injected;
    if (!injected.empty()) comm().sum(injected.data(), static_cast<int>(injected.size()));
    // Every rank sees the same events; a missed one is missed on all of them.
    for (size_t k = 0; k < c.size(); ++k) c[k].injected = injected[k];
    return c;
  }
  std::vector<double> bin_sums(const BinGrid& grid) override {
    check_bin_grid(grid);
    std::vector<double> sums;
    solver_.engine->bin_sums(grid, sums);
    comm().sum(sums.data(), static_cast<int>(sums.size()));
    return sums;
  }

  const Model& model() const override { return model_; }
  const BoxSpec& box() const override { return box_; }
  std::string backend_name() const override { return solver_.engine->name(); }
  std::string pass_name() const override { return pass_name_; }
  std::size_t device_bytes() const override { return solver_.engine->device_bytes(); }
  std::string profile_report() const override { return solver_.engine->profile_report(); }
  std::uint64_t graph_steps() const override { return solver_.engine->graph_steps(); }
  std::uint64_t buried_particles() const override { return solver_.engine->buried_particles(); }
  int rank() const override { return comm().rank(); }
  int ranks() const override { return comm().size(); }
  std::vector<double> rank_costs() override { return domain_->rank_costs(); }
  std::string decomposition_report() const override { return domain_->report(); }
  // One rank saves its cell-sorted storage (a resume continues bit for bit); a decomposition
  // gathers the original order (no single storage order exists).
  SimulationState state() override {
    if (domain_->decomposed()) return gathered_state();
    SimulationState out = save_state(solver_.synced());
    out.dt = dt_;
    out.wall_corrections = solver_.engine->wall_corrections();
    return out;
  }

 private:
  Communicator& comm() const { return domain_->comm(); }
  // The thermo row's temperature and momentum: one bin over the box (a margin of 1 rc) counting
  // the mobile types (frozen walls and rigid slabs do not move thermally), summed over the ranks.
  std::vector<double> mobile_bin() {
    BinGrid whole;
    for (int a = 0; a < 3; ++a) {
      whole.lo[static_cast<size_t>(a)] = box_.lo[static_cast<size_t>(a)] - 1;
      whole.hi[static_cast<size_t>(a)] = box_.hi[static_cast<size_t>(a)] + 1;
    }
    whole.type_mask = model_.mobile_mask();
    return bin_sums(whole);
  }
  // Every rank's records, on every rank (one rank: its own, not copied).
  template <class Rec>
  std::vector<Rec> all_ranks(std::vector<Rec>&& mine) const {
    if (ranks() == 1) return std::move(mine);
    return comm().allgather_records(mine);
  }
  // A per-particle array of every rank's own particles, in the caller's original order.
  std::vector<double> gather_field(const std::vector<Real>& values) {
    struct Rec {
      std::int64_t id;
      std::int32_t origin;
      double v;
    };
    const HostState<Real>& s = solver_.host;
    std::vector<Rec> mine;
    solver_.for_owned([&](int i) {
      mine.push_back({s.id[i], s.origin[i], double(values[static_cast<size_t>(i)])});
    });
    std::vector<double> out(total_, 0.0);
    for (const Rec& r : all_ranks(std::move(mine)))
      out[domain_->original_index(r.origin, r.id)] = r.v;
    return out;
  }
  StressSample stress_of(const VirialRegion<Real>& region, double volume);
  SimulationState gathered_state();

  Model model_;
  BoxSpec box_;
  double dt_;
  size_t total_;  // over all ranks; injection moves particles, never adds or removes them
  std::function<void(std::uint64_t, std::size_t)> on_run_;
  std::string pass_name_;
  RankSolver<Real> solver_;  // before domain_, which keeps a reference to it
  std::unique_ptr<Domain<Real>> domain_;
};

template <class Real>
std::vector<RigidSlabState> SimulationImpl<Real>::rigid_slabs() {
  std::vector<double> sums;
  const std::vector<RigidSlabBody> bodies = solver_.engine->slab_bodies(sums);
  if (!sums.empty()) comm().sum(sums.data(), static_cast<int>(sums.size()));
  std::vector<RigidSlabState> out;
  for (size_t k = 0; k < sums.size(); ++k) {
    const RigidSlabBody& b = bodies[k];
    RigidSlabState r;
    r.type = model_.types[static_cast<size_t>(b.type)].name;
    r.axis = b.axis;
    r.velocity = b.velocity;
    r.force = b.force;
    r.applied_force = b.applied_force;
    r.mass = b.mass;
    r.position = b.mass > 0 ? sums[k] / b.mass : 0;
    out.push_back(r);
  }
  return out;
}

template <class Real>
SolidIntrusion SimulationImpl<Real>::solid_intrusion() {
  if (!solver_.host.solid.enabled()) return {};
  const SolidIntrusion r = solver_.engine->solid_intrusion();
  // The counts add up; the deepest particle travels from its rank (depth first, then id).
  std::uint64_t inside = r.inside;
  comm().sum(&inside, 1);
  double deepest[5] = {r.deepest_id >= 0 ? r.max_depth : -1.0, 0, 0, 0, 0};
  double best = deepest[0];
  comm().max(&best, 1);
  std::uint64_t id = r.deepest_id >= 0 && deepest[0] == best
                         ? static_cast<std::uint64_t>(r.deepest_id)
                         : ~std::uint64_t(0);
  comm().min(&id, 1);
  if (id != ~std::uint64_t(0) && static_cast<std::int64_t>(id) == r.deepest_id) {
    for (int a = 0; a < 3; ++a) deepest[1 + a] = r.deepest_position[static_cast<size_t>(a)];
    deepest[4] = 1;
  } else {
    for (double& d : deepest) d = 0;
  }
  comm().sum(deepest + 1, 4);
  SolidIntrusion out;
  out.available = true;
  out.inside = inside;
  if (id != ~std::uint64_t(0)) {
    out.max_depth = best;
    out.deepest_id = static_cast<std::int64_t>(id);
    for (int a = 0; a < 3; ++a) out.deepest_position[static_cast<size_t>(a)] = deepest[1 + a];
  }
  return out;
}

template <class Real>
StressSample SimulationImpl<Real>::stress_of(const VirialRegion<Real>& region, double volume) {
  double sums[24] = {};
  const VirialSums w = solver_.engine->virial(region);  // ghosts are never in a region
  for (int c = 0; c < 6; ++c) {
    sums[c] = w.kinetic[c];
    sums[6 + c] = w.conservative[c];
    sums[12 + c] = w.dissipative[c];
    sums[18 + c] = w.random[c];
  }
  comm().sum(sums, 24);
  const double inv_v = 1.0 / volume;
  auto per_volume = [inv_v](double x) { return x * inv_v; };
  StressSample out;
  out.volume = volume;
  for (int c = 0; c < 6; ++c) {
    out.kinetic[c] = per_volume(sums[c]);
    out.conservative[c] = per_volume(sums[6 + c]);
    out.dissipative[c] = per_volume(sums[12 + c]);
    out.random[c] = per_volume(sums[18 + c]);
  }
  return out;
}

// Every rank's own particles gathered in the original order (origin = 0, 1, ...), on every rank:
// a checkpoint of it resumes on any number of ranks, one included. It continues the same
// physics, not bit for bit: storage order (so the order of force sums) and the regions of the
// re-balances are not kept.
template <class Real>
SimulationState SimulationImpl<Real>::gathered_state() {
  // One record per owned particle; arrays the model does not use (v~ without a thermostat, phi
  // without the wall model) travel as zeros and are left out of the state.
  struct Rec {
    double v[14];  // x y z, v, v~, f, rho, phi
    std::int64_t id;
    std::int32_t type, origin;
  };
  const HostState<Real>& s = solver_.synced();
  const std::vector<Real>* in[14] = {&s.x,   &s.y,   &s.z,  &s.vx, &s.vy, &s.vz,  &s.vex,
                                     &s.vey, &s.vez, &s.fx, &s.fy, &s.fz, &s.rho, &s.bvf};
  std::vector<Rec> mine;
  solver_.for_owned([&](int i) {
    Rec r{};
    for (int a = 0; a < 14; ++a)
      if (!in[a]->empty()) r.v[a] = double((*in[a])[static_cast<size_t>(i)]);
    r.id = s.id[i];
    r.type = s.type[i];
    r.origin = s.origin[i];
    mine.push_back(r);
  });
  SimulationState out;
  out.precision = std::is_same_v<Real, float> ? Precision::Single : Precision::Double;
  out.step = solver_.engine->step();
  out.dt = dt_;
  std::vector<double>* to[14] = {&out.x,   &out.y,   &out.z,  &out.vx, &out.vy, &out.vz,  &out.vex,
                                 &out.vey, &out.vez, &out.fx, &out.fy, &out.fz, &out.rho, &out.bvf};
  const bool ve = model_.thermostat, walls = model_.wall_model.enabled;
  for (int a = 0; a < 14; ++a) {
    const bool present = a == 13 ? walls : (a >= 6 && a <= 8 ? ve : true);
    if (present) to[a]->assign(total_, 0.0);
  }
  out.type.assign(total_, 0);
  out.id.assign(total_, 0);
  for (const Rec& r : all_ranks(std::move(mine))) {
    const size_t k = domain_->original_index(r.origin, r.id);
    for (int a = 0; a < 14; ++a)
      if (!to[a]->empty()) (*to[a])[k] = r.v[a];
    out.type[k] = r.type;
    out.id[k] = r.id;
  }
  out.origin.resize(total_);
  for (size_t k = 0; k < total_; ++k) out.origin[k] = static_cast<std::int32_t>(k);
  out.slabs = s.slab_bodies;  // the same on every rank (their forces are summed)
  out.wall_corrections = wall_corrections();
  return out;
}

// Whether the options cut the box into regions: several ranks, or one when forced (rockflow
// bench --decompose measures the decomposition's own cost that way).
bool decomposes(const SimulationOptions& options) {
  return options.comm && (options.comm->size() > 1 || options.decomposition.force);
}

void require_backend(const SimulationOptions& options) {
  if (options.backend == BackendKind::CUDA) {
    const std::string why = cuda_unavailable_reason();
    if (!why.empty()) throw DeviceError(why);
  }
}

template <class Real>
std::unique_ptr<Simulation> make_in_precision(const Model& model, const BoxSpec& box,
                                              const ParticleSet& p, double dt,
                                              const SimulationOptions& options,
                                              const SimulationState* resume) {
  return std::make_unique<SimulationImpl<Real>>(model, box, p, dt, options, decomposes(options),
                                                resume);
}

std::unique_ptr<Simulation> make_for_model(const Model& model, const BoxSpec& box,
                                           const ParticleSet& p, double dt,
                                           const SimulationOptions& options,
                                           const SimulationState* resume) {
  if (model.precision == Precision::Single)
    return make_in_precision<float>(model, box, p, dt, options, resume);
  return make_in_precision<double>(model, box, p, dt, options, resume);
}

}  // namespace

std::unique_ptr<Simulation> make_simulation(const Model& model, const BoxSpec& box,
                                            const ParticleSet& particles, double dt,
                                            const SimulationOptions& options) {
  validate_inputs(model, box, particles, dt);
  if (options.interrupt_check) options.interrupt_check();
  if (!decomposes(options)) require_backend(options);
  return make_for_model(model, box, particles, dt, options, nullptr);
}

std::unique_ptr<Simulation> resume_simulation(const Model& model, const BoxSpec& box,
                                              const SimulationState& state,
                                              const SimulationOptions& options) {
  state.check();
  state.check_fits(model);  // on the whole state: every rank of a decomposed resume agrees
  validate_inputs(model, box, state.particles(), state.dt, state.step);
  if (options.interrupt_check) options.interrupt_check();
  if (decomposes(options)) {
    const SimulationState ordered = state.in_original_order();
    return make_for_model(model, box, ordered.particles(), state.dt, options, &ordered);
  }
  require_backend(options);
  return make_for_model(model, box, state.particles(), state.dt, options, &state);
}

#if !defined(MESOROCK_HAVE_CUDA)
std::string cuda_unavailable_reason() {
  return "backend cuda: this build has no CUDA backend (nvcc was not found when it was "
         "configured); use --backend cpu";
}
#endif

}  // namespace mesorock::sim
