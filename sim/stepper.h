#pragma once
// The one step sequence of every backend (Cabana-style backend policy). Stepper<Real, Terms,
// Backend> writes the velocity-Verlet step, the force computation and the re-sort decision once;
// the engine (Backend, CRTP) supplies the few primitives that truly differ between a CPU loop and
// CUDA kernels:
//
//   HostState<Real>& host_state()          the run's parameters (and, on the CPU, its storage)
//   StepView<Real> view()                  the storage as the kernel bodies see it
//   for_each(view, body)                   body(view, i) for every stored particle, in parallel
//   pair_sums(view, pass), pair_forces(view, pass)
//                                          a pass over the pairs (below): on the GPU a gather per
//                                          particle, on the CPU Newton over a half list
//   sort_by_cell(carry_forces)             the stable cell sort of the storage (and, on the CPU,
//                                          its half list)
//   sort_positions_stale(), remember_sort_positions(), any_moved_beyond(limit2)
//   correct_penetrations()                 the wall model's corrector; returns the count
//   kCorrectsBeforeSort, frozen_part_ready(), correct_against_frozen_part()
//                                          optional (the GPU): the corrector before the sort,
//                                          finding the walls in the frozen part alone
//   slab_half_kicks(), slab_forces(kick)   the rigid slabs' reductions and kicks
//   inject(), watchdog_step()              per-step events, after the second kick
//   kick_and_watchdog()                    the second kick and the watchdog's check (a step
//                                          without injection: the GPU fuses them, one launch)
//   next_step(), finish_steps(steps), mark(phase), poll_setup()
//
// A new phase of the step is written here, once. The kernel bodies stay in sim/kernels.h; a
// run on one rank uses SerialHooks, so the decomposition's phases are plain calls, never a
// branch on a null pointer.
#include <cstdint>
#include <type_traits>

#include "sim/domain/exchange.h"
#include "sim/hd.h"
#include "sim/kernels.h"
#include "sim/state.h"

namespace mesorock::sim {

// The domain phases of a run on one rank: no ghosts, no migration, and each reduction over the
// ranks returns its argument.
template <class Real>
class SerialHooks final : public StepHooks<Real> {
 public:
  void exchange(DomainStore<Real>&) override {}
  void sync_sums(DomainStore<Real>&) override {}
  void refresh_ghosts(DomainStore<Real>&) override {}
  bool any(bool local) override { return local; }
  void sum(double*, int) override {}
  std::uint64_t min(std::uint64_t value) override { return value; }
  bool distributed() const override { return false; }
};

// Where the profiler's marks stand in a step (the CUDA engine times the passes between them).
enum class StepPhase : int {
  KickDrift = 0,
  Corrector = 1,  // the wall model's corrector against the frozen part, before the sort
  Sort = 2,
  Sums = 3,
  Resort = 4,  // otherwise the corrector after the sums, and its re-sort and second sums
  Forces = 5,
  Kick = 6,
  End = 7
};

// ---- The passes: the functions of sim/kernels.h as functors. ----
// Each pass has two forms of one computation. operator()(v, i) gathers particle i's sums over its
// neighbours (the GPU: one thread per particle, each pair seen from both sides). begin, pairs and
// finish add each pair once to both particles (Newton's third law; the CPU over its half list:
// begin for every particle, then pairs(v, i, first, force_end, last) over particle i's half list,
// whose pairs from force_end on join two frozen particles, then finish for every particle).

template <class Real, bool kVelocityEstimate>
struct KickDriftPass {
  MESO_HD MESO_INLINE void operator()(const StepView<Real>& v, int i) const {
    kick_drift<Real, kVelocityEstimate>(v, i);
  }
};

template <class Real>
struct KickPass {
  MESO_HD MESO_INLINE void operator()(const StepView<Real>& v, int i) const { kick(v, i); }
};

// rho; with kWalls also phi, the wall model's boundary volume fraction. DensityKernel is void
// without a many-body term: phi alone. Frozen pairs count (a frozen particle's rho enters the
// force on its mobile neighbours).
// (The gathers take the lanes that share particle i's scan: OneLane, or the GPU's LaneGroup.)
template <class Real, class DensityKernel, bool kWalls>
struct SumsPass {
  template <class Lanes = OneLane>
  MESO_HD MESO_INLINE void operator()(const StepView<Real>& v, int i,
                                      const Lanes& lanes = Lanes{}) const {
    if constexpr (kWalls)
      density_and_bvf_of_particle<Real, DensityKernel>(v, i, lanes);
    else
      density_of_particle<Real, DensityKernel>(v, i, lanes);
  }
  MESO_HD MESO_INLINE void begin(const StepView<Real>& v, int i) const {
    begin_sums<Real, DensityKernel, kWalls>(v, i);
  }
  MESO_HD MESO_INLINE void pairs(const StepView<Real>& v, int i, const int* first, const int*,
                                 const int* last) const {
    sums_of_pairs<Real, DensityKernel, kWalls>(v, i, first, last);
  }
  // Only phi needs a finish (its scale): without walls the Newton pass skips the loop.
  static constexpr bool kFinishes = kWalls;
  MESO_HD MESO_INLINE void finish([[maybe_unused]] const StepView<Real>& v,
                                  [[maybe_unused]] int i) const {
    if constexpr (kWalls) finish_sums(v, i);
  }
};

// Forces; pairs of two frozen particles are skipped (neither moves).
template <class Real, class Terms>
struct ForcePass {
  using C = typename Terms::conservative;
  using T = typename Terms::thermostat;
  template <class Lanes = OneLane>
  MESO_HD MESO_INLINE void operator()(const StepView<Real>& v, int i, NeighbourStash stash,
                                      const Lanes& lanes = Lanes{}) const {
    force_on_particle<Real, C, T, typename Terms::body_force, typename Terms::wall_model>(
        v, i, stash, lanes);
  }
  MESO_HD MESO_INLINE void begin(const StepView<Real>& v, int i) const { begin_forces(v, i); }
  static constexpr bool kFinishes = true;
  MESO_HD MESO_INLINE void pairs(const StepView<Real>& v, int i, const int* first,
                                 const int* force_end, const int*) const {
    forces_of_pairs<Real, C, T, typename Terms::wall_model>(v, i, first, force_end);
  }
  MESO_HD MESO_INLINE void finish(const StepView<Real>& v, int i) const {
    finish_forces<Real, typename Terms::body_force>(v, i);
  }
};

template <class Real, class Terms, class Backend>
class Stepper {
 protected:
  using C = typename Terms::conservative;
  using W = typename Terms::wall_model;
  // The density and phi pass (the density kernel is void without a many-body term).
  using Sums =
      SumsPass<Real, std::conditional_t<C::needs_density, typename C::density_kernel, void>,
               W::enabled>;

  // The domain's hooks: SerialHooks on one rank, the decomposition's otherwise.
  void attach_hooks(StepHooks<Real>& hooks) { hooks_ = &hooks; }
  StepHooks<Real>& hooks() const { return *hooks_; }

  // Forces (and the slabs' forces) of the current step: the start of a run.
  void initial_forces() {
    compute_forces();
    backend().slab_forces(false);
  }

  // Velocity Verlet (Groot & Warren 1997 with lambda = 1/2): half kick and drift, forces of the
  // new positions, second half kick; then this step's injections and the watchdog.
  void run_steps(std::uint64_t steps) {
    Backend& b = backend();
    for (std::uint64_t k = 0; k < steps; ++k) {
      b.mark(StepPhase::KickDrift);
      b.slab_half_kicks();
      b.for_each(b.view(), KickDriftPass<Real, Terms::thermostat::enabled>{});
      b.next_step();
      compute_forces();  // a decomposed run's particle count may change here
      b.slab_forces(true);
      b.mark(StepPhase::Kick);
      if (b.host_state().injections.empty()) {
        b.kick_and_watchdog();  // throws on a blow-up (the GPU when it polls)
        b.mark(StepPhase::End);
      } else {
        b.for_each(b.view(), KickPass<Real>{});
        b.inject();
        b.mark(StepPhase::End);
        b.watchdog_step();
      }
    }
    b.finish_steps(steps);
  }

  // Cell list, density (only with a many-body term), the wall model's phi and corrector (only
  // with it), forces; for the current step. Decomposed: migration and ghosts first, the ghosts'
  // sums after the density pass.
  void compute_forces() {
    Backend& b = backend();
    hooks_->exchange(b);
    b.mark(StepPhase::Corrector);
    const bool corrected_before_sort = correct_before_sort();
    b.mark(StepPhase::Sort);
    if (sort_due()) sort();
    b.mark(StepPhase::Sums);
    b.poll_setup();
    local_sums();
    b.poll_setup();
    hooks_->sync_sums(b);
    b.mark(StepPhase::Resort);
    bool corrected = false;
    if constexpr (W::enabled)
      if (!corrected_before_sort) corrected = hooks_->any(b.correct_penetrations() > 0);
    if (corrected) {
      // Corrected particles moved: sort and sum again so the cell list and rho stay exact (and,
      // decomposed, their ghosts follow them first).
      hooks_->refresh_ghosts(b);
      sort();
      local_sums();
      hooks_->sync_sums(b);
    }
    b.mark(StepPhase::Forces);
    b.pair_forces(b.view(), ForcePass<Real, Terms>{});
  }

  // The stable cell sort; with a reorder interval, also the positions it was made at.
  void sort(bool carry_forces = false) {
    Backend& b = backend();
    b.sort_by_cell(carry_forces);
    if (b.host_state().reorder_every > 1) {
      b.remember_sort_positions();
      steps_since_sort_ = 0;
    }
  }

 private:
  Backend& backend() { return static_cast<Backend&>(*this); }

  // Every step, or with a reorder interval (HostState::reorder_every) when the interval is up or a
  // particle has moved more than skin / 2 since the last sort.
  bool sort_due() {
    Backend& b = backend();
    const HostState<Real>& h = b.host_state();
    if (h.reorder_every <= 1 || ++steps_since_sort_ >= h.reorder_every || b.sort_positions_stale())
      return true;
    const Real half = Real(0.5) * h.skin;
    return b.any_moved_beyond(half * half);
  }

  // The wall corrector before the sort, where the backend can find the walls without a cell list
  // of this step (the GPU's frozen part, sorted once) and the run is on one rank. phi and the
  // wall normal at the predicted positions sum the same wall particles in the same order as
  // after the sort, so the decisions and moves are the same; the corrected positions are then
  // sorted and summed once. false: nothing done (the corrector runs after the sums).
  bool correct_before_sort() {
    if constexpr (Backend::kCorrectsBeforeSort && W::enabled) {
      Backend& b = backend();
      if (hooks_->distributed() || !b.frozen_part_ready()) return false;
      b.correct_against_frozen_part();
      return true;
    } else {
      return false;
    }
  }

  void local_sums() {
    Backend& b = backend();
    if constexpr (W::enabled || C::needs_density) b.pair_sums(b.view(), Sums{});
  }

  StepHooks<Real>* hooks_ = nullptr;
  int steps_since_sort_ = 0;
};

}  // namespace mesorock::sim
