#include "sim/engine_cpu.h"

#include <omp.h>

#include <algorithm>
#include <type_traits>
#include <vector>

#include "sim/half_list.h"
#include "sim/kernels.h"
#include "sim/stepper.h"
#include "sim/terms.h"
#include "sim/watchdog.h"

namespace mesorock::sim {

namespace {

// Counting sort of the particles by cell, applied to the storage itself: afterwards cell c holds
// particles [cell_start[c], cell_start[c+1]) and the neighbour loop reads contiguous memory.
// Stable, so the order within a cell (and hence every floating-point sum) is deterministic.
template <class Real>
class CellSorter {
 public:
  // Sorts the first `count` stored particles by key and leaves the rest where they are: the key
  // is the cell, plus `frozen_offset` for a frozen particle when that is not 0 (the frozen part,
  // StepView::frozen_part). cell_start[0..keys] is rewritten; a full sort (count = all) sizes it
  // to keys + 1, a sort of the mobile part keeps the frozen part's entries behind it.
  // carry_forces: forces, densities and phi move with their particles too (a restored state; a
  // step's sort comes before its force pass, which writes them anew).
  // With `bury`, a buried frozen particle's key is the cell plus twice frozen_offset
  // (StepView::buried_part).
  void sort(HostState<Real>& s, int count, int keys, int frozen_offset, bool carry_forces,
            bool bury = false) {
    const bool all = count == s.size();
    if (all)
      s.cell_start.assign(static_cast<size_t>(keys) + 1, 0);
    else
      std::fill(s.cell_start.begin(), s.cell_start.begin() + keys + 1, 0);
    cell_of_.resize(static_cast<size_t>(count));
    dest_.resize(static_cast<size_t>(count));
    const StepView<Real> v = s.view();
    // The keys in parallel (a full sort that buries searches the voxels about each frozen
    // particle), then counted in order.
#pragma omp parallel for schedule(static)
    for (int i = 0; i < count; ++i) {
      const int part = frozen_offset > 0 && v.frozen(i) ? (bury && buried(v, i) ? 2 : 1) : 0;
      cell_of_[static_cast<size_t>(i)] = cell_of(v, i) + part * frozen_offset;
    }
    for (int i = 0; i < count; ++i) ++s.cell_start[static_cast<size_t>(cell_of_[i]) + 1];
    for (int c = 0; c < keys; ++c) s.cell_start[c + 1] += s.cell_start[c];
    fill_.assign(s.cell_start.begin(), s.cell_start.begin() + keys);
    for (int i = 0; i < count; ++i) dest_[static_cast<size_t>(i)] = fill_[cell_of_[i]]++;
    // v~ is empty without a thermostat: permuting it is then a no-op.
    for (auto* a : {&s.x, &s.y, &s.z, &s.vx, &s.vy, &s.vz, &s.vex, &s.vey, &s.vez})
      permute(*a, scratch_real_);
    permute(s.type, scratch_int_);
    permute(s.origin, scratch_int_);
    permute(s.id, scratch_id_);
    if (!s.left_to_grid.empty()) permute(s.left_to_grid, scratch_flag_);
    if (carry_forces)  // phi is empty without the wall model: a no-op then
      for (auto* a : {&s.fx, &s.fy, &s.fz, &s.rho, &s.bvf}) permute(*a, scratch_real_);
  }

 private:
  // a[dest[i]] = a[i] for the sorted particles (an empty array stays empty).
  template <class T>
  void permute(std::vector<T>& a, std::vector<T>& scratch) {
    const size_t count = std::min(dest_.size(), a.size());
    scratch.resize(count);
    for (size_t i = 0; i < count; ++i) scratch[static_cast<size_t>(dest_[i])] = a[i];
    if (count == a.size())
      a.swap(scratch);
    else  // the mobile part: the frozen part behind it stays
      std::copy(scratch.begin(), scratch.end(), a.begin());
  }
  std::vector<int> cell_of_, dest_, fill_;
  std::vector<Real> scratch_real_;
  std::vector<std::int32_t> scratch_int_;
  std::vector<std::int64_t> scratch_id_;
  std::vector<std::uint8_t> scratch_flag_;
};

template <class Real, class Terms>
class CpuEngine final : public Engine<Real>,
                        public DomainStore<Real>,
                        private Stepper<Real, Terms, CpuEngine<Real, Terms>> {
  using Steps = Stepper<Real, Terms, CpuEngine<Real, Terms>>;
  using C = typename Terms::conservative;
  using W = typename Terms::wall_model;
  friend Steps;

 public:
  explicit CpuEngine(const CpuEngineOptions& o)
      : threads_(o.threads), frozen_part_option_(o.frozen_part), burying_(o.buried_part) {}

  const char* name() const override { return "cpu"; }

  void initialize(HostState<Real>& host, StepHooks<Real>& hooks) override {
    s_ = &host;
    frozen_sums_valid_ = false;  // a new state: the first sort is full
    this->attach_hooks(hooks);
    ThreadScope scope(threads_);
    this->initial_forces();
  }

  void restore(HostState<Real>& host, std::uint64_t wall_corrections,
               StepHooks<Real>& hooks) override {
    s_ = &host;
    frozen_sums_valid_ = false;  // a new state: the first sort is full
    this->attach_hooks(hooks);
    corrected_ = wall_corrections;
    ThreadScope scope(threads_);
    // A single-rank checkpoint is already sorted (stable sort: no particle moves); a gathered one
    // (decomposed run) is in the original order, so the last forces move with their particles.
    this->sort(true);
  }

  void advance(std::uint64_t steps) override {
    ThreadScope scope(threads_);
    this->run_steps(steps);
  }

  void neighbour_counts(std::vector<int>& counts) override {
    ThreadScope scope(threads_);
    const StepView<Real> v = view();
    counts.assign(static_cast<size_t>(v.n), 0);
    const int n = v.n;
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) counts[static_cast<size_t>(i)] = neighbour_count(v, i);
  }

  std::vector<InjectionCounts> injection_counts() const override {
    std::vector<InjectionCounts> c = counts_;
    c.resize(s_->injections.size());
    return c;
  }

  void set_dt(Real dt) override {
    s_->dt = dt;
  }
  void download(HostState<Real>&) override {}
  std::uint64_t buried_particles() const override {
    if (!buried_part_) return 0;
    const size_t n = s_->cell_start.size();
    return static_cast<std::uint64_t>(s_->cell_start[n - 1] - s_->cell_start[n - 1 - frozen_part_]);
  }
  std::uint64_t step() const override {
    return s_->step;
  }

  // Deterministic whatever the thread count: fixed blocks of particles are summed in parallel,
  // each in particle order, and the block sums are added in block order. (Partial sums per thread
  // added under `omp critical` made stress and pressure depend on the scheduling at round-off.)
  VirialSums virial(const VirialRegion<Real>& region) override {
    ThreadScope scope(threads_);
    const StepView<Real> v = view();
    const int n = v.n;
    constexpr int kBlock = 256;  // particles per block: a few kB of sums for 1 M particles
    const int blocks = (n + kBlock - 1) / kBlock;
    std::vector<VirialSums> partial(static_cast<size_t>(blocks));
#pragma omp parallel for schedule(static)
    for (int b = 0; b < blocks; ++b) {
      VirialSums& local = partial[static_cast<size_t>(b)];
      const int end = std::min(n, (b + 1) * kBlock);
      for (int k = b * kBlock; k < end; ++k) {
        if (!region.contains(v, k)) continue;
        if (thermal(v, k)) add_kinetic_stress(v, k, local.kinetic);
        const auto w =
            virial_of_particle<Real, typename Terms::conservative, typename Terms::thermostat,
                               typename Terms::wall_model>(v, k);
        for (int c = 0; c < 6; ++c) {
          local.conservative[c] += w.conservative[c];
          local.dissipative[c] += w.dissipative[c];
          local.random[c] += w.random[c];
        }
      }
    }
    VirialSums total;
    for (const VirialSums& local : partial)
      for (int c = 0; c < 6; ++c) {
        total.kinetic[c] += local.kinetic[c];
        total.conservative[c] += local.conservative[c];
        total.dissipative[c] += local.dissipative[c];
        total.random[c] += local.random[c];
      }
    return total;
  }

  std::vector<RigidSlabBody> slab_bodies(std::vector<double>& coordinate_sums) override {
    const StepView<Real> v = view();
    coordinate_sums.assign(s_->slab_bodies.size(), 0.0);
    for (int i = 0; i < v.n; ++i)
      for (size_t k = 0; k < coordinate_sums.size(); ++k)
        coordinate_sums[k] += double(slab_coordinate_of(v, i, static_cast<int>(k)));
    return s_->slab_bodies;
  }
  SolidIntrusion solid_intrusion() override {
    const StepView<Real> v = view();
    if (!v.solid.enabled()) return {};
    SolidIntrusionSums sums;
    for (int i = 0; i < v.n; ++i) sums.merge(solid_intrusion_of_particle(v, i));
    return solid_intrusion_from(sums);
  }

  // Serial on purpose: the sums then come out the same whatever the thread count, and binning is
  // O(N) against the force pass's O(N x neighbours).
  void bin_sums(const BinGrid& grid, std::vector<double>& sums) override {
    const StepView<Real> v = view();
    const BinView<Real> b = BinView<Real>::make(grid);
    sums.assign(grid.count() * kBinFields, 0.0);
    for (int i = 0; i < v.n; ++i) {
      const int bin = bin_of_particle(v, b, i);
      if (bin < 0) continue;
      double* s = sums.data() + static_cast<size_t>(kBinFields) * bin;
      double t[kBinFields];
      bin_terms(v, i, t);
      for (int c = 0; c < kBinFields; ++c) s[c] += t[c];
    }
  }

 private:
  // Applies the requested thread count for the duration of a call, then restores it.
  struct ThreadScope {
    explicit ThreadScope(int t) : saved(omp_get_max_threads()) {
      if (t > 0) omp_set_num_threads(t);
    }
    ~ThreadScope() { omp_set_num_threads(saved); }
    int saved;
  };

  // ---- The backend primitives of the step sequence (sim/stepper.h). ----
  HostState<Real>& host_state() {
    return *s_;
  }
  // The host state's view, with the frozen part where the storage has one.
  StepView<Real> view() const {
    StepView<Real> v = s_->view();
    v.frozen_part = frozen_part_;
    v.buried_part = buried_part_;
    if (frozen_sums_valid_) {
      v.frozen_rho = frozen_rho_.empty() ? nullptr : frozen_rho_.data();
      v.frozen_bvf = frozen_bvf_.empty() ? nullptr : frozen_bvf_.data();
    }
    return v;
  }
  void next_step() {
    ++s_->step;
  }

  // body(v, i) for every stored particle, OpenMP static schedule: each particle's result is its
  // own, so the thread count changes nothing. While setting up, in chunks with the interrupt check
  // between them.
  template <class Body>
  void for_each(const StepView<Real>& v, Body body) {
    const int n = v.n;
    if (setting_up()) {
      setup_chunks(n, [&](int k) { body(v, k); });
      return;
    }
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) body(v, i);
  }
  // The pair passes use Newton's third law over the half list (sim/half_list.h): begin for every
  // particle, each pair once, finish for every particle.
  template <class Pass>
  void pair_sums(const StepView<Real>& v, const Pass& pass) {
    newton_pass(v, pass);
  }
  template <class Pass>
  void pair_forces(const StepView<Real>& v, const Pass& pass) {
    newton_pass(v, pass);
  }
  template <class Pass>
  void newton_pass(const StepView<Real>& v, const Pass& pass) {
    for_each(v, [&](const StepView<Real>& w, int i) { pass.begin(w, i); });
    list_.for_each_particle(v, pass, [&] { poll_setup(); });
    if constexpr (Pass::kFinishes)
      for_each(v, [&](const StepView<Real>& w, int i) { pass.finish(w, i); });
  }

  // Set-up (an interrupt check is set, Engine::set_interrupt_check; never in a decomposed run,
  // whose ranks must not leave a collective alone): the first density and force passes of a
  // large system take seconds (4 M particles on 2 cores: 4 s and 8 s), so they run in chunks of
  // kSetupChunk particles with the check between them. Each particle's sums are its own: the
  // results are those of one loop. A step's passes keep the plain loops.
  static constexpr int kSetupChunk = 1 << 18;
  bool setting_up() const {
    return this->interrupt_check_ && !this->hooks().distributed();
  }
  void poll_setup() {
    if (setting_up()) this->interrupt_check_();
  }
  template <class Body>
  void setup_chunks(int n, Body&& body) {
    for (int first = 0; first < n; first += kSetupChunk) {
      const int last = std::min(n, first + kSetupChunk);
#pragma omp parallel for schedule(static)
      for (int k = first; k < last; ++k) body(k);
      this->interrupt_check_();
    }
  }

  // The sort, and the half list of that sort: pairs within rc + skin (the skin of a reorder
  // interval; 0 when every step sorts). With a frozen part whose static sums hold, only the
  // mobile part is sorted (a stable sort would leave the frozen part as it is), and the half
  // list holds the pairs of the mobile particles only: a pair of two frozen particles is in
  // their static sums.
  void sort_by_cell(bool carry_forces) {
    const int ncells = s_->grid.count();
    const int n = s_->size();
    if (!split_frozen()) {
      frozen_part_ = 0;
      sorter_.sort(*s_, n, ncells, 0, carry_forces);
    } else if (frozen_sums_valid_ && frozen_part_ == ncells) {
      sorter_.sort(*s_, s_->cell_start[static_cast<size_t>(ncells)], ncells, 0, carry_forces);
    } else {
      frozen_part_ = ncells;
      frozen_sums_valid_ = false;
      buried_part_ = burying_ && s_->may_bury() && solid_intrusion().inside == 0;
      sorter_.sort(*s_, n, (buried_part_ ? 3 : 2) * ncells, ncells, carry_forces, buried_part_);
      update_frozen_sums();
    }
    list_.build(view(), Real(1) + s_->skin);
  }
  // Frozen particles in a part of their own, as on the GPU (StepView::frozen_part), when the
  // scene has frozen types and the run is on one rank (a decomposition moves particles between
  // ranks and refreshes its ghosts every step, which would void the static sums each time).
  bool split_frozen() const {
    return frozen_part_option_ && s_->frozen_mask != 0 && !this->hooks().distributed();
  }
  // After a full sort with a frozen part: each frozen particle's sums over its frozen neighbours
  // (StepView::frozen_rho), kept until the frozen particles may change (a new state, an
  // injection).
  void update_frozen_sums() {
    using K = std::conditional_t<C::needs_density, typename C::density_kernel, void>;
    const int start = s_->cell_start[static_cast<size_t>(frozen_part_)];
    const size_t frozen = static_cast<size_t>(s_->size() - start);
    frozen_rho_.assign(C::needs_density ? frozen : 0, Real(0));
    frozen_bvf_.assign(W::enabled ? frozen : 0, Real(0));
    if constexpr (C::needs_density || W::enabled)
      for_each(view(), [&](const StepView<Real>& v, int i) {
        if (i >= start)
          frozen_sums_of_particle<Real, K, W::enabled>(v, i, frozen_rho_.data(),
                                                       frozen_bvf_.data());
      });
    frozen_sums_valid_ = true;
  }
  bool sort_positions_stale() const {
    return x0_.size() != s_->x.size();
  }
  void remember_sort_positions() {
    x0_ = s_->x;
    y0_ = s_->y;
    z0_ = s_->z;
  }
  bool any_moved_beyond(Real limit2) {
    const StepView<Real> v = view();
    const int n = v.n;
    int moved = 0;
#pragma omp parallel for schedule(static) reduction(max : moved)
    for (int i = 0; i < n; ++i)
      moved =
          std::max(moved, displacement2(v, x0_.data(), y0_.data(), z0_.data(), i) > limit2 ? 1 : 0);
    return moved != 0;
  }

  void slab_half_kicks() {
    for (size_t b = 0; b < s_->slab_bodies.size(); ++b) {
      slab_half_kick(s_->slab_bodies[b], s_->dt);
      s_->slab_half_velocity[b] = static_cast<Real>(s_->slab_bodies[b].half_velocity);
    }
  }

  // Sum over slab k's particles of their force along its axis; a serial loop in storage order, so
  // the result does not depend on the thread count.
  double slab_pair_force(int k) const {
    const StepView<Real> v = view();
    double sum = 0;
    for (int i = 0; i < v.n; ++i) sum += slab_force_of(v, i, k);
    return sum;
  }

  // The slabs' forces from the last force pass (summed over the ranks), then (kick) their second
  // half kicks.
  void slab_forces(bool kick) {
    const size_t count = s_->slab_bodies.size();
    if (count == 0) return;
    std::vector<double> f(count);
    for (size_t b = 0; b < count; ++b) f[b] = slab_pair_force(static_cast<int>(b));
    this->hooks().sum(f.data(), static_cast<int>(count));
    for (size_t b = 0; b < count; ++b) {
      slab_set_force(s_->slab_bodies[b], f[b]);
      if (!kick) continue;
      slab_full_kick(s_->slab_bodies[b], s_->dt);
      s_->slab_velocity[b] = static_cast<Real>(s_->slab_bodies[b].velocity);
    }
  }

  // The injection/ejection events due at this step (sim/injection.h). Serial on purpose: one
  // O(N) scan per pick, independent of the thread count; the GPU takes the same particle.
  void inject() {
    if (counts_.size() != s_->injections.size()) counts_.resize(s_->injections.size());
    const StepView<Real> v = view();
    for (size_t k = 0; k < s_->injections.size(); ++k) {
      const InjectionPlan<Real>& plan = s_->injections[k];
      if (!plan.due(v.step)) continue;
      for (int pick = 0; pick < plan.per_event; ++pick) {
        std::uint64_t best = kNoInjectionCandidate;
        for (int i = 0; i < v.n; ++i)
          best = std::min(best, injection_key_of(v, plan.view, i, pick));
        best = this->hooks().min(best);
        if (best == kNoInjectionCandidate) {
          ++counts_[k].missed;
          continue;
        }
        for (int i = 0; i < v.n; ++i)
          if (injection_key_of(v, plan.view, i, pick) == best) {
            inject_particle(v, plan.view, i, pick);
            ++counts_[k].injected;
            frozen_sums_valid_ = false;  // a pick may change a type: the next sort is full
          }
      }
    }
  }

  void watchdog_step() {
    if (this->watchdog_.enabled) watchdog_scan(view(), this->watchdog_);  // throws
  }
  void kick_and_watchdog() {
    for_each(view(), KickPass<Real>{});
    watchdog_step();
  }
  void finish_steps(std::uint64_t) {}
  void mark(StepPhase) {}

 public:
  // ---- DomainStore (sim/domain/exchange.h): the host storage as a decomposition sees it. ----
  int owned_count() const override {
    return s_->size() - ghost_count_;
  }

  void drop_ghosts_take_leavers(const LocalRegion<Real>& region,
                                std::vector<MigrantRecord<Real>>& leavers) override {
    HostState<Real>& s = *s_;
    const int n = s.size();
    const bool est = !s.vex.empty();
    keep_.clear();
    for (int i = 0; i < n; ++i) {
      if (s.origin[i] < 0) continue;  // a ghost: rebuilt after the migration
      Real x[3] = {s.x[i], s.y[i], s.z[i]};
      region.wrap(x);
      s.x[i] = x[0], s.y[i] = x[1], s.z[i] = x[2];
      if (region.contains(x)) {
        keep_.push_back(i);
        continue;
      }
      MigrantRecord<Real> r;
      for (int a = 0; a < 3; ++a) r.x[a] = x[a];
      r.v[0] = s.vx[i], r.v[1] = s.vy[i], r.v[2] = s.vz[i];
      r.ve[0] = est ? s.vex[i] : r.v[0];
      r.ve[1] = est ? s.vey[i] : r.v[1];
      r.ve[2] = est ? s.vez[i] : r.v[2];
      r.f[0] = s.fx[i], r.f[1] = s.fy[i], r.f[2] = s.fz[i];
      r.type = s.type[i];
      r.id = s.id[i];
      r.left_to_grid = s.left_to_grid.empty() ? 0 : s.left_to_grid[i];
      leavers.push_back(r);
    }
    if (keep_.size() != static_cast<size_t>(n))  // else nothing left and there were no ghosts
      s.for_each_particle_array([&](auto& a) {
        for (size_t k = 0; k < keep_.size(); ++k) a[k] = a[static_cast<size_t>(keep_[k])];
        a.resize(keep_.size());
      });
    for (size_t k = 0; k < keep_.size(); ++k) s.origin[k] = static_cast<std::int32_t>(k);
    ghost_count_ = 0;
  }

  void add_owned(const std::vector<MigrantRecord<Real>>& in) override {
    HostState<Real>& s = *s_;
    for (const MigrantRecord<Real>& r : in) {
      s.origin.push_back(static_cast<std::int32_t>(s.x.size()));
      push_particle(r.x, r.v, r.ve, r.f, r.type, r.id, r.left_to_grid);
    }
  }

  void pack_ghosts(const std::vector<HaloBox<Real>>& boxes, std::vector<GhostRecord<Real>>& out,
                   std::vector<int>& counts) override {
    const HostState<Real>& s = *s_;
    send_slots_.clear();
    send_shift_.clear();
    counts.assign(boxes.size(), 0);
    const int n = s.size();
    for (size_t b = 0; b < boxes.size(); ++b) {
      const HaloBox<Real>& h = boxes[b];
      for (int i = 0; i < n; ++i) {
        if (s.origin[i] < 0 || !h.contains(s.x[i], s.y[i], s.z[i])) continue;
        out.push_back(ghost_record(i, h.shift));
        send_slots_.push_back(s.origin[i]);
        send_shift_.push_back(static_cast<int>(b));
        ++counts[b];
      }
    }
    send_boxes_ = boxes;
  }

  void add_ghosts(const std::vector<GhostRecord<Real>>& in) override {
    HostState<Real>& s = *s_;
    const Real zero[3] = {0, 0, 0};
    for (size_t k = 0; k < in.size(); ++k) {
      s.origin.push_back(-1 - static_cast<std::int32_t>(k));
      push_particle(in[k].x, zero, in[k].ve, zero, in[k].type, in[k].id);
    }
    ghost_count_ = static_cast<int>(in.size());
    s.has_ghosts = true;
  }

  int sums_per_particle() const override {
    return s_->bvf.empty() ? 1 : 2;
  }

  void pack_sums(std::vector<Real>& out) override {
    map_slots();
    const bool walls = !s_->bvf.empty();
    for (std::int32_t slot : send_slots_) {
      const int i = slot_index_[static_cast<size_t>(slot)];
      out.push_back(s_->rho[i]);
      if (walls) out.push_back(s_->bvf[i]);
    }
  }

  void set_ghost_sums(const std::vector<Real>& in) override {
    HostState<Real>& s = *s_;
    const int per = sums_per_particle();
    for (int i = 0; i < s.size(); ++i) {
      if (s.origin[i] >= 0) continue;
      const size_t k = static_cast<size_t>(-1 - s.origin[i]) * static_cast<size_t>(per);
      s.rho[i] = in[k];
      if (per == 2) s.bvf[i] = in[k + 1];
    }
  }

  void pack_refresh(std::vector<GhostRecord<Real>>& out) override {
    map_slots();
    for (size_t k = 0; k < send_slots_.size(); ++k)
      out.push_back(ghost_record(slot_index_[static_cast<size_t>(send_slots_[k])],
                                 send_boxes_[static_cast<size_t>(send_shift_[k])].shift));
  }

  void set_ghost_refresh(const std::vector<GhostRecord<Real>>& in) override {
    HostState<Real>& s = *s_;
    const bool est = !s.vex.empty();
    for (int i = 0; i < s.size(); ++i) {
      if (s.origin[i] >= 0) continue;
      const GhostRecord<Real>& r = in[static_cast<size_t>(-1 - s.origin[i])];
      s.x[i] = r.x[0], s.y[i] = r.x[1], s.z[i] = r.x[2];
      if (est) s.vex[i] = r.ve[0], s.vey[i] = r.ve[1], s.vez[i] = r.ve[2];
    }
  }

 private:
  GhostRecord<Real> ghost_record(int i, const Real shift[3]) const {
    const HostState<Real>& s = *s_;
    const bool est = !s.vex.empty();
    GhostRecord<Real> r;
    r.x[0] = s.x[i] + shift[0], r.x[1] = s.y[i] + shift[1], r.x[2] = s.z[i] + shift[2];
    r.ve[0] = est ? s.vex[i] : Real(0);
    r.ve[1] = est ? s.vey[i] : Real(0);
    r.ve[2] = est ? s.vez[i] : Real(0);
    r.type = s.type[i];
    r.id = s.id[i];
    return r;
  }

  void push_particle(const Real x[3], const Real v[3], const Real ve[3], const Real f[3],
                     std::int32_t type, std::int64_t id, std::uint8_t left_to_grid = 0) {
    HostState<Real>& s = *s_;
    if (s.needs_left_to_grid()) s.left_to_grid.push_back(left_to_grid);
    // v~ exists only with a thermostat, phi only with the wall model (HostState).
    if constexpr (Terms::thermostat::enabled)
      s.vex.push_back(ve[0]), s.vey.push_back(ve[1]), s.vez.push_back(ve[2]);
    if constexpr (Terms::wall_model::enabled) s.bvf.push_back(Real(0));
    s.x.push_back(x[0]), s.y.push_back(x[1]), s.z.push_back(x[2]);
    s.vx.push_back(v[0]), s.vy.push_back(v[1]), s.vz.push_back(v[2]);
    s.fx.push_back(f[0]), s.fy.push_back(f[1]), s.fz.push_back(f[2]);
    s.rho.push_back(Real(0));
    s.type.push_back(type);
    s.id.push_back(id);
  }

  // Where each owned slot stands in the (cell-sorted) storage now.
  void map_slots() {
    const HostState<Real>& s = *s_;
    slot_index_.assign(static_cast<size_t>(owned_count()), -1);
    for (int i = 0; i < s.size(); ++i)
      if (s.origin[i] >= 0) slot_index_[static_cast<size_t>(s.origin[i])] = i;
  }

  // The corrector runs after the sums (the CPU has no frozen part to find walls in before them).
  static constexpr bool kCorrectsBeforeSort = false;

  // Finds every penetrating particle against the same positions, then applies the corrections.
  int correct_penetrations() {
    const StepView<Real> v = view();
    const int n = v.n;
    corrections_.clear();
#pragma omp parallel
    {
      std::vector<Correction> mine;
#pragma omp for schedule(static) nowait
      for (int k = 0; k < n; ++k) {
        Correction c;
        if (penetration_correction(v, k, v.bvf[k], c.dv)) {
          c.index = k;
          mine.push_back(c);
        }
      }
#pragma omp critical
      corrections_.insert(corrections_.end(), mine.begin(), mine.end());
    }
    for (const Correction& c : corrections_)
      apply_penetration_correction<Real, Terms::thermostat::enabled>(v, c.index, c.dv);
    corrected_ += corrections_.size();
    return static_cast<int>(corrections_.size());
  }

 public:
  std::uint64_t wall_corrections() const override {
    return corrected_;
  }

 private:
  struct Correction {
    int index = 0;
    Real dv[3] = {0, 0, 0};
  };
  std::vector<Correction> corrections_;
  std::vector<InjectionCounts> counts_;
  // Reorder interval only: the positions at the last sort.
  std::vector<Real> x0_, y0_, z0_;
  int ghost_count_ = 0;
  std::vector<int> keep_, slot_index_, send_shift_;
  std::vector<std::int32_t> send_slots_;
  std::vector<HaloBox<Real>> send_boxes_;
  std::uint64_t corrected_ = 0;
  int threads_;
  // The frozen part (split_frozen): its cell count offset in cell_start (0: no frozen part), its
  // static sums and whether they hold. frozen_part_option_: SimulationOptions::frozen_part.
  bool frozen_part_option_ = true;
  int frozen_part_ = 0;
  bool frozen_sums_valid_ = false;
  // Whether the last full sort made a buried part (StepView::buried_part; kernels.h buried);
  // burying_: SimulationOptions::buried_part.
  bool burying_ = true;
  bool buried_part_ = false;
  std::vector<Real> frozen_rho_, frozen_bvf_;
  HostState<Real>* s_ = nullptr;
  CellSorter<Real> sorter_;
  HalfList<Real> list_;
};

}  // namespace

template <class Real>
std::unique_ptr<Engine<Real>> make_cpu_engine(const Model& model, const CpuEngineOptions& options) {
  std::unique_ptr<Engine<Real>> engine;
  dispatch_terms(model, [&](auto terms) {
    engine = std::make_unique<CpuEngine<Real, decltype(terms)>>(options);
  });
  return engine;
}

template std::unique_ptr<Engine<float>> make_cpu_engine<float>(const Model&,
                                                               const CpuEngineOptions&);
template std::unique_ptr<Engine<double>> make_cpu_engine<double>(const Model&,
                                                                 const CpuEngineOptions&);

}  // namespace mesorock::sim
