// A decomposed Simulation: each rank owns the particles in its region and runs the ordinary engine
// over them plus a layer of ghosts, with the exchanges of sim/domain/exchange.h between the phases
// of every step (the engine calls this class's StepHooks). Observables are sums over each rank's
// own particles, reduced over the ranks; particle outputs are gathered and returned in the
// caller's original order (by id).
#include "sim/domain/distributed.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "mesorock/errors.h"
#include "sim/checkpoint.h"
#include "sim/domain/communicator.h"
#include "sim/domain/decomposition.h"
#include "sim/engine_factory.h"
#include "sim/host_reductions.h"
#include "sim/state_snapshot.h"
#include "sim/terms.h"

namespace mesorock::sim {

namespace {

// Relative cost of a particle per neighbour: the density pass for every particle, the force pass
// (about 3.5 times the density pass on both backends, docs/benchmarks.md) for mobile ones.
constexpr double kFrozenCost = 1.0, kMobileCost = 4.5;

template <class Real>
class DistributedSimulation final : public Simulation, public StepHooks<Real> {
 public:
  // resume: a saved state in the original order (SimulationState::in_original_order) whose
  // particles are `p`; each rank takes its own particles' rows of it (else the run starts from p).
  DistributedSimulation(const Model& model, const BoxSpec& box, const ParticleSet& p, double dt,
                        const SimulationOptions& opt, const SimulationState* resume = nullptr)
      : model_(model), box_(box), dt_(dt), comm_(opt.comm), opt_(opt) {
    const DecompositionOptions& d = opt.decomposition;
    if (!(d.halo >= 1.0)) throw ConfigError("decomposition halo must be at least rc = 1");
    if ((d.axes & 7u) == 0) throw ConfigError("decomposition: no axis allowed for cuts");
    for (size_t i = 0; i < p.size(); ++i)
      if (!id_index_.emplace(p.id[i], static_cast<std::int32_t>(i)).second)
        throw ConfigError("a decomposed run needs unique particle ids (id " +
                          std::to_string(p.id[i]) + " repeats)");
    total_ = p.size();
    frozen_mask_ = model.frozen_mask();

    // The first decomposition weighs the particles by their type alone (no neighbour counts
    // exist yet): every rank holds the whole initial set, so each computes the same one.
    std::vector<double> pos[3];
    for (int a = 0; a < 3; ++a) pos[a].resize(p.size());
    std::vector<double> weight(p.size());
    for (size_t i = 0; i < p.size(); ++i) {
      const double c[3] = {p.x[i], p.y[i], p.z[i]};
      for (int a = 0; a < 3; ++a) pos[a][i] = inside_box(c[a], a);
      weight[i] = ((frozen_mask_ >> p.type[i]) & 1u) ? kFrozenCost : kMobileCost;
    }
    decompose([&](const Region& g, int axis, int bins) {
      return histogram(pos, weight, g, axis, bins);  // local data is global here: no reduction
    });
    ParticleSet mine;
    std::vector<size_t> rows;
    const Region& own = decomp_.region(comm_->rank());
    for (size_t i = 0; i < p.size(); ++i) {
      const double c[3] = {pos[0][i], pos[1][i], pos[2][i]};
      if (!own.contains(c)) continue;
      mine.add(p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i], p.type[i], p.id[i]);
      rows.push_back(i);
    }
    init_host_state(state_, model, box, mine, dt, opt);
    for (RigidSlabBody& b : state_.slab_bodies)
      b.mass = static_cast<double>(std::count(p.type.begin(), p.type.end(), b.type));
    if (resume) {
      // This rank's rows, with their velocities, v~, forces, densities and phi of the saved step.
      load_state(state_, resume->select(rows));
    }
    state_.has_ghosts = true;
    set_local_geometry();
    dispatch_terms(model, [&](auto terms) { pass_name_ = term_set_name<decltype(terms)>(); });
    engine_ = make_engine<Real>(model, opt);
    if (resume) {
      // No ghosts yet: the first step's exchange brings them, before its force pass. The run's
      // wall-correction count goes to rank 0 alone (wall_corrections() sums over the ranks).
      engine_->restore(state_, comm_->rank() == 0 ? resume->wall_corrections : 0, this);
    } else {
      engine_->initialize(state_, this);
    }
    engine_->set_watchdog(opt.watchdog);
    host_current_ = false;
    // The first cut weighed particles by type; the initial force pass has counted neighbours, so
    // RCB cuts again on the measured cost before the first step (a flooding run on 4 ranks
    // peaked at 1.11 in its first 1,000 steps on the type-weighted cut, 1.00-1.05 after). A
    // resumed run counts without ghosts (particles near a cut see fewer neighbours) until its
    // next re-balance.
    if (opt.decomposition.method == DecompositionMethod::RCB) rebalance();
  }

  // ---- StepHooks: called by the engine inside every step, on every rank. ----
  void exchange(DomainStore<Real>& store) override {
    const int P = comm_->size();
    std::vector<MigrantRecord<Real>> leavers;
    store.drop_ghosts_take_leavers(region_, leavers);
    std::vector<std::vector<MigrantRecord<Real>>> to(static_cast<size_t>(P));
    for (const MigrantRecord<Real>& m : leavers) {
      const int q = owner_of(m.x);
      if (q < 0) {
        std::ostringstream s;
        s << "step " << engine_->step() << ": particle " << m.id << " at (" << m.x[0] << ", "
          << m.x[1] << ", " << m.x[2] << ") left the box (no rank owns it)";
        throw NumericalError(s.str());
      }
      to[static_cast<size_t>(q)].push_back(m);
    }
    std::vector<MigrantRecord<Real>> arrivals;
    std::vector<int> counts;
    comm_->alltoallv_records(to, arrivals, counts);
    store.add_owned(arrivals);

    std::vector<GhostRecord<Real>> packed;
    std::vector<int> per_box;
    store.pack_ghosts(halo_boxes_, packed, per_box);
    std::vector<std::vector<GhostRecord<Real>>> ghosts(static_cast<size_t>(P));
    size_t k = 0;
    for (size_t b = 0; b < halo_boxes_.size(); ++b) {
      auto& dest = ghosts[static_cast<size_t>(halo_rank_[b])];
      dest.insert(dest.end(), packed.begin() + static_cast<std::ptrdiff_t>(k),
                  packed.begin() + static_cast<std::ptrdiff_t>(k + per_box[b]));
      k += static_cast<size_t>(per_box[b]);
    }
    send_counts_.assign(static_cast<size_t>(P), 0);
    for (int q = 0; q < P; ++q)
      send_counts_[static_cast<size_t>(q)] =
          static_cast<int>(ghosts[static_cast<size_t>(q)].size());
    std::vector<GhostRecord<Real>> received;
    comm_->alltoallv_records(ghosts, received, recv_counts_);
    store.add_ghosts(received);
  }

  void sync_sums(DomainStore<Real>& store) override {
    std::vector<Real> out, in;
    store.pack_sums(out);
    std::vector<int> counts;
    comm_->alltoallv_records(split(out, store.sums_per_particle()), in, counts);
    store.set_ghost_sums(in);
  }

  void refresh_ghosts(DomainStore<Real>& store) override {
    std::vector<GhostRecord<Real>> out, in;
    store.pack_refresh(out);
    std::vector<int> counts;
    comm_->alltoallv_records(split(out, 1), in, counts);
    store.set_ghost_refresh(in);
  }

  bool any(bool local) override {
    double v = local ? 1 : 0;
    comm_->max(&v, 1);
    return v > 0;
  }
  void sum(double* values, int count) override { comm_->sum(values, count); }
  std::uint64_t min(std::uint64_t value) override {
    comm_->min(&value, 1);
    return value;
  }

  // ---- Simulation ----
  void run(std::uint64_t steps) override {
    const std::uint64_t every = opt_.decomposition.rebalance_every;
    const bool rcb = opt_.decomposition.method == DecompositionMethod::RCB;
    while (steps > 0) {
      // A re-balance at the end of the last chunk chose new regions; the engine takes them here,
      // just before the step whose exchange moves the particles, so observables read in between
      // (stress, bins, regions) see storage and cell list of one geometry (seen: a segfault in
      // the virial when the new cell grid met the old storage).
      if (geometry_pending_) {
        set_local_geometry();
        geometry_pending_ = false;
      }
      std::uint64_t n = steps;
      if (rcb && every > 0) n = std::min(n, every - engine_->step() % every);
      engine_->advance(n);
      steps -= n;
      host_current_ = false;
      if (rcb && every > 0 && engine_->step() % every == 0) rebalance();
      if (opt_.on_run) opt_.on_run(n, total_);
    }
  }
  void set_dt(double dt) override {
    if (!(dt > 0) || !std::isfinite(dt)) throw ConfigError("dt must be a positive number");
    dt_ = dt;
    engine_->set_dt(static_cast<Real>(dt));
  }
  double dt() const override { return dt_; }
  std::uint64_t step() const override { return engine_->step(); }
  size_t size() const override { return total_; }

  ParticleSet particles() override {
    struct Rec {
      double x[3], v[3];
      std::int32_t type;
      std::int64_t id;
    };
    std::vector<Rec> mine;
    for_owned([&](int i) {
      mine.push_back({{double(state_.x[i]), double(state_.y[i]), double(state_.z[i])},
                      {double(state_.vx[i]), double(state_.vy[i]), double(state_.vz[i])},
                      state_.type[i],
                      state_.id[i]});
    });
    const std::vector<Rec> all = comm_->allgather_records(mine);
    ParticleSet p;
    for (auto* a : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz}) a->resize(total_);
    p.type.resize(total_);
    p.id.resize(total_);
    for (const Rec& r : all) {
      const size_t k = index_of(r.id);
      p.x[k] = r.x[0], p.y[k] = r.x[1], p.z[k] = r.x[2];
      p.vx[k] = r.v[0], p.vy[k] = r.v[1], p.vz[k] = r.v[2];
      p.type[k] = r.type;
      p.id[k] = r.id;
    }
    return p;
  }
  std::vector<double> densities() override {
    return gather_field([&](int i) { return double(state_.rho[i]); });
  }
  std::vector<double> boundary_volume_fractions() override {
    if (!model_.wall_model.enabled) return {};
    return gather_field([&](int i) { return double(state_.bvf[i]); });
  }
  std::array<std::vector<double>, 3> forces() override {
    return {gather_field([&](int i) { return double(state_.fx[i]); }),
            gather_field([&](int i) { return double(state_.fy[i]); }),
            gather_field([&](int i) { return double(state_.fz[i]); })};
  }
  std::uint64_t wall_corrections() const override {
    std::uint64_t c = engine_->wall_corrections();
    comm_->sum(&c, 1);
    return c;
  }
  std::vector<RigidSlabState> rigid_slabs() override {
    sync();
    std::vector<RigidSlabState> out;
    std::vector<double> sums(state_.slab_bodies.size(), 0.0);
    for (size_t k = 0; k < sums.size(); ++k) {
      const RigidSlabBody& b = state_.slab_bodies[k];
      const std::vector<Real>& pos = b.axis == 0 ? state_.x : (b.axis == 1 ? state_.y : state_.z);
      for_owned([&](int i) {
        if (state_.type[i] == b.type) sums[k] += pos[i];
      });
    }
    if (!sums.empty()) comm_->sum(sums.data(), static_cast<int>(sums.size()));
    for (size_t k = 0; k < sums.size(); ++k) {
      const RigidSlabBody& b = state_.slab_bodies[k];
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
  double kinetic_temperature() override {
    sync();
    const MobileSums m = mobile_sums(state_, [&](int i) { return state_.origin[i] >= 0; });
    double s[2] = {m.v2, m.count};
    comm_->sum(s, 2);
    return s[1] > 0 ? s[0] / (3.0 * s[1]) : 0.0;
  }
  std::array<double, 3> momentum() override {
    sync();
    std::array<double, 3> p = mobile_sums(state_, [&](int i) { return state_.origin[i] >= 0; }).p;
    comm_->sum(p.data(), 3);
    return p;
  }
  SolidIntrusion solid_intrusion() override {
    if (!state_.solid.enabled()) return {};
    sync();
    SolidIntrusion r = solid_intrusion_of(state_, [&](int i) { return state_.origin[i] >= 0; });
    // The counts add up; the deepest particle travels from its rank (depth first, then id).
    std::uint64_t inside = r.inside;
    comm_->sum(&inside, 1);
    double deepest[5] = {r.deepest_id >= 0 ? r.max_depth : -1.0, 0, 0, 0, 0};
    double best = deepest[0];
    comm_->max(&best, 1);
    std::uint64_t id = r.deepest_id >= 0 && deepest[0] == best
                           ? static_cast<std::uint64_t>(r.deepest_id)
                           : ~std::uint64_t(0);
    comm_->min(&id, 1);
    if (id != ~std::uint64_t(0) && static_cast<std::int64_t>(id) == r.deepest_id) {
      for (int a = 0; a < 3; ++a) deepest[1 + a] = r.deepest_position[static_cast<size_t>(a)];
      deepest[4] = 1;
    } else {
      for (double& d : deepest) d = 0;
    }
    comm_->sum(deepest + 1, 4);
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
  StressSample stress() override { return stress_of(VirialRegion<Real>{}, box_.volume()); }
  StressSample region_stress(const RegionSelection& r) override {
    double volume = 1;
    const VirialRegion<Real> region = virial_region_of<Real>(r, &volume);
    return stress_of(region, volume);
  }
  std::vector<InjectionCounts> injections() override {
    std::vector<InjectionCounts> c = engine_->injection_counts();
    std::vector<std::uint64_t> injected(c.size());
    for (size_t k = 0; k < c.size(); ++k) injected[k] = c[k].injected;
    if (!injected.empty()) comm_->sum(injected.data(), static_cast<int>(injected.size()));
    // Every rank sees the same events; a missed one is missed on all of them.
    for (size_t k = 0; k < c.size(); ++k) c[k].injected = injected[k];
    return c;
  }
  std::vector<double> bin_sums(const BinGrid& grid) override {
    check_bin_grid(grid);
    std::vector<double> sums;
    engine_->bin_sums(grid, sums);
    comm_->sum(sums.data(), static_cast<int>(sums.size()));
    return sums;
  }
  const Model& model() const override { return model_; }
  const BoxSpec& box() const override { return box_; }
  std::string backend_name() const override { return engine_->name(); }
  std::string pass_name() const override { return pass_name_; }
  std::size_t device_bytes() const override { return engine_->device_bytes(); }
  std::string profile_report() const override { return engine_->profile_report(); }
  int rank() const override { return comm_->rank(); }
  int ranks() const override { return comm_->size(); }
  // Each rank's cost under the current regions: each particle's measured cost added to the rank
  // whose region holds it (after a re-balance the storage still follows the old regions until
  // the next step's exchange).
  std::vector<double> rank_costs() override {
    const std::vector<double> cost = particle_costs();
    std::vector<double> per_rank(static_cast<size_t>(comm_->size()), 0.0);
    // Under the regions the next step will use (new ones right after a re-balance).
    const std::vector<LocalRegion<Real>> owners = geometry_pending_ ? owner_regions() : owners_;
    size_t k = 0;
    for_owned([&](int i) {
      Real x[3] = {state_.x[i], state_.y[i], state_.z[i]};
      region_.wrap(x);
      const int q = owner_in(owners, x);
      per_rank[static_cast<size_t>(q < 0 ? comm_->rank() : q)] += cost[k++];
    });
    comm_->sum(per_rank.data(), static_cast<int>(per_rank.size()));
    return per_rank;
  }
  // Every rank's own particles gathered in the original order (origin = 0, 1, ...), on every
  // rank: a checkpoint of it resumes on any number of ranks, one included. It continues the same
  // physics, not bit for bit: storage order (so the order of force sums) and the regions of the
  // re-balances are not kept.
  SimulationState state() override {
    // One record per owned particle; arrays the model does not use (v~ without a thermostat,
    // phi without the wall model) travel as zeros and are left out of the state.
    struct Rec {
      double v[14];  // x y z, v, v~, f, rho, phi
      std::int64_t id;
      std::int32_t type;
    };
    const std::vector<Real>* in[14] = {
        &state_.x,   &state_.y,   &state_.z,  &state_.vx, &state_.vy, &state_.vz,  &state_.vex,
        &state_.vey, &state_.vez, &state_.fx, &state_.fy, &state_.fz, &state_.rho, &state_.bvf};
    std::vector<Rec> mine;
    for_owned([&](int i) {
      Rec r{};
      for (int a = 0; a < 14; ++a)
        if (!in[a]->empty()) r.v[a] = double((*in[a])[static_cast<size_t>(i)]);
      r.id = state_.id[i];
      r.type = state_.type[i];
      mine.push_back(r);
    });
    SimulationState out;
    out.precision = std::is_same_v<Real, float> ? Precision::Single : Precision::Double;
    out.step = engine_->step();
    out.dt = dt_;
    std::vector<double>* to[14] = {&out.x,  &out.y,   &out.z,   &out.vx,  &out.vy,
                                   &out.vz, &out.vex, &out.vey, &out.vez, &out.fx,
                                   &out.fy, &out.fz,  &out.rho, &out.bvf};
    const bool ve = model_.thermostat, walls = model_.wall_model.enabled;
    for (int a = 0; a < 14; ++a) {
      const bool present = a == 13 ? walls : (a >= 6 && a <= 8 ? ve : true);
      if (present) to[a]->assign(total_, 0.0);
    }
    out.type.assign(total_, 0);
    out.id.assign(total_, 0);
    for (const Rec& r : comm_->allgather_records(mine)) {
      const size_t k = index_of(r.id);
      for (int a = 0; a < 14; ++a)
        if (!to[a]->empty()) (*to[a])[k] = r.v[a];
      out.type[k] = r.type;
      out.id[k] = r.id;
    }
    out.origin.resize(total_);
    for (size_t k = 0; k < total_; ++k) out.origin[k] = static_cast<std::int32_t>(k);
    out.slabs = state_.slab_bodies;  // the same on every rank (their forces are summed)
    out.wall_corrections = wall_corrections();
    return out;
  }
  std::string decomposition_report() const override {
    return std::string(to_string(opt_.decomposition.method)) + " over " +
           std::to_string(comm_->size()) + " ranks: " + decomp_.describe();
  }

 private:
  void sync() {
    if (!host_current_) {
      engine_->download(state_);
      host_current_ = true;
    }
  }
  template <class F>
  void for_owned(F&& f) {
    sync();
    for (int i = 0; i < state_.size(); ++i)
      if (state_.origin[i] >= 0) f(i);
  }
  size_t index_of(std::int64_t id) const {
    const auto it = id_index_.find(id);
    if (it == id_index_.end())
      throw NumericalError("particle id " + std::to_string(id) + " appeared from nowhere");
    return static_cast<size_t>(it->second);
  }
  template <class F>
  std::vector<double> gather_field(F&& value) {
    struct Rec {
      std::int64_t id;
      double v;
    };
    std::vector<Rec> mine;
    for_owned([&](int i) { mine.push_back({state_.id[i], value(i)}); });
    std::vector<double> out(total_, 0.0);
    for (const Rec& r : comm_->allgather_records(mine)) out[index_of(r.id)] = r.v;
    return out;
  }

  StressSample stress_of(const VirialRegion<Real>& region, double volume) {
    sync();
    StressSample out;
    out.volume = volume;
    double sums[24] = {};
    const std::array<double, 6> kinetic = kinetic_stress_sums(state_, region);  // no ghosts
    const VirialSums w = engine_->virial(region);
    for (int c = 0; c < 6; ++c) {
      sums[c] = kinetic[c];
      sums[6 + c] = w.conservative[c];
      sums[12 + c] = w.dissipative[c];
      sums[18 + c] = w.random[c];
    }
    comm_->sum(sums, 24);
    for (int c = 0; c < 6; ++c) {
      out.kinetic[c] = sums[c] / volume;
      out.conservative[c] = sums[6 + c] / volume;
      out.dissipative[c] = sums[12 + c] / volume;
      out.random[c] = sums[18 + c] / volume;
    }
    return out;
  }

  // A position mapped into the box the way the solver does (the upper face of a periodic axis
  // is its lower face), for ownership.
  double inside_box(double c, int a) const {
    const double lo = box_.lo[static_cast<size_t>(a)], hi = box_.hi[static_cast<size_t>(a)];
    if (c >= hi) return box_.periodic[static_cast<size_t>(a)] ? lo : std::nextafter(hi, lo);
    return c < lo ? lo : c;
  }

  static std::vector<double> histogram(const std::vector<double> pos[3],
                                       const std::vector<double>& weight, const Region& g, int axis,
                                       int bins) {
    std::vector<double> h(static_cast<size_t>(bins), 0.0);
    const double lo = g.lo[static_cast<size_t>(axis)], w = g.width(axis);
    for (size_t i = 0; i < weight.size(); ++i) {
      const double c[3] = {pos[0][i], pos[1][i], pos[2][i]};
      if (!g.contains(c)) continue;
      int b = static_cast<int>((c[axis] - lo) / w * bins);
      b = std::clamp(b, 0, bins - 1);
      h[static_cast<size_t>(b)] += weight[i];
    }
    return h;
  }

  void decompose(const Decomposition::Histogram& weight) {
    const DecompositionOptions& d = opt_.decomposition;
    decomp_ = d.method == DecompositionMethod::Slabs
                  ? Decomposition::slabs(box_, comm_->size(), d.axes)
                  : Decomposition::rcb(box_, comm_->size(), weight, d.axes, 0.5 * d.halo);
  }

  // Each owned particle's cost (storage order of the owned ones): neighbours x type weight,
  // measured over the cell list of the last force pass (a re-balance changes the engine's cell
  // grid only at the start of the next run, so the list always matches its grid here).
  std::vector<double> particle_costs() {
    std::vector<int> counts;
    engine_->neighbour_counts(counts);
    sync();
    std::vector<double> cost;
    for_owned([&](int i) {
      const double per = ((frozen_mask_ >> state_.type[i]) & 1u) ? kFrozenCost : kMobileCost;
      cost.push_back(per * std::max(1, counts[static_cast<size_t>(i)]));
    });
    return cost;
  }

  // RCB on the measured cost: the histograms of every cut are summed over the ranks.
  void rebalance() {
    const std::vector<double> cost = particle_costs();
    std::vector<double> pos[3];
    for_owned([&](int i) {
      pos[0].push_back(state_.x[i]);
      pos[1].push_back(state_.y[i]);
      pos[2].push_back(state_.z[i]);
    });
    decompose([&](const Region& g, int axis, int bins) {
      std::vector<double> h = histogram(pos, cost, g, axis, bins);
      comm_->sum(h.data(), bins);
      return h;
    });
    geometry_pending_ = true;
  }

  // The engine's box (the region widened by the halo on faces inside the global box, which are
  // open), the cell grid over it, the migration test and the ghost sends.
  void set_local_geometry() {
    const Region& g = decomp_.region(comm_->rank());
    const double h = opt_.decomposition.halo;
    Box<Real>& b = state_.box;
    for (int a = 0; a < 3; ++a) {
      const size_t s = static_cast<size_t>(a);
      double lo = box_.lo[s], hi = box_.hi[s];
      b.periodic[a] = box_.periodic[s];
      b.open_lo[a] = b.open_hi[a] = false;
      if (!spans_axis(g, box_, a)) {
        b.periodic[a] = false;
        b.open_lo[a] = box_.periodic[s] || g.lo[s] > box_.lo[s];
        b.open_hi[a] = box_.periodic[s] || g.hi[s] < box_.hi[s];
        lo = b.open_lo[a] ? g.lo[s] - h : box_.lo[s];
        hi = b.open_hi[a] ? g.hi[s] + h : box_.hi[s];
      }
      b.lo[a] = static_cast<Real>(lo);
      b.length[a] = static_cast<Real>(hi - lo);
      region_.lo[a] = static_cast<Real>(g.lo[s]);
      region_.hi[a] = static_cast<Real>(g.hi[s]);
      region_.global_lo[a] = static_cast<Real>(box_.lo[s]);
      region_.global_length[a] = static_cast<Real>(box_.length(a));
      region_.periodic[a] = box_.periodic[s];
    }
    state_.grid = CellGrid<Real>::make(b, Real(1), opt_.cells_per_cutoff);
    owners_ = owner_regions();
    halo_boxes_.clear();
    halo_rank_.clear();
    for (const HaloTarget& t : halo_targets(decomp_, box_, comm_->rank(), h)) {
      HaloBox<Real> hb;
      for (int a = 0; a < 3; ++a) {
        const size_t s = static_cast<size_t>(a);
        hb.lo[a] = static_cast<Real>(t.box.lo[s]);
        hb.hi[a] = static_cast<Real>(t.box.hi[s]);
        hb.shift[a] = static_cast<Real>(t.shift[s]);
      }
      halo_boxes_.push_back(hb);
      halo_rank_.push_back(t.rank);
    }
  }

  // Every rank's region of the decomposition in the run's precision: the owner test matches the
  // migration test.
  std::vector<LocalRegion<Real>> owner_regions() const {
    std::vector<LocalRegion<Real>> out;
    for (const Region& r : decomp_.regions()) {
      LocalRegion<Real> o = region_;
      for (int a = 0; a < 3; ++a) {
        o.lo[a] = static_cast<Real>(r.lo[static_cast<size_t>(a)]);
        o.hi[a] = static_cast<Real>(r.hi[static_cast<size_t>(a)]);
      }
      out.push_back(o);
    }
    return out;
  }

  int owner_of(const Real x[3]) const { return owner_in(owners_, x); }
  static int owner_in(const std::vector<LocalRegion<Real>>& owners, const Real x[3]) {
    for (size_t q = 0; q < owners.size(); ++q)
      if (owners[q].contains(x)) return static_cast<int>(q);
    return -1;
  }

  // The send buffer of a per-particle array (per values each) cut by destination rank, in the
  // order the ghosts were sent.
  template <class T>
  std::vector<std::vector<T>> split(const std::vector<T>& flat, int per) const {
    std::vector<std::vector<T>> out(send_counts_.size());
    size_t k = 0;
    for (size_t q = 0; q < send_counts_.size(); ++q) {
      const size_t n = static_cast<size_t>(send_counts_[q]) * static_cast<size_t>(per);
      out[q].assign(flat.begin() + static_cast<std::ptrdiff_t>(k),
                    flat.begin() + static_cast<std::ptrdiff_t>(k + n));
      k += n;
    }
    return out;
  }

  Model model_;
  BoxSpec box_;
  double dt_;
  std::shared_ptr<Communicator> comm_;
  SimulationOptions opt_;
  Decomposition decomp_;
  HostState<Real> state_;
  std::unique_ptr<Engine<Real>> engine_;
  std::string pass_name_;
  bool host_current_ = false;
  bool geometry_pending_ = false;  // new regions chosen; the engine takes them before the next step
  std::unordered_map<std::int64_t, std::int32_t> id_index_;
  size_t total_ = 0;
  std::uint32_t frozen_mask_ = 0;  // for the load-balance cost
  LocalRegion<Real> region_;
  std::vector<LocalRegion<Real>> owners_;
  std::vector<HaloBox<Real>> halo_boxes_;
  std::vector<int> halo_rank_, send_counts_, recv_counts_;
};

}  // namespace

std::unique_ptr<Simulation> make_distributed_simulation(const Model& model, const BoxSpec& box,
                                                        const ParticleSet& particles, double dt,
                                                        const SimulationOptions& options) {
  if (!options.comm) throw ConfigError("a decomposed run needs a communicator");
  if (model.precision == Precision::Single)
    return std::make_unique<DistributedSimulation<float>>(model, box, particles, dt, options);
  return std::make_unique<DistributedSimulation<double>>(model, box, particles, dt, options);
}

std::unique_ptr<Simulation> resume_distributed_simulation(const Model& model, const BoxSpec& box,
                                                          const SimulationState& state,
                                                          const SimulationOptions& options) {
  if (!options.comm) throw ConfigError("a decomposed run needs a communicator");
  const SimulationState ordered = state.in_original_order();
  const ParticleSet p = ordered.particles();
  if (model.precision == Precision::Single)
    return std::make_unique<DistributedSimulation<float>>(model, box, p, state.dt, options,
                                                          &ordered);
  return std::make_unique<DistributedSimulation<double>>(model, box, p, state.dt, options,
                                                         &ordered);
}

}  // namespace mesorock::sim
