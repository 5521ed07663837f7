// A domain decomposition (sim/domain/domain.h): each rank owns the particles in its region and
// runs the ordinary engine over them plus a layer of ghosts, with the exchanges of
// sim/domain/exchange.h between the phases of every step (the engine calls this class's
// StepHooks), and re-balances by RCB on the measured cost. The Simulation (sim/simulation.cpp)
// reduces its observables over the ranks; gathered particles find their original order by id.
#include "sim/domain/domain.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "mesorock/errors.h"
#include "sim/checkpoint.h"
#include "sim/domain/communicator.h"
#include "sim/domain/decomposition.h"
#include "sim/engine_factory.h"
#include "sim/state_snapshot.h"

namespace mesorock::sim {

namespace {

// Relative cost of a particle per neighbour: the density pass for every particle, the force pass
// (about 3.5 times the density pass on both backends, docs/benchmarks.md) for mobile ones.
constexpr double kFrozenCost = 1.0, kMobileCost = 4.5;

template <class Real>
class DecomposedDomain final : public Domain<Real>, public StepHooks<Real> {
 public:
  DecomposedDomain(RankSolver<Real>& solver, const SimulationOptions& opt)
      : solver_(solver), comm_(opt.comm), opt_(opt) {
    if (!comm_) throw ConfigError("a decomposed run needs a communicator");
  }

  bool decomposed() const override { return true; }
  Communicator& comm() const override { return *comm_; }
  StepHooks<Real>* hooks() override { return this; }

  void init_state(const Model& model, const BoxSpec& box, const ParticleSet& p, double dt,
                  const SimulationOptions& opt, const SimulationState* resume) override {
    box_ = box;
    const DecompositionOptions& d = opt.decomposition;
    if (!(d.halo >= 1.0)) throw ConfigError("decomposition halo must be at least rc = 1");
    if ((d.axes & 7u) == 0) throw ConfigError("decomposition: no axis allowed for cuts");
    for (size_t i = 0; i < p.size(); ++i)
      if (!id_index_.emplace(p.id[i], static_cast<std::int32_t>(i)).second)
        throw ConfigError("a decomposed run needs unique particle ids (id " +
                          std::to_string(p.id[i]) + " repeats)");
    frozen_mask_ = model.frozen_mask();
    std::vector<size_t> rows;
    const ParticleSet mine = first_share(p, rows);
    HostState<Real>& s = solver_.host;
    init_host_state(s, model, box, mine, dt, opt);
    for (RigidSlabBody& b : s.slab_bodies)
      b.mass = static_cast<double>(std::count(p.type.begin(), p.type.end(), b.type));
    if (resume) {
      // This rank's rows, with their velocities, v~, forces, densities and phi of the saved step.
      // No ghosts yet: the first step's exchange brings them, before its force pass.
      load_state(s, resume->select(rows));
    }
    s.has_ghosts = true;
    set_local_geometry();
  }

  // The first cut weighed particles by type; the initial force pass has counted neighbours, so
  // RCB cuts again on the measured cost before the first step (a flooding run on 4 ranks peaked
  // at 1.11 in its first 1,000 steps on the type-weighted cut, 1.00-1.05 after). A resumed run
  // counts without ghosts (particles near a cut see fewer neighbours) until its next re-balance.
  void started() override {
    if (opt_.decomposition.method == DecompositionMethod::RCB) rebalance();
  }

  // A re-balance at the end of the last steps chose new regions; the engine takes them here,
  // just before the step whose exchange moves the particles, so observables read in between
  // (stress, bins, regions) see storage and cell list of one geometry (seen: a segfault in the
  // virial when the new cell grid met the old storage).
  void before_steps() override {
    if (geometry_pending_) {
      set_local_geometry();
      geometry_pending_ = false;
    }
  }
  std::uint64_t steps_in_one_go(std::uint64_t steps) override {
    const std::uint64_t every = opt_.decomposition.rebalance_every;
    if (rcb() && every > 0) return std::min(steps, every - solver_.engine->step() % every);
    return steps;
  }
  void after_steps() override {
    const std::uint64_t every = opt_.decomposition.rebalance_every;
    if (rcb() && every > 0 && solver_.engine->step() % every == 0) rebalance();
  }

  std::size_t original_index(std::int32_t, std::int64_t id) const override {
    const auto it = id_index_.find(id);
    if (it == id_index_.end())
      throw NumericalError("particle id " + std::to_string(id) + " appeared from nowhere");
    return static_cast<size_t>(it->second);
  }

  // ---- StepHooks: called by the engine inside every step, on every rank. ----
  bool distributed() const override { return true; }

  void exchange(DomainStore<Real>& store) override {
    const int P = comm_->size();
    std::vector<MigrantRecord<Real>> leavers;
    store.drop_ghosts_take_leavers(region_, leavers);
    std::vector<std::vector<MigrantRecord<Real>>> to(static_cast<size_t>(P));
    for (const MigrantRecord<Real>& m : leavers) {
      const int q = owner_of(m.x);
      if (q < 0) {
        std::ostringstream s;
        s << "step " << solver_.engine->step() << ": particle " << m.id << " at (" << m.x[0] << ", "
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

  // Each rank's cost under the current regions: each particle's measured cost added to the rank
  // whose region holds it (after a re-balance the storage still follows the old regions until
  // the next step's exchange).
  std::vector<double> rank_costs() override {
    const std::vector<double> cost = particle_costs();
    std::vector<double> per_rank(static_cast<size_t>(comm_->size()), 0.0);
    // Under the regions the next step will use (new ones right after a re-balance).
    const std::vector<LocalRegion<Real>> owners = geometry_pending_ ? owner_regions() : owners_;
    size_t k = 0;
    solver_.for_owned([&](int i) {
      const HostState<Real>& s = solver_.host;
      Real x[3] = {s.x[i], s.y[i], s.z[i]};
      region_.wrap(x);
      const int q = owner_in(owners, x);
      per_rank[static_cast<size_t>(q < 0 ? comm_->rank() : q)] += cost[k++];
    });
    comm_->sum(per_rank.data(), static_cast<int>(per_rank.size()));
    return per_rank;
  }
  std::string report() const override {
    return std::string(to_string(opt_.decomposition.method)) + " over " +
           std::to_string(comm_->size()) + " ranks: " + decomp_.describe();
  }

 private:
  bool rcb() const { return opt_.decomposition.method == DecompositionMethod::RCB; }

  // The first decomposition weighs the particles by their type alone (no neighbour counts exist
  // yet): every rank holds the whole initial set, so each computes the same one. Returns this
  // rank's particles and their rows of p.
  ParticleSet first_share(const ParticleSet& p, std::vector<size_t>& rows) {
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
    const Region& own = decomp_.region(comm_->rank());
    for (size_t i = 0; i < p.size(); ++i) {
      const double c[3] = {pos[0][i], pos[1][i], pos[2][i]};
      if (!own.contains(c)) continue;
      mine.add(p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i], p.type[i], p.id[i]);
      rows.push_back(i);
    }
    return mine;
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
    solver_.engine->neighbour_counts(counts);
    const HostState<Real>& state = solver_.synced();
    std::vector<double> cost;
    solver_.for_owned([&](int i) {
      const double per = ((frozen_mask_ >> state.type[i]) & 1u) ? kFrozenCost : kMobileCost;
      cost.push_back(per * std::max(1, counts[static_cast<size_t>(i)]));
    });
    return cost;
  }

  // RCB on the measured cost: the histograms of every cut are summed over the ranks.
  void rebalance() {
    const std::vector<double> cost = particle_costs();
    std::vector<double> pos[3];
    solver_.for_owned([&](int i) {
      pos[0].push_back(solver_.host.x[i]);
      pos[1].push_back(solver_.host.y[i]);
      pos[2].push_back(solver_.host.z[i]);
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
    Box<Real>& b = solver_.host.box;
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
    solver_.host.grid = CellGrid<Real>::make(b, Real(1), opt_.cells_per_cutoff);
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

  RankSolver<Real>& solver_;
  std::shared_ptr<Communicator> comm_;
  SimulationOptions opt_;
  BoxSpec box_;
  Decomposition decomp_;
  bool geometry_pending_ = false;  // new regions chosen; the engine takes them before the next step
  std::unordered_map<std::int64_t, std::int32_t> id_index_;
  std::uint32_t frozen_mask_ = 0;  // for the load-balance cost
  LocalRegion<Real> region_;
  std::vector<LocalRegion<Real>> owners_;
  std::vector<HaloBox<Real>> halo_boxes_;
  std::vector<int> halo_rank_, send_counts_, recv_counts_;
};

}  // namespace

template <class Real>
std::unique_ptr<Domain<Real>> make_decomposed_domain(RankSolver<Real>& solver,
                                                     const SimulationOptions& options) {
  return std::make_unique<DecomposedDomain<Real>>(solver, options);
}
template std::unique_ptr<Domain<float>> make_decomposed_domain<float>(RankSolver<float>&,
                                                                      const SimulationOptions&);
template std::unique_ptr<Domain<double>> make_decomposed_domain<double>(RankSolver<double>&,
                                                                        const SimulationOptions&);

}  // namespace mesorock::sim
