#pragma once
// The solver's public face: a Simulation built from a Model, a BoxSpec and a ParticleSet, run on
// a chosen backend in the model's precision. pipeline/ and tests use only this header.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/domain/decomposition.h"
#include "sim/model.h"
#include "sim/observables.h"
#include "sim/watchdog.h"

namespace mesorock::sim {

class Communicator;

enum class BackendKind { CPU, CUDA };
inline const char* to_string(BackendKind b) {
  return b == BackendKind::CPU ? "cpu" : "cuda";
}

// lanes_per_particle = 0 takes 8 lanes up to kEightLanesUpTo particles, 4 up to kFourLanesUpTo,
// 2 up to kTwoLanesUpTo and 1 above: about where one thread per particle fills the H200's 132
// SMs (docs/benchmarks.md, 2026-12-04). sim/ensemble.h counts the members together.
inline constexpr int kEightLanesUpTo = 32768, kFourLanesUpTo = 100000, kTwoLanesUpTo = 250000;

struct SimulationOptions {
  BackendKind backend = BackendKind::CPU;
  int threads = 0;       // CPU backend: OpenMP threads; <= 0 means OpenMP's default
  int device = 0;        // CUDA backend: device ordinal
  bool profile = false;  // CUDA backend: time each pass with events (synchronises every step)
  // Frozen particles stored apart from the mobile ones, sorted once, their sums over frozen
  // neighbours kept (ARCHITECTURE.md; the CPU in a run on one rank). Off only to measure what that
  // saves (`rockflow bench --frozen-part off`); the physics is the same, the order of sums differs.
  bool frozen_part = true;
  // With the frozen part and the solid grid's bounce: frozen particles farther than rc from every
  // pore voxel kept out of every step's passes (StepView::buried_part). Off only to measure what
  // that saves (`rockflow bench --buried-part off`); the order of the frozen particles' static
  // sums differs, nothing else.
  bool buried_part = true;
  // CUDA backend, wall model with the frozen part: the corrector before the sort computes phi
  // only where the frozen part may put it past phi_c (StepView::penetration, a bit per cell of
  // rc / 8 or more). Every bit of the result is the same; off only to measure what it saves
  // (`rockflow bench --penetration-mask off`).
  bool penetration_mask = true;
  // CUDA backend, with the buried part: the density pass sums only the frozen particles within rd
  // of a pore voxel (a list made at the full sort); the others, which no mobile particle can come
  // within rd of, keep their static sums. Every bit of the result is the same; off only to
  // measure what it saves (`rockflow bench --frozen-density-list off`).
  bool frozen_density_list = true;
  // CUDA backend: runs of steps captured once as a CUDA graph and replayed (ARCHITECTURE.md), so
  // a small system is not bound by kernel launches. Every bit of the result is the same; off only
  // to measure what it saves (`rockflow bench --graphs off`). Runs with a reorder interval,
  // injection, decomposition or profiling step without graphs.
  bool graphs = true;
  // CUDA backend: threads that share each particle's neighbour scan in the density and force
  // passes, 1, 2, 4 or 8; 0 chooses by the particle count (more threads for a small system, which
  // one thread per particle leaves mostly idle). Changes the order of the sums (results at
  // round-off), not the physics.
  int lanes_per_particle = 0;
  // Cell-list resolution: cells of rc / cells_per_cutoff, scanned cells_per_cutoff deep. Changes
  // speed and the order of force sums (so results at round-off), not the physics. 1 measured
  // fastest on the GPU (docs/benchmarks.md); the CPU is indifferent.
  int cells_per_cutoff = 1;
  // Reorder interval and skin (a Verlet-style cell list): the storage is re-sorted by cell only
  // every `reorder_every` steps, over cells of (rc + skin) / cells_per_cutoff, and sooner when a
  // particle has moved more than skin / 2 since the last sort (checked every step), so no pair
  // within rc is missed. 1 and 0: sort every step over cells of rc (the default). Changes the
  // order of force sums (results at round-off), not the physics; speed is in docs/accuracy.md.
  int reorder_every = 1;
  double skin = 0;
  // Ranks of a domain decomposition (sim/domain): a communicator of more than one rank makes a
  // decomposed run; null or one rank runs the plain single-rank solver.
  std::shared_ptr<Communicator> comm;
  DecompositionOptions decomposition;
  // Stops a run that blows up (NaN, infinity, runaway velocity) with a NumericalError naming the
  // step, particle and quantity (sim/watchdog.h). On by default.
  WatchdogOptions watchdog;
  // Called after every Simulation::run with the steps just taken and the particle count (for
  // progress meters; empty = nothing is called).
  std::function<void(std::uint64_t steps, std::size_t particles)> on_run;
  // Called between the phases of make_simulation / resume_simulation (inputs checked, state
  // built, cell sort, density pass, force pass) and, in the CPU engine's first passes, after
  // every 2^18 particles; it throws to abandon the set-up (rockflow run: Interrupted on Ctrl-C,
  // which took 37 s to act during the set-up of 4 M particles). Never called once set-up is done.
  std::function<void()> interrupt_check;
};

struct SimulationState;  // sim/checkpoint.h

// Stress tensor parts in Voigt order xx yy zz xy xz yz; sigma = (kinetic + virial) / V, with the
// sign convention of pressure (positive = pushes outwards), so p = (xx + yy + zz) / 3.
struct StressSample {
  std::array<double, 6> kinetic{}, conservative{}, dissipative{}, random{};
  double volume = 1;
  std::array<double, 6> total() const {
    std::array<double, 6> t{};
    for (int c = 0; c < 6; ++c) t[c] = kinetic[c] + conservative[c] + dissipative[c] + random[c];
    return t;
  }
  // Pressure from the kinetic and conservative parts (Groot & Warren's definition, used by the
  // equation-of-state validation). The dissipative and random parts average to O(dt) terms.
  double pressure_conservative() const {
    return (kinetic[0] + kinetic[1] + kinetic[2] + conservative[0] + conservative[1] +
            conservative[2]) /
           3.0;
  }
  double pressure() const {
    const auto t = total();
    return (t[0] + t[1] + t[2]) / 3.0;
  }
};

// One rigid slab now: its type, axis, mean position of its particles along the axis, velocity,
// total force along the axis (pair forces + the applied P A) and the applied part alone.
struct RigidSlabState {
  std::string type;
  int axis = 0;
  double position = 0, velocity = 0, force = 0, applied_force = 0, mass = 0;
};

// The particles a region's stress covers: the given types inside the box [lo, hi).
struct RegionSelection {
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  std::uint32_t type_mask = ~0u;
};

class Simulation {
 public:
  virtual ~Simulation() = default;

  virtual void run(std::uint64_t steps) = 0;
  virtual void set_dt(double dt) = 0;
  virtual double dt() const = 0;
  virtual std::uint64_t step() const = 0;
  virtual size_t size() const = 0;

  // Copies of the current particle data (double precision), synced from the backend.
  virtual ParticleSet particles() = 0;
  virtual std::vector<double> densities() = 0;  // rho_i of the last force pass (0 without mDPD)
  // The wall model's boundary volume fraction phi_i of the last force pass (empty without it).
  virtual std::vector<double> boundary_volume_fractions() = 0;
  // Fluid particles the wall model has put back out of a wall since the start (0 without it).
  virtual std::uint64_t wall_corrections() const = 0;
  // The rigid slabs (pistons) now, in the order of Model::rigid_slabs (empty without slabs).
  virtual std::vector<RigidSlabState> rigid_slabs() = 0;
  // Forces of the last force pass (pair terms + body force; zero on frozen particles).
  virtual std::array<std::vector<double>, 3> forces() = 0;

  // Reductions over mobile particles.
  virtual double kinetic_temperature() = 0;      // sum m v^2 / (3 N_mobile)
  virtual std::array<double, 3> momentum() = 0;  // total momentum of mobile particles
  virtual StressSample stress() = 0;             // kinetic + pair virials, per volume
  // The stress of a region: the kinetic terms of its mobile particles of the selected types and
  // half of each of their pair virials, over the region's volume (the per-particle convention
  // of LAMMPS compute stress/atom). For a region of bulk fluid it agrees with stress().
  virtual StressSample region_stress(const RegionSelection& region) = 0;
  // Per injection/ejection boundary (Model::injections): particles moved so far and events that
  // found no candidate in the outlet box.
  virtual std::vector<InjectionCounts> injections() = 0;
  // The leak invariant now (available = false without a solid grid).
  virtual SolidIntrusion solid_intrusion() = 0;
  // Per-bin sums over the current configuration (kBinFields per bin: count, sum v, sum v*v), for
  // profiles and fields; average them with BinnedAverage. Computed where the particles live (on
  // the device for CUDA); only the bins cross to the host.
  virtual std::vector<double> bin_sums(const BinGrid& grid) = 0;

  virtual const Model& model() const = 0;
  virtual const BoxSpec& box() const = 0;
  virtual std::string backend_name() const = 0;
  virtual std::string pass_name() const = 0;     // the compiled term set this run uses
  virtual std::size_t device_bytes() const = 0;  // device memory held by the backend
  virtual std::string profile_report() const = 0;
  // Steps run as replays or captures of a CUDA graph (SimulationOptions::graphs; 0 on the CPU).
  virtual std::uint64_t graph_steps() const = 0;
  // Frozen particles kept out of the steps at the last full sort (SimulationOptions::buried_part).
  virtual std::uint64_t buried_particles() const = 0;

  // A decomposed run: this rank, the ranks, and each rank's cost now (the load-balance measure:
  // sum over its particles of neighbours x (1 for a frozen particle, 4.5 for a mobile one: the
  // density pass, plus the force pass at about 3.5 times its cost). Single rank: 0, 1, {}.
  virtual int rank() const { return 0; }
  virtual int ranks() const { return 1; }
  virtual std::vector<double> rank_costs() { return {}; }
  virtual std::string decomposition_report() const { return ""; }
  // Everything needed to continue this run bit for bit (sim/checkpoint.h): the particles in the
  // engine's cell-sorted storage order, the last forces, step, dt, slab bodies, wall corrections.
  // A decomposed run gathers every rank's particles in the original order (collective): that
  // continues the same physics on any number of ranks, though not bit for bit.
  virtual SimulationState state() = 0;
};

// Validates the inputs (ConfigError with the reason) and builds the simulation. Initial forces are
// computed for step 0. Asking for CUDA without a CUDA build or device throws DeviceError.
std::unique_ptr<Simulation> make_simulation(const Model& model, const BoxSpec& box,
                                            const ParticleSet& particles, double dt,
                                            const SimulationOptions& options = {});

// Continues a run from Simulation::state() of the same model and box: the next run() computes
// what the interrupted simulation would have computed (bit for bit on the same backend; on the
// CPU whatever the thread count). Throws ConfigError when the state does not fit the model. With
// a communicator of several ranks it resumes decomposed, from a state saved on any number of
// ranks (the same physics; the order of force sums differs, so not bit for bit).
std::unique_ptr<Simulation> resume_simulation(const Model& model, const BoxSpec& box,
                                              const SimulationState& state,
                                              const SimulationOptions& options = {});

// Whether this build has the CUDA backend and a usable device ("" if yes, else the reason).
std::string cuda_unavailable_reason();

}  // namespace mesorock::sim
