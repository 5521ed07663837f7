#include "sim/engine_cpu.h"

#include <omp.h>

#include <algorithm>
#include <type_traits>
#include <vector>

#include "sim/kernels.h"
#include "sim/terms.h"

namespace mesorock::sim {

namespace {

// Counting sort of the particles by cell, applied to the storage itself: afterwards cell c holds
// particles [cell_start[c], cell_start[c+1]) and the neighbour loop reads contiguous memory.
// Stable, so the order within a cell (and hence every floating-point sum) is deterministic.
template <class Real>
class CellSorter {
 public:
  void sort(HostState<Real>& s) {
    const int ncells = s.grid.count();
    const int n = s.size();
    s.cell_start.assign(static_cast<size_t>(ncells) + 1, 0);
    cell_of_.resize(static_cast<size_t>(n));
    dest_.resize(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      const int c = s.grid.index(s.grid.coordinate(s.x[i], s.box.lo[0], 0),
                                 s.grid.coordinate(s.y[i], s.box.lo[1], 1),
                                 s.grid.coordinate(s.z[i], s.box.lo[2], 2));
      cell_of_[static_cast<size_t>(i)] = c;
      ++s.cell_start[static_cast<size_t>(c) + 1];
    }
    for (int c = 0; c < ncells; ++c) s.cell_start[c + 1] += s.cell_start[c];
    fill_.assign(s.cell_start.begin(), s.cell_start.end() - 1);
    for (int i = 0; i < n; ++i) dest_[static_cast<size_t>(i)] = fill_[cell_of_[i]]++;
    // v~ is empty without a thermostat: permuting it is then a no-op.
    for (auto* a : {&s.x, &s.y, &s.z, &s.vx, &s.vy, &s.vz, &s.vex, &s.vey, &s.vez})
      permute(*a, scratch_real_);
    permute(s.type, scratch_int_);
    permute(s.origin, scratch_int_);
    permute(s.id, scratch_id_);
  }

 private:
  template <class T>
  void permute(std::vector<T>& a, std::vector<T>& scratch) {
    scratch.resize(a.size());
    const size_t n = a.size();
    for (size_t i = 0; i < n; ++i) scratch[static_cast<size_t>(dest_[i])] = a[i];
    a.swap(scratch);
  }
  std::vector<int> cell_of_, dest_, fill_;
  std::vector<Real> scratch_real_;
  std::vector<std::int32_t> scratch_int_;
  std::vector<std::int64_t> scratch_id_;
};

template <class Real, class Terms>
class CpuEngine final : public Engine<Real> {
 public:
  explicit CpuEngine(int threads) : threads_(threads) {}

  const char* name() const override { return "cpu"; }

  void initialize(HostState<Real>& host) override {
    s_ = &host;
    compute_forces();
    for (size_t k = 0; k < s_->slab_bodies.size(); ++k)
      slab_set_force(s_->slab_bodies[k], slab_pair_force(static_cast<int>(k)));
  }

  void restore(HostState<Real>& host, std::uint64_t wall_corrections) override {
    s_ = &host;
    corrected_ = wall_corrections;
    ThreadScope scope(threads_);
    sorter_.sort(*s_);  // the saved storage is already sorted (stable sort: no particle moves)
  }

  void advance(std::uint64_t steps) override {
    ThreadScope scope(threads_);
    for (std::uint64_t k = 0; k < steps; ++k) {
      for (size_t b = 0; b < s_->slab_bodies.size(); ++b) {
        slab_half_kick(s_->slab_bodies[b], s_->dt);
        s_->slab_half_velocity[b] = static_cast<Real>(s_->slab_bodies[b].half_velocity);
      }
      const StepView<Real> v = s_->view();
      const int n = v.n;
#pragma omp parallel for schedule(static)
      for (int i = 0; i < n; ++i) kick_drift<Real, Terms::thermostat::enabled>(v, i);
      ++s_->step;
      compute_forces();
      for (size_t b = 0; b < s_->slab_bodies.size(); ++b) {
        slab_set_force(s_->slab_bodies[b], slab_pair_force(static_cast<int>(b)));
        slab_full_kick(s_->slab_bodies[b], s_->dt);
        s_->slab_velocity[b] = static_cast<Real>(s_->slab_bodies[b].velocity);
      }
      const StepView<Real> w = s_->view();
#pragma omp parallel for schedule(static)
      for (int i = 0; i < n; ++i) kick(w, i);
    }
  }

  void set_dt(Real dt) override {
    s_->dt = dt;
  }
  void download(HostState<Real>&) override {}
  std::uint64_t step() const override {
    return s_->step;
  }

  VirialSums virial() override {
    ThreadScope scope(threads_);
    const StepView<Real> v = s_->view();
    const int n = v.n;
    VirialSums total;
#pragma omp parallel
    {
      VirialSums local;
#pragma omp for schedule(static)
      for (int k = 0; k < n; ++k) {
        const auto w =
            virial_of_particle<Real, typename Terms::conservative, typename Terms::thermostat,
                               typename Terms::wall_model>(v, k);
        for (int c = 0; c < 6; ++c) {
          local.conservative[c] += w.conservative[c];
          local.dissipative[c] += w.dissipative[c];
          local.random[c] += w.random[c];
        }
      }
#pragma omp critical
      for (int c = 0; c < 6; ++c) {
        total.conservative[c] += local.conservative[c];
        total.dissipative[c] += local.dissipative[c];
        total.random[c] += local.random[c];
      }
    }
    return total;
  }

  // Serial on purpose: the sums then come out the same whatever the thread count, and binning is
  // O(N) against the force pass's O(N x neighbours).
  void bin_sums(const BinGrid& grid, std::vector<double>& sums) override {
    const StepView<Real> v = s_->view();
    const BinView<Real> b = BinView<Real>::make(grid);
    sums.assign(grid.count() * kBinFields, 0.0);
    for (int i = 0; i < v.n; ++i) {
      const int bin = bin_of_particle(v, b, i);
      if (bin < 0) continue;
      double* s = sums.data() + static_cast<size_t>(kBinFields) * bin;
      const double vel[3] = {double(v.vx[i]), double(v.vy[i]), double(v.vz[i])};
      s[kBinCount] += 1.0;
      for (int a = 0; a < 3; ++a) {
        s[kBinVx + a] += vel[a];
        s[kBinVxx + a] += vel[a] * vel[a];
      }
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

  // Cell list, density (only with a many-body term), the wall model's phi and corrector (only
  // with it), forces; for step s_->step.
  void compute_forces() {
    ThreadScope scope(threads_);
    sorter_.sort(*s_);
    using C = typename Terms::conservative;
    using W = typename Terms::wall_model;
    local_sums();
    if constexpr (W::enabled) {
      if (correct_penetrations() > 0) {
        // Corrected particles moved: sort and sum again so the cell list and rho stay exact.
        sorter_.sort(*s_);
        local_sums();
      }
    }
    const StepView<Real> v = s_->view();
    const int n = v.n;
#pragma omp parallel for schedule(static)
    for (int k = 0; k < n; ++k)
      force_on_particle<Real, C, typename Terms::thermostat, typename Terms::body_force, W>(
          v, k, NeighbourStash{});
  }

  void local_sums() {
    using C = typename Terms::conservative;
    const StepView<Real> v = s_->view();
    const int n = v.n;
    if constexpr (Terms::wall_model::enabled) {
      using K = std::conditional_t<C::needs_density, typename C::density_kernel, void>;
#pragma omp parallel for schedule(static)
      for (int k = 0; k < n; ++k) density_and_bvf_of_particle<Real, K>(v, k);
    } else if constexpr (C::needs_density) {
#pragma omp parallel for schedule(static)
      for (int k = 0; k < n; ++k) density_of_particle<Real, typename C::density_kernel>(v, k);
    }
  }

  // Sum over slab k's particles of their force along its axis; a serial loop in storage order, so
  // the result does not depend on the thread count.
  double slab_pair_force(int k) const {
    const StepView<Real> v = s_->view();
    double sum = 0;
    for (int i = 0; i < v.n; ++i) sum += slab_force_of(v, i, k);
    return sum;
  }

  // Finds every penetrating particle against the same positions, then applies the corrections.
  int correct_penetrations() {
    const StepView<Real> v = s_->view();
    const int n = v.n;
    corrections_.clear();
#pragma omp parallel
    {
      std::vector<Correction> mine;
#pragma omp for schedule(static) nowait
      for (int k = 0; k < n; ++k) {
        Correction c;
        if (penetration_correction(v, k, c.dv)) {
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
  std::uint64_t corrected_ = 0;
  int threads_;
  HostState<Real>* s_ = nullptr;
  CellSorter<Real> sorter_;
};

}  // namespace

template <class Real>
std::unique_ptr<Engine<Real>> make_cpu_engine(const Model& model, int threads) {
  std::unique_ptr<Engine<Real>> engine;
  dispatch_terms(model, [&](auto terms) {
    engine = std::make_unique<CpuEngine<Real, decltype(terms)>>(threads);
  });
  return engine;
}

template std::unique_ptr<Engine<float>> make_cpu_engine<float>(const Model&, int);
template std::unique_ptr<Engine<double>> make_cpu_engine<double>(const Model&, int);

}  // namespace mesorock::sim
