#pragma once
// Host-side solver state in the run's precision (SoA). The CPU engine works on it in place; the
// CUDA engine mirrors it on the device and writes it back only when an output asks.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sim/box.h"
#include "sim/cell_grid.h"
#include "sim/domain/exchange.h"
#include "sim/kernels.h"
#include "sim/model.h"
#include "sim/pair_terms.h"
#include "sim/watchdog.h"

namespace mesorock::sim {

template <class Real>
struct HostState {
  std::vector<Real> x, y, z, vx, vy, vz, vex, vey, vez, fx, fy, fz, rho;
  std::vector<Real> bvf;  // boundary volume fraction: empty without the wall model
  // StepView::left_to_grid: sized only with the solid grid's bounce and the wall model both on.
  std::vector<std::uint8_t> left_to_grid;
  std::vector<std::int32_t> type;
  std::vector<std::int64_t> id;
  // Where each stored particle stood in the initial ParticleSet: engines keep particles sorted by
  // cell, and outputs are returned in the caller's original order through this.
  std::vector<std::int32_t> origin;
  std::vector<int> cell_start;  // cell list over the cell-sorted storage (built by the engine)
  bool has_ghosts = false;      // a decomposed run's storage holds ghosts (origin < 0)
  // Reorder interval and skin (SimulationOptions): with reorder_every > 1 the cell list may be
  // stale by up to skin / 2 of motion, and the positions at the last sort are kept to check it.
  int reorder_every = 1;
  Real skin = 0;

  std::vector<PairParams<Real>> table;  // ntypes x ntypes
  std::vector<Real> body_force;         // ntypes x 3
  std::uint32_t frozen_mask = 0;
  WallModelView<Real> walls;  // its kappa pointer is set by view() (host) or the engine (device)
  VirtualWalls<Real> virtual_walls;
  // The solid grid (its bytes belong to the model's mask; the CUDA engine keeps a device copy).
  SolidView<Real> solid;
  // Rigid slabs: the bodies (double precision) and the velocities the kernels read.
  RigidSlabs<Real> slabs;
  std::vector<RigidSlabBody> slab_bodies;
  std::vector<Real> slab_half_velocity, slab_velocity;
  std::vector<Real> kappa;                      // the wall model's dissipation table
  std::vector<InjectionPlan<Real>> injections;  // injection/ejection boundaries (often none)
  int ntypes = 0;
  int body_force_axis = 2;
  Real body_force_midplane = 0;

  Box<Real> box;
  CellGrid<Real> grid;
  Real rd = Real(0.75), dt = Real(0.01), lambda = Real(0.5);
  std::uint64_t seed = 0;
  std::uint64_t step = 0;

  int size() const { return static_cast<int>(x.size()); }

  // Calls f on every per-particle array that is in use (v~ exists only with a thermostat, phi
  // only with the wall model), Real arrays first, then type, id, origin.
  template <class F>
  void for_each_particle_array(F&& f) {
    const size_t n = x.size();
    for (auto* a : {&x, &y, &z, &vx, &vy, &vz, &vex, &vey, &vez, &fx, &fy, &fz, &rho, &bvf})
      if (a->size() == n) f(*a);
    f(type);
    f(id);
    f(origin);
    if (left_to_grid.size() == n) f(left_to_grid);
  }

  // Whether this run needs StepView::left_to_grid, and the array sized (zeros) when it does.
  bool needs_left_to_grid() const {
    return solid.bounce && solid.enabled() && walls.wall_mask != 0;
  }
  // Whether the scene allows a buried part (StepView::buried_part): the solid grid's bounce keeps
  // every mobile particle that starts a step in the pore there, and no rigid slab (which moves
  // without the bounce) exists. The engines add the run's own conditions (the option, the frozen
  // part, one rank) and that no mobile particle is in the solid now (solid_intrusion).
  bool may_bury() const { return solid.enabled() && solid.bounce && slabs.count == 0; }
  void size_left_to_grid() {
    if (needs_left_to_grid()) left_to_grid.assign(x.size(), 0);
  }

  // Raw-pointer view of the host arrays for the kernel bodies.
  StepView<Real> view() {
    StepView<Real> v;
    v.n = size();
    v.x = x.data(), v.y = y.data(), v.z = z.data();
    v.vx = vx.data(), v.vy = vy.data(), v.vz = vz.data();
    // Null without a thermostat (an empty vector's data() need not be null).
    v.vex = vex.empty() ? nullptr : vex.data();
    v.vey = vey.empty() ? nullptr : vey.data();
    v.vez = vez.empty() ? nullptr : vez.data();
    v.fx = fx.data(), v.fy = fy.data(), v.fz = fz.data();
    v.rho = rho.data();
    v.bvf = bvf.empty() ? nullptr : bvf.data();
    v.left_to_grid = left_to_grid.empty() ? nullptr : left_to_grid.data();
    v.walls = walls;
    v.walls.kappa = kappa.empty() ? nullptr : kappa.data();
    v.type = type.data();
    v.id = id.data();
    v.origin = origin.data();
    v.has_ghosts = has_ghosts;
    v.stale_cells = reorder_every > 1;
    v.cell_start = cell_start.data();
    v.box = box;
    v.grid = grid;
    v.table = table.data();
    v.ntypes = ntypes;
    v.body_force = body_force.data();
    v.frozen_mask = frozen_mask;
    v.virtual_walls = virtual_walls;
    v.solid = solid;
    v.slabs = slabs;
    v.slabs.half_velocity = slab_half_velocity.data();
    v.slabs.velocity = slab_velocity.data();
    v.body_force_axis = body_force_axis;
    v.body_force_midplane = body_force_midplane;
    v.rd = rd;
    v.dt = dt;
    v.inv_sqrt_dt = Real(1) / static_cast<Real>(std::sqrt(static_cast<double>(dt)));
    v.lambda = lambda;
    v.seed = seed;
    v.step = step;
    return v;
  }
};

// Sums over particles of the per-particle virial halves (see virial_of_particle).
struct VirialSums {
  double kinetic[6] = {0, 0, 0, 0, 0, 0};  // sum m v^a v^b of the thermal particles in the region
  double conservative[6] = {0, 0, 0, 0, 0, 0};
  double dissipative[6] = {0, 0, 0, 0, 0, 0};
  double random[6] = {0, 0, 0, 0, 0, 0};
};

// A backend: advances the state by whole steps and answers the reductions observables need.
template <class Real>
class Engine {
 public:
  virtual ~Engine() = default;
  virtual const char* name() const = 0;
  // Takes the host state as the initial condition and computes the forces of step `host.step`.
  // `hooks` are called between the phases of every step (sim/domain/exchange.h; SerialHooks on
  // one rank, sim/stepper.h) and the engine's storage is the DomainStore they work on.
  virtual void initialize(HostState<Real>& host, StepHooks<Real>& hooks) = 0;
  // Takes a saved host state (cell-sorted, with the forces, densities and slab forces of step
  // `host.step` already in it) and continues from it: builds the cell list, computes nothing.
  // A decomposed run's saved state holds this rank's own particles and no ghosts (the first
  // step's exchange brings them); `hooks` as for initialize.
  virtual void restore(HostState<Real>& host, std::uint64_t wall_corrections,
                       StepHooks<Real>& hooks) = 0;
  virtual void advance(std::uint64_t steps) = 0;
  virtual void set_dt(Real dt) = 0;
  // Brings host positions, velocities, forces and densities up to date.
  virtual void download(HostState<Real>& host) = 0;
  // Virial of the current configuration, with the same v~ and random numbers the last force pass
  // used (the pair RNG is keyed by step, so nothing needs storing).
  // `region` restricts the sum to the particles of some types inside a box (region pressure).
  virtual VirialSums virial(const VirialRegion<Real>& region = {}) = 0;
  // The leak invariant over this rank's mobile particles (kernels.h thermal), where they are (not
  // available without a solid grid).
  virtual SolidIntrusion solid_intrusion() = 0;
  // The rigid slabs' bodies, and per slab the sum of this rank's slab particles' coordinates
  // along its axis (kernels.h slab_coordinate_of).
  virtual std::vector<RigidSlabBody> slab_bodies(std::vector<double>& coordinate_sums) = 0;
  // Per-bin sums (kBinFields per bin, see observables.h) over the current configuration.
  virtual void bin_sums(const BinGrid& grid, std::vector<double>& sums) = 0;
  virtual std::uint64_t step() const = 0;
  // Fluid particles put back out of a wall by the wall model so far (0 without it).
  virtual std::uint64_t wall_corrections() const { return 0; }
  // Neighbours within rc of each stored particle (0 for ghosts), over the cell list of the last
  // force pass: the load-balance cost measure of a decomposed run.
  virtual void neighbour_counts(std::vector<int>& counts) = 0;
  // Per injection/ejection boundary: particles moved and events without a candidate.
  virtual std::vector<InjectionCounts> injection_counts() const { return {}; }
  // Bytes of device memory this engine holds (0 on the CPU).
  virtual std::size_t device_bytes() const { return 0; }
  // Per-pass times when profiling was asked for ("" otherwise).
  virtual std::string profile_report() const { return ""; }
  // Steps run through a CUDA graph so far (SimulationOptions::graphs; 0 on the CPU).
  virtual std::uint64_t graph_steps() const { return 0; }
  // Frozen particles in the buried part (StepView::buried_part) since the last full sort.
  virtual std::uint64_t buried_particles() const { return 0; }
  // The numerical watchdog (sim/watchdog.h), checked after every step while enabled.
  virtual void set_watchdog(const WatchdogOptions& o) { watchdog_ = o; }
  // Set-up only (SimulationOptions::interrupt_check): set around initialize/restore, then cleared;
  // the engine calls it between its passes and may throw through them.
  void set_interrupt_check(std::function<void()> check) { interrupt_check_ = std::move(check); }

 protected:
  WatchdogOptions watchdog_;
  std::function<void()> interrupt_check_;
};

}  // namespace mesorock::sim
