#pragma once
// The kernel bodies of one step, shared by the CPU backend (OpenMP loops) and the CUDA backend
// (one thread per particle). The per-particle bodies write only that particle's outputs; the
// pair passes also have a Newton form (each pair once, added to both particles) that the CPU runs
// over its half list (sim/half_list.h), whose scheduling keeps threads apart: no atomics either
// way.
//
// Step (velocity Verlet, DPD variant of Groot & Warren 1997 with lambda; the 2020 paper's
// Algorithm 1):
//   kick_drift:  v <- v + dt/2 f;  v~ <- v_old + lambda dt f;  x <- x + dt v;  boundaries
//   density:     rho_i = sum_j w(r_ij)            (only with a many-body term)
//                and the boundary volume fraction phi_i (only with the wall model)
//   correction:  fluid particles that entered a wall are put back (only with the wall model)
//   forces:      f_i = sum_j F_ij(x, v~, rho) + g_type
//   kick:        v <- v + dt/2 f
// lambda = 0.5 makes v~ the half-step velocity: plain velocity Verlet.
#include <cstdint>
#include <type_traits>

#include "sim/box.h"
#include "sim/cell_grid.h"
#include "sim/hd.h"
#include "sim/injection.h"
#include "sim/observables.h"
#include "sim/pair_terms.h"
#include "sim/penetration_mask.h"
#include "sim/rigid_slabs.h"
#include "sim/rng.h"
#include "sim/solid_grid.h"
#include "sim/wall_model.h"

namespace mesorock::sim {

// Everything a pass reads or writes, as raw pointers: valid for host or device memory alike.
template <class Real>
struct StepView {
  int n = 0;
  Real *x = nullptr, *y = nullptr, *z = nullptr;
  Real *vx = nullptr, *vy = nullptr, *vz = nullptr;
  // Velocity estimate v~ for the dissipative force; absent (null) without a thermostat.
  Real *vex = nullptr, *vey = nullptr, *vez = nullptr;
  Real *fx = nullptr, *fy = nullptr, *fz = nullptr;
  Real* rho = nullptr;
  Real* bvf = nullptr;  // boundary volume fraction phi (wall model only; 0 for wall particles)
  const std::int32_t* type = nullptr;
  const std::int64_t* id = nullptr;
  // With a domain decomposition (sim/domain), origin < 0 marks a ghost: another rank's particle,
  // read by the pair terms, never moved, its force never computed. has_ghosts is false otherwise,
  // so a single-rank run never loads origin.
  const std::int32_t* origin = nullptr;
  bool has_ghosts = false;
  // The cell list may be up to skin / 2 of motion old (a reorder interval above 1): a particle
  // may have crossed a periodic face since it was filed in its cell, so every separation is taken
  // as the minimum image instead of through the cell's shift.
  bool stale_cells = false;

  // Cell list: particles are stored sorted by cell; cell c holds [cell_start[c], cell_start[c+1]).
  // With frozen_part > 0 (the GPU, in a scene with frozen types) the storage holds the mobile
  // particles first and the frozen ones after them, each part sorted by cell: cell c's frozen
  // particles are [cell_start[frozen_part + c], cell_start[frozen_part + c + 1]), frozen_part
  // being the cell count. Why: a warp then holds mobile or frozen particles, not both, so the
  // passes that skip frozen particles skip whole warps.
  //
  // With a buried part as well (buried_part): the frozen particles farther than rc from every
  // pore voxel of the solid grid, which no mobile particle can reach while the grid's bounce
  // keeps the mobile ones in the pore, stand behind the frozen part in a third part of their own,
  // cell c's at [cell_start[2 frozen_part + c], cell_start[2 frozen_part + c + 1]). Only the
  // frozen particles' static sums scan it (Parts::FrozenAndBuried): a step's passes never see it.
  const int* cell_start = nullptr;
  int frozen_part = 0;
  bool buried_part = false;
  // With a frozen part, the sums of each frozen particle over its frozen neighbours, which hold
  // while the frozen particles stay what they are (the k-th frozen particle's at k; frozen_rho
  // with a density, frozen_bvf with the wall model). A pass then sums only a frozen particle's
  // mobile neighbours. Null: everything is summed every time.
  const Real* frozen_rho = nullptr;
  const Real* frozen_bvf = nullptr;

  Box<Real> box;
  CellGrid<Real> grid;

  const PairParams<Real>* table = nullptr;  // ntypes x ntypes, symmetric
  int ntypes = 0;
  const Real* body_force = nullptr;  // ntypes x 3
  int body_force_axis = 2;           // profile axis of a position-dependent body force
  Real body_force_midplane = 0;      // its sign changes here (ReversedBodyForce)
  std::uint32_t frozen_mask = 0;     // bit t set: type t never moves
  WallModelView<Real> walls;         // read only by the wall-model pass variants
  VirtualWalls<Real> virtual_walls;  // planes that keep some types on one side until a step
  SolidView<Real> solid;             // the solid as voxels (sim/solid_grid.h); often none
  // With the solid grid's bounce and the wall model both on: 1 for a particle the wall model's
  // corrector leaves to the grid in this step, else 0 (kick_drift writes it, the corrector reads
  // it, a sort moves it): one the bounce turned in this step's drift, which a second turn would
  // turn back (a particle in a pocket it could not leave then gained speed every step), and one
  // that started the step inside the wall (phi > phi_c), which the corrector would turn at every
  // step while a push gains on the steps it does not (a fluid cluster in a tight pore was thrown
  // out at 100 rc per time unit). The grid keeps both out of the solid. docs/walls.md, "One turn
  // per step". Null otherwise.
  std::uint8_t* left_to_grid = nullptr;
  // Where the frozen part alone may put a mobile particle inside the wall (phi > phi_c): the
  // GPU's corrector before the sort scans only there (sim/penetration_mask.h). Set only while
  // the frozen part's sums hold; none elsewhere (every particle is scanned).
  PenetrationMask<Real> penetration;
  RigidSlabs<Real> slabs;  // pistons moving as rigid bodies (sim/rigid_slabs.h)

  Real rd = Real(0.75);
  Real dt = Real(0.01);
  Real inv_sqrt_dt = Real(10);
  Real lambda = Real(0.5);
  std::uint64_t seed = 0;
  std::uint64_t step = 0;  // the step whose forces are being computed (keys the pair RNG)
  // A step captured in a CUDA graph (sim/cuda) reads its number as *step_base + step, so that one
  // graph serves every replay; null elsewhere. Read it through current_step(). (A kernel that
  // wrote the resolved step into its StepView parameter made the compiler copy the whole view to
  // local memory: every pass 20% slower.)
  const std::uint64_t* step_base = nullptr;

  MESO_HD std::uint64_t current_step() const { return step_base ? *step_base + step : step; }
  MESO_HD bool frozen(int i) const { return (frozen_mask >> type[i]) & 1u; }
  // With a frozen part: stored particle i's place among the frozen ones (frozen_rho's index).
  MESO_HD int frozen_index(int i) const { return i - cell_start[frozen_part]; }
  MESO_HD bool ghost(int i) const { return has_ghosts && origin[i] < 0; }
  MESO_HD bool left_to_grid_at(int i) const { return left_to_grid && left_to_grid[i]; }
};

// Calls visit(j, dx, dy, dz, r2) for every particle j in the cell stencil around particle i's
// cell (i itself included), in storage order within each row of cells along x. Periodic images
// come from per-cell shifts (no per-pair branch) except on axes too short for the stencil, where
// minimum_image decides per pair. Either way dx_ij = -dx_ji exactly.
// Parts (see StepView::frozen_part): 0 the mobile particles, 1 the frozen ones, 2 the buried ones
// (StepView::buried_part). All: the mobile and frozen parts, every particle a step can meet (with
// neither part, all particles); FrozenAndBuried: every frozen particle (the static sums).
enum class Parts : int { All = 0, MobileOnly = 1, FrozenOnly = 2, FrozenAndBuried = 3 };

// The threads that share one particle's scan in the GPU's gather passes (sim/cuda: LaneGroup):
// lane k of kCount takes the k-th, (k + kCount)-th, ... candidate of each run of cells, the
// bodies add their partial sums with sum() and the leader writes. Why: a small system has too
// few particles to fill the GPU with one thread each. OneLane, the default (the CPU, the other
// passes, large systems), is the scan unchanged: every sum in the order it always had.
//
// A lane group may also keep the neighbours its scans find (the GPU's neighbour list for small
// systems): record(j) is called for each neighbour j of the density pass, in scan order, and a
// group with kReplays visits those instead of scanning again in the force pass (sim/cuda:
// RecordingLanes, ReplayingLanes). OneLane keeps nothing: record compiles to nothing.
struct OneLane {
  static constexpr int kCount = 1;
  static constexpr bool kReplays = false;
  MESO_HD int index() const { return 0; }
  MESO_HD bool leader() const { return true; }
  MESO_HD void record(int) const {}
  template <class T>
  MESO_HD T sum(T x) const {
    return x;
  }
};

template <class Real, class Visit, class Lanes = OneLane>
MESO_HD MESO_INLINE void for_each_candidate(const StepView<Real>& v, int i, Visit&& visit,
                                            Parts parts = Parts::All,
                                            const Lanes& lanes = Lanes{}) {
  const Real xi = v.x[i], yi = v.y[i], zi = v.z[i];
  const CellGrid<Real>& g = v.grid;
  const int cx = g.coordinate(xi, v.box.lo[0], 0);
  const int cy = g.coordinate(yi, v.box.lo[1], 1);
  const int cz = g.coordinate(zi, v.box.lo[2], 2);
  const auto rx = g.axis_range(cx, 0, v.box.periodic[0]);
  const auto ry = g.axis_range(cy, 1, v.box.periodic[1]);
  const auto rz = g.axis_range(cz, 2, v.box.periodic[2]);
  const int nx = g.dims[0];
  // The x stencil splits into at most three runs of consecutive cells: below 0 (wrapped, shift
  // -L), inside, above n - 1 (wrapped, shift +L). Each run's particles are contiguous.
  const int x_first[3] = {rx.begin + nx, rx.begin < 0 ? 0 : rx.begin, 0};
  const int x_last[3] = {nx, rx.end > nx ? nx : rx.end, rx.end - nx};
  const Real x_shift[3] = {-v.box.length[0], Real(0), v.box.length[0]};
  // Mobile, then frozen (see StepView); without a frozen part, one part of everything.
  const bool frozen_only = parts == Parts::FrozenOnly || parts == Parts::FrozenAndBuried;
  const int first_part = frozen_only && v.frozen_part > 0 ? 1 : 0;
  const int last_part = v.frozen_part == 0 || parts == Parts::MobileOnly
                            ? 1
                            : (parts == Parts::FrozenAndBuried && v.buried_part ? 3 : 2);
  for (int kz = rz.begin; kz < rz.end; ++kz) {
    Real sz;
    const int wz = g.wrap(kz, 2, v.box.length[2], sz);
    for (int ky = ry.begin; ky < ry.end; ++ky) {
      Real sy;
      const int wy = g.wrap(ky, 1, v.box.length[1], sy);
      const int row = g.index(0, wy, wz);
      MESO_UNROLL
      for (int run = 0; run < 3; ++run) {
        if (x_first[run] >= x_last[run]) continue;
        const Real sx = x_shift[run];
        for (int part = first_part; part < last_part; ++part) {
          const int base = row + part * v.frozen_part;
          const int end = v.cell_start[base + x_last[run]];
          for (int j = v.cell_start[base + x_first[run]] + lanes.index(); j < end;
               j += Lanes::kCount) {
            Real dx = (xi - v.x[j]) - sx;
            Real dy = (yi - v.y[j]) - sy;
            Real dz = (zi - v.z[j]) - sz;
            if (rx.all || v.stale_cells) dx = v.box.minimum_image(dx, 0);
            if (ry.all || v.stale_cells) dy = v.box.minimum_image(dy, 1);
            if (rz.all || v.stale_cells) dz = v.box.minimum_image(dz, 2);
            visit(j, dx, dy, dz, dx * dx + dy * dy + dz * dz);
          }
        }
      }
    }
  }
}

// The cell particle i's position falls in (the cell sort's key).
template <class Real>
MESO_HD MESO_INLINE int cell_of(const StepView<Real>& v, int i) {
  const CellGrid<Real>& g = v.grid;
  return g.index(g.coordinate(v.x[i], v.box.lo[0], 0), g.coordinate(v.y[i], v.box.lo[1], 1),
                 g.coordinate(v.z[i], v.box.lo[2], 2));
}

// Squared displacement of particle i since the positions x0 of the last sort (minimum image: a
// particle may have crossed a periodic face).
template <class Real>
MESO_HD MESO_INLINE Real displacement2(const StepView<Real>& v, const Real* x0, const Real* y0,
                                       const Real* z0, int i) {
  const Real dx = v.box.minimum_image(v.x[i] - x0[i], 0);
  const Real dy = v.box.minimum_image(v.y[i] - y0[i], 1);
  const Real dz = v.box.minimum_image(v.z[i] - z0[i], 2);
  return dx * dx + dy * dy + dz * dz;
}

// Calls visit(j, dx, dy, dz, r2) for every particle j != i within the cutoff rc = 1 (this lane's
// share of them).
template <class Real, class Visit, class Lanes = OneLane>
MESO_HD MESO_INLINE void for_each_neighbour(const StepView<Real>& v, int i, Visit&& visit,
                                            Parts parts = Parts::All,
                                            const Lanes& lanes = Lanes{}) {
  for_each_candidate(
      v, i,
      [&](int j, Real dx, Real dy, Real dz, Real r2) {
        if (r2 < Real(1) && j != i) {
          lanes.record(j);
          visit(j, dx, dy, dz, r2);
        }
      },
      parts, lanes);
}

// A per-thread list of the neighbour indices a scan found, visited after the scan. Why: on the
// GPU a warp executes the pair body whenever any of its 32 lanes has a neighbour, so a scan that
// calls the body in place pays for about 190 candidates per particle instead of its 29
// neighbours. Collecting first and visiting afterwards runs the body once per neighbour with the
// lanes in step. The slots live in shared memory (slot k of a thread at slot[k * stride]). The
// visiting order is the scan order, so the sums are those of the in-place scan (an empty stash).
// (MESOROCK_NO_NEIGHBOUR_STASH builds the GPU without it, for the side-by-side benchmark in
// docs/benchmarks.md.)
struct NeighbourStash {
  static constexpr int kCapacity = 48;  // about 1.6x the neighbours of a liquid at rho = 7
  int* slot = nullptr;
  int stride = 1;
  MESO_HD MESO_INLINE int& operator[](int k) const { return slot[k * stride]; }
};

// Calls visit(j, dx, dy, dz, r2) for every particle j != i within rc = 1, in the order
// for_each_neighbour visits them, through the stash: the scan only stores indices; separations are
// recomputed for the stored ones. The recomputation is the minimum image on periodic axes, which
// gives the same bits as the cell shifts of the scan: on an axis the stencil does not cover whole
// (2 reach + 1 cells or more, so an edge above 2 rc), a neighbour within rc differs from its raw
// separation by exactly 0 or +-L, and the raw separation is then below L/2 or beyond it.
template <class Real, class Visit, class Lanes = OneLane>
MESO_HD MESO_INLINE void for_each_neighbour_stashed(const StepView<Real>& v, int i,
                                                    const NeighbourStash& stash, Visit&& visit,
                                                    const Lanes& lanes = Lanes{}) {
#if !defined(__CUDA_ARCH__) || defined(MESOROCK_NO_NEIGHBOUR_STASH)
  // The CPU visits in place: its branch predictor copes with the scan, and the stash measured
  // slower there (bulk, 200,000 particles, one thread: 0.318 MPS/s with it, 0.377 without).
  (void)stash;
  for_each_neighbour(v, i, visit, Parts::All, lanes);
#else
  const Real xi = v.x[i], yi = v.y[i], zi = v.z[i];
  auto visit_stored = [&](int j) {
    const Real dx = v.box.minimum_image(xi - v.x[j], 0);
    const Real dy = v.box.minimum_image(yi - v.y[j], 1);
    const Real dz = v.box.minimum_image(zi - v.z[j], 2);
    visit(j, dx, dy, dz, dx * dx + dy * dy + dz * dz);
  };
  if constexpr (Lanes::kReplays) {
    // This lane's neighbours as the density pass found them, in its scan order: the same visits
    // as the scan, without it. A lane that found more than its list holds scans in place (the
    // scan order too; the replaying kernels have no stash).
    const int recorded = lanes.recorded_count();
    if (recorded > Lanes::kListCapacity) {
      for_each_neighbour(v, i, visit, Parts::All, lanes);
      return;
    }
    for (int k = 0; k < recorded; ++k) visit_stored(lanes.recorded(k));
    return;
  }
  int count = 0;
  auto flush = [&]() {
    for (int k = 0; k < count; ++k) visit_stored(stash[k]);
    count = 0;
  };
  for_each_candidate(
      v, i,
      [&](int j, Real, Real, Real, Real r2) {
        // Store unconditionally, keep it only when it is a neighbour: no branch in the scan.
        stash[count] = j;
        count += (r2 < Real(1)) & (j != i);
        if (count == NeighbourStash::kCapacity) flush();
      },
      Parts::All, lanes);
  flush();
#endif
}

// Below this separation the pair direction is undefined: coincident particles exert no force on
// each other (finite, not NaN). The conservative force is bounded, so this loses nothing physical.
template <class Real>
MESO_HD MESO_INLINE constexpr Real coincident_r2() {
  return Real(1e-20);
}

// ---------------------------------------------------------------------------------------------
// Density pass: rho_i = sum_{j != i} w(r_ij). Frozen particles need it too (their rho enters the
// many-body force on the fluid). With the frozen particles' static sums (StepView::frozen_rho),
// a frozen particle adds only its mobile neighbours to them.
template <class Real, class DensityKernel, class Lanes = OneLane>
MESO_HD MESO_INLINE void add_density(const StepView<Real>& v, int i, Parts parts, Real& rho,
                                     const Lanes& lanes = Lanes{}) {
  // In place, not stashed: this body is cheap, and the stash measured slower here (H200, porous
  // 16 M: 7.8 ms per pass with it, 6.7 without; docs/benchmarks.md).
  const Real rd = v.rd;
  const Real rd2 = rd * rd;
  for_each_neighbour(
      v, i,
      [&](int, Real, Real, Real, Real r2) {
        if (r2 < rd2) rho += DensityKernel::weight(real_sqrt(r2), rd);
      },
      parts, lanes);
}

// (Lanes: see OneLane. The kept sums start the leader's share, so they count once.)
template <class Real, class DensityKernel, class Lanes = OneLane>
MESO_HD MESO_INLINE void density_of_particle(const StepView<Real>& v, int i,
                                             const Lanes& lanes = Lanes{}) {
  if (v.ghost(i)) return;  // a ghost's density comes from its owner
  Real rho = 0;
  Parts parts = Parts::All;
  if (v.frozen_rho && v.frozen(i)) {
    if (lanes.leader()) rho = v.frozen_rho[v.frozen_index(i)];
    parts = Parts::MobileOnly;
  }
  add_density<Real, DensityKernel>(v, i, parts, rho, lanes);
  rho = lanes.sum(rho);
  if (lanes.leader()) v.rho[i] = rho;
}

// Density (when DensityKernel is not void) and the wall model's sum of particle i over the
// neighbours in `parts`, added to rho and wall:
//   phi_i = (1 / n_w) sum_{j in wall} W(r_ij),  W the Lucy kernel of support rc,
// for particles that are not wall themselves.
template <class Real, class DensityKernel, class Lanes = OneLane>
MESO_HD MESO_INLINE void add_density_and_wall(const StepView<Real>& v, int i, Parts parts,
                                              Real& rho, Real& wall, const Lanes& lanes = Lanes{}) {
  constexpr bool kDensity = !std::is_void<DensityKernel>::value;
  const Real rd = v.rd;
  const Real rd2 = rd * rd;
  const bool fluid = !v.walls.is_wall(v.type[i]);
  for_each_neighbour(
      v, i,
      [&](int j, Real, Real, Real, Real r2) {
        const Real r = real_sqrt(r2);
        if constexpr (kDensity) {
          if (r2 < rd2) rho += DensityKernel::weight(r, rd);
        }
        if (fluid && v.walls.is_wall(v.type[j])) wall += bvf_weight(r);
      },
      parts, lanes);
}

// Density and the boundary volume fraction of the wall model (sim/wall_model.h) in one neighbour
// loop (phi = 0 for wall particles).
template <class Real, class DensityKernel, class Lanes = OneLane>
MESO_HD MESO_INLINE void density_and_bvf_of_particle(const StepView<Real>& v, int i,
                                                     const Lanes& lanes = Lanes{}) {
  constexpr bool kDensity = !std::is_void<DensityKernel>::value;
  if (v.ghost(i)) return;  // a ghost's sums come from its owner
  Real rho = 0, wall = 0;
  Parts parts = Parts::All;
  if (v.frozen_bvf && v.frozen(i)) {
    const int k = v.frozen_index(i);
    if (lanes.leader()) {
      if constexpr (kDensity) rho = v.frozen_rho[k];
      wall = v.frozen_bvf[k];
    }
    parts = Parts::MobileOnly;
  }
  add_density_and_wall<Real, DensityKernel>(v, i, parts, rho, wall, lanes);
  if constexpr (kDensity) rho = lanes.sum(rho);
  wall = lanes.sum(wall);
  if (!lanes.leader()) return;
  if constexpr (kDensity) v.rho[i] = rho;
  v.bvf[i] = v.walls.is_wall(v.type[i]) ? Real(0) : wall * v.walls.inv_wall_density;
}

// Whether particle i belongs in the buried part (StepView::buried_part): frozen, with no pore
// voxel within rc (and a margin of 1e-3 rc for the rounding at the voxel faces).
template <class Real>
MESO_HD MESO_INLINE bool buried(const StepView<Real>& v, int i) {
  return v.frozen(i) && !v.solid.pore_within(v.x[i], v.y[i], v.z[i], Real(1.001));
}

// The static sums of frozen particle i over its frozen neighbours (StepView::frozen_rho): rho
// and the unscaled wall sum, at k = i - the first frozen position.
template <class Real, class DensityKernel, bool kWalls>
MESO_HD MESO_INLINE void frozen_sums_of_particle(const StepView<Real>& v, int i, Real* rho_out,
                                                 Real* wall_out) {
  const int k = v.frozen_index(i);
  Real rho = 0, wall = 0;
  add_density_and_wall<Real, DensityKernel>(v, i, Parts::FrozenAndBuried, rho, wall);
  if constexpr (kWalls) wall_out[k] = wall;
  if constexpr (!std::is_void<DensityKernel>::value) rho_out[k] = rho;
}

// The wall model's phi of a particle that is not wall, over its neighbours in `parts`: the sum
// of density_and_bvf_of_particle without the density (the wall particles are all frozen, so the
// frozen part alone gives the same sum in the same order).
template <class Real>
MESO_HD MESO_INLINE Real wall_fraction(const StepView<Real>& v, int i, Parts parts) {
  Real rho = 0, wall = 0;
  add_density_and_wall<Real, void>(v, i, parts, rho, wall);
  return wall * v.walls.inv_wall_density;
}

// Word w of the penetration mask m (sim/penetration_mask.h) from the wall particles of the
// frozen part: bit k set where the bound of phi over the word's k-th cell (along x) passes
// phi_c - PenetrationMask::kPhiMargin. One word per thread: no atomics, the same bits every run.
// The cell-list cells that can hold a wall particle within rc of the word's cells are scanned,
// each with its image shift; a periodic axis shorter than the scan visits some cells twice, which
// only raises the bound.
template <class Real>
MESO_HD std::uint32_t penetration_mask_word(const StepView<Real>& v, const PenetrationMask<Real>& m,
                                            std::size_t w) {
  constexpr int K = PenetrationMask<Real>::kCellsPerWord;
  const Real margin = Real(PenetrationMask<Real>::kRoundingMargin);
  const std::size_t words_x = static_cast<std::size_t>(m.dims[0] / K);
  const int first_cell[3] = {static_cast<int>(w % words_x) * K,
                             static_cast<int>((w / words_x) % static_cast<std::size_t>(m.dims[1])),
                             static_cast<int>(w / words_x / static_cast<std::size_t>(m.dims[1]))};
  const int cells[3] = {K, 1, 1};
  Real lo[3], hi[3];  // the word's cells together, widened by the margin
  int first[3], last[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = m.lo[a] + Real(first_cell[a]) * m.cell[a] - margin;
    hi[a] = m.lo[a] + Real(first_cell[a] + cells[a]) * m.cell[a] + margin;
    auto floor_cell = [&](Real p) {
      const Real u = (p - v.box.lo[a]) * v.grid.inv_cell[a];
      const int k = static_cast<int>(u);
      return Real(k) > u ? k - 1 : k;
    };
    first[a] = floor_cell(lo[a] - Real(1));
    last[a] = floor_cell(hi[a] + Real(1));
    if (!v.box.periodic[a]) {  // positions beyond a wall face are filed in the edge cells
      first[a] = first[a] < 0 ? 0 : (first[a] >= v.grid.dims[a] ? v.grid.dims[a] - 1 : first[a]);
      last[a] = last[a] < 0 ? 0 : (last[a] >= v.grid.dims[a] ? v.grid.dims[a] - 1 : last[a]);
    }
  }
  Real sum[K];
  MESO_UNROLL
  for (int k = 0; k < K; ++k) sum[k] = Real(0);
  const int part = v.frozen_part > 0 ? v.frozen_part : 0;  // the frozen part, or everything
  // CellGrid::wrap covers one image each way; a short periodic axis needs more here.
  auto wrap = [&](int k, int a, Real& shift) {
    const int n = v.grid.dims[a];
    int q = k / n;
    if (q * n > k) --q;
    shift = Real(q) * v.box.length[a];
    return k - q * n;
  };
  auto outside = [](Real p, Real lo_edge, Real hi_edge) {
    return p < lo_edge ? lo_edge - p : (p > hi_edge ? p - hi_edge : Real(0));
  };
  for (int kz = first[2]; kz <= last[2]; ++kz) {
    Real sz;
    const int cz = wrap(kz, 2, sz);
    for (int ky = first[1]; ky <= last[1]; ++ky) {
      Real sy;
      const int cy = wrap(ky, 1, sy);
      for (int kx = first[0]; kx <= last[0]; ++kx) {
        Real sx;
        const int c = v.grid.index(wrap(kx, 0, sx), cy, cz);
        for (int j = v.cell_start[part + c]; j < v.cell_start[part + c + 1]; ++j) {
          if (!v.walls.is_wall(v.type[j])) continue;
          const Real dy = outside(v.y[j] + sy, lo[1], hi[1]);
          const Real dz = outside(v.z[j] + sz, lo[2], hi[2]);
          const Real r2_yz = dy * dy + dz * dz;
          if (!(r2_yz < Real(1))) continue;
          const Real xj = v.x[j] + sx;
          MESO_UNROLL
          for (int k = 0; k < K; ++k) {
            const Real cell_lo = lo[0] + Real(k) * m.cell[0];
            const Real dx = outside(xj, cell_lo, cell_lo + m.cell[0] + 2 * margin);
            const Real r2 = dx * dx + r2_yz;
            if (r2 < Real(1)) sum[k] += bvf_weight(real_sqrt(r2));
          }
        }
      }
    }
  }
  const Real threshold =
      (v.walls.phi_c - Real(PenetrationMask<Real>::kPhiMargin)) / v.walls.inv_wall_density;
  std::uint32_t bits = 0;
  MESO_UNROLL
  for (int k = 0; k < K; ++k)
    if (sum[k] > threshold) bits |= 1u << k;
  return bits;
}

// The corrector of the wall model for particle i after the drift (the predictor): a mobile
// non-wall particle with phi_i > phi_c is inside the wall. With n the wall-side normal (along
// -grad phi: sum_{j in wall} r (1 - r)^2 e_ij) its velocity v becomes
//   Li2018:   v' = -v + 2 max(0, v . n) n
//   Specular: v' = v - 2 min(0, v . n) n
// and its drift is redone from x(t): x += dt (v' - v). Writes dv = v' - v and returns true when
// the particle must be corrected; changes nothing itself, so that every particle's decision
// sees the same positions (the caller applies the changes). phi is particle i's phi at its
// predicted position; `parts`, where its wall neighbours are (the frozen part alone, on the GPU
// before the mobile part is sorted again).
template <class Real>
MESO_HD MESO_INLINE bool penetration_correction(const StepView<Real>& v, int i, Real phi,
                                                Real dv[3], Parts parts = Parts::All) {
  if (v.frozen(i) || v.ghost(i) || v.walls.is_wall(v.type[i]) || v.slabs.is_slab(v.type[i]) ||
      !(phi > v.walls.phi_c) || v.left_to_grid_at(i))
    return false;
  Real nx = 0, ny = 0, nz = 0;
  for_each_neighbour(
      v, i,
      [&](int j, Real dx, Real dy, Real dz, Real r2) {
        if (!v.walls.is_wall(v.type[j]) || r2 < coincident_r2<Real>()) return;
        const Real r = real_sqrt(r2);
        const Real w = bvf_normal_weight(r) / r;  // times the unit vector d / r
        nx += w * dx;
        ny += w * dy;
        nz += w * dz;
      },
      parts);
  const Real norm2 = nx * nx + ny * ny + nz * nz;
  if (!(norm2 > Real(0))) return false;
  const Real inv = Real(1) / real_sqrt(norm2);
  nx *= inv;
  ny *= inv;
  nz *= inv;
  const Real vn = v.vx[i] * nx + v.vy[i] * ny + v.vz[i] * nz;
  if (v.walls.reflection == WallReflection::Li2018) {
    const Real out = vn > Real(0) ? vn : Real(0);
    dv[0] = -2 * v.vx[i] + 2 * out * nx;
    dv[1] = -2 * v.vy[i] + 2 * out * ny;
    dv[2] = -2 * v.vz[i] + 2 * out * nz;
  } else {
    if (!(vn < Real(0))) return false;  // specular: only a particle moving in is turned
    dv[0] = -2 * vn * nx;
    dv[1] = -2 * vn * ny;
    dv[2] = -2 * vn * nz;
  }
  return true;
}

// Per-pair force split into its parts, for the force pass and the stress observable alike.
template <class Real>
struct PairForce {
  Real conservative = 0, dissipative = 0, random = 0;  // components along e_ij
  Real r = 0;
};

// What the pair terms read of one particle of a pair, loaded once per particle (only what the
// compiled terms need). (Packing these into 16-byte records for the GPU was measured and did not
// pay: H200, porous 16 M, 803 MPS/s packed against 817 without; docs/benchmarks.md.)
template <class Real>
struct PairSide {
  int index = 0;
  int type = 0;
  Real rho = 0;
  Real vx = 0, vy = 0, vz = 0;  // velocity estimate v~
  std::uint64_t id = 0;
};

template <class Real, class Conservative, class Thermostat>
MESO_HD MESO_INLINE PairSide<Real> pair_side(const StepView<Real>& v, int j) {
  PairSide<Real> s;
  s.index = j;
  constexpr bool kDensity = Conservative::enabled && Conservative::needs_density;
  s.type = v.type[j];
  if constexpr (kDensity) s.rho = v.rho[j];
  if constexpr (Thermostat::enabled) {
    s.vx = v.vex[j];
    s.vy = v.vey[j];
    s.vz = v.vez[j];
    s.id = static_cast<std::uint64_t>(v.id[j]);
  }
  return s;
}

// With the wall model, a fluid-wall pair's dissipation is scaled by the no-slip factor of the
// fluid particle's phi (gamma_eff = gamma kappa, sigma_eff = sigma sqrt(kappa)), whichever side
// the pair is evaluated from, so F_ij = -F_ji still holds.
template <class Real, class Conservative, class Thermostat, class WallModel = NoWallModel>
MESO_HD MESO_INLINE PairForce<Real> pair_force(const StepView<Real>& v, const PairSide<Real>& a,
                                               const PairSide<Real>& b, Real dx, Real dy, Real dz,
                                               Real r2) {
  PairForce<Real> f;
  if (r2 < coincident_r2<Real>()) return f;
  const Real r = real_sqrt(r2);
  f.r = r;
  const PairParams<Real>& p = v.table[a.type * v.ntypes + b.type];
  if constexpr (Conservative::enabled)
    f.conservative = Conservative::magnitude(r, a.rho, b.rho, p, v.rd);
  if constexpr (Thermostat::enabled) {
    const Real inv_r = Real(1) / r;
    const Real e_dot_v = (dx * (a.vx - b.vx) + dy * (a.vy - b.vy) + dz * (a.vz - b.vz)) * inv_r;
    const Real xi = pair_random<Real>(v.seed, v.current_step(), a.id, b.id);
    PairParams<Real> q = p;
    if constexpr (WallModel::enabled) {
      const bool wall_a = v.walls.is_wall(a.type);
      if (wall_a != v.walls.is_wall(b.type)) {
        const Real kappa = v.walls.dissipation_factor(v.bvf[wall_a ? b.index : a.index]);
        q.gamma *= kappa;
        q.sigma *= real_sqrt(kappa);
      }
    }
    f.dissipative = Thermostat::dissipative(r, e_dot_v, q);
    f.random = Thermostat::random(r, xi, v.inv_sqrt_dt, q);
  }
  return f;
}

// |F_ij| / r for particle i (its side `self`) and j: F_ij = s d_ij; 0 for coincident particles.
template <class Real, class Conservative, class Thermostat, class WallModel>
MESO_HD MESO_INLINE Real pair_force_over_r(const StepView<Real>& v, const PairSide<Real>& self,
                                           int j, Real dx, Real dy, Real dz, Real r2) {
  const PairForce<Real> f = pair_force<Real, Conservative, Thermostat, WallModel>(
      v, self, pair_side<Real, Conservative, Thermostat>(v, j), dx, dy, dz, r2);
  if (f.r == Real(0)) return Real(0);
  return (f.conservative + f.dissipative + f.random) / f.r;
}

// The body force g_type of particle i (with its sign, for a position-dependent one) added to f.
template <class Real, class BodyForce>
MESO_HD MESO_INLINE void add_body_force([[maybe_unused]] const StepView<Real>& v,
                                        [[maybe_unused]] int i, [[maybe_unused]] Real& fx,
                                        [[maybe_unused]] Real& fy, [[maybe_unused]] Real& fz) {
  if constexpr (BodyForce::enabled) {
    const Real* g = v.body_force + 3 * v.type[i];
    const Real* pos = v.body_force_axis == 0 ? v.x : (v.body_force_axis == 1 ? v.y : v.z);
    const Real s = BodyForce::sign(pos[i], v.body_force_midplane);
    fx += s * g[0];
    fy += s * g[1];
    fz += s * g[2];
  }
}

// Force pass for one particle: f_i = sum_j F_ij + g_type. Frozen particles get f = 0.
template <class Real, class Conservative, class Thermostat, class BodyForce,
          class WallModel = NoWallModel, class Lanes = OneLane>
MESO_HD MESO_INLINE void force_on_particle(const StepView<Real>& v, int i,
                                           const NeighbourStash& stash,
                                           const Lanes& lanes = Lanes{}) {
  Real fx = 0, fy = 0, fz = 0;
  if (!v.frozen(i) && !v.ghost(i)) {
    const PairSide<Real> self = pair_side<Real, Conservative, Thermostat>(v, i);
    for_each_neighbour_stashed(
        v, i, stash,
        [&](int j, Real dx, Real dy, Real dz, Real r2) {
          const Real s = pair_force_over_r<Real, Conservative, Thermostat, WallModel>(
              v, self, j, dx, dy, dz, r2);
          fx += s * dx;
          fy += s * dy;
          fz += s * dz;
        },
        lanes);
    fx = lanes.sum(fx);
    fy = lanes.sum(fy);
    fz = lanes.sum(fz);
    add_body_force<Real, BodyForce>(v, i, fx, fy, fz);
  }
  if (!lanes.leader()) return;
  v.fx[i] = fx;
  v.fy[i] = fy;
  v.fz[i] = fz;
}

// ---------------------------------------------------------------------------------------------
// Newton's third law: the same sums, each pair evaluated once and its result added to both
// particles. The CPU backend runs these over its half neighbour list (sim/half_list.h), which
// holds each pair once, in the list [first, last) of its lower-stored particle, and schedules the
// particles so that no two threads add to one particle at once, in an order that does not depend
// on the thread count. A pass is: begin (every particle), the pair bodies, finish (every particle).
// The separations are minimum images, so a list may be kept while the particles move (a skin).

template <class Real>
MESO_HD MESO_INLINE Real separation2(const StepView<Real>& v, int i, int j, Real& dx, Real& dy,
                                     Real& dz) {
  dx = v.box.minimum_image(v.x[i] - v.x[j], 0);
  dy = v.box.minimum_image(v.y[i] - v.y[j], 1);
  dz = v.box.minimum_image(v.z[i] - v.z[j], 2);
  return dx * dx + dy * dy + dz * dz;
}

// rho (when DensityKernel is not void) and the wall sum of phi, before the pairs.
template <class Real, class DensityKernel, bool kWalls>
MESO_HD MESO_INLINE void begin_sums(const StepView<Real>& v, int i) {
  constexpr bool kDensity = !std::is_void<DensityKernel>::value;
  // A frozen particle's sums over its frozen neighbours, where they are kept (StepView::frozen_rho;
  // its half list then holds no pair of two frozen particles).
  if ((kWalls ? v.frozen_bvf : v.frozen_rho) != nullptr && v.frozen(i)) {
    const int k = v.frozen_index(i);
    if constexpr (kDensity) v.rho[i] = v.frozen_rho[k];
    if constexpr (kWalls) v.bvf[i] = v.frozen_bvf[k];
    return;
  }
  if constexpr (kDensity) v.rho[i] = Real(0);
  if constexpr (kWalls) v.bvf[i] = Real(0);
}

// The pairs of particle i in the density pass and, with walls, the wall sum of phi (as in
// density_and_bvf_of_particle): rho_i += w(r_ij) and rho_j += w(r_ij); the fluid side of a
// fluid-wall pair gets W(r_ij).
template <class Real, class DensityKernel, bool kWalls>
MESO_HD MESO_INLINE void sums_of_pairs(const StepView<Real>& v, int i, const int* first,
                                       const int* last) {
  constexpr bool kDensity = !std::is_void<DensityKernel>::value;
  Real rho = 0, wall = 0;
  const Real rd = v.rd;
  const Real rd2 = rd * rd;
  const bool wall_i = kWalls && v.walls.is_wall(v.type[i]);
  for (const int* p = first; p < last; ++p) {
    const int j = *p;
    Real dx, dy, dz;
    const Real r2 = separation2(v, i, j, dx, dy, dz);
    if (!(r2 < Real(1))) continue;
    const Real r = real_sqrt(r2);
    if constexpr (kDensity) {
      if (r2 < rd2) {
        const Real w = DensityKernel::weight(r, rd);
        rho += w;
        v.rho[j] += w;
      }
    }
    if constexpr (kWalls) {
      if (wall_i != v.walls.is_wall(v.type[j])) {
        const Real w = bvf_weight(r);
        if (wall_i)
          v.bvf[j] += w;
        else
          wall += w;
      }
    }
  }
  if constexpr (kDensity) v.rho[i] += rho;
  if constexpr (kWalls) v.bvf[i] += wall;
}

// phi_i = (wall sum) / n_w; a wall particle's stays 0 (it never gets a wall sum).
template <class Real>
MESO_HD MESO_INLINE void finish_sums(const StepView<Real>& v, int i) {
  v.bvf[i] *= v.walls.inv_wall_density;
}

template <class Real>
MESO_HD MESO_INLINE void begin_forces(const StepView<Real>& v, int i) {
  v.fx[i] = Real(0);
  v.fy[i] = Real(0);
  v.fz[i] = Real(0);
}

// The pairs of particle i in the force pass: f_i += F_ij, f_j -= F_ij (F_ij = -F_ji to the last
// bit: pair_force is symmetric in its two sides and the random number is keyed by the sorted ids).
template <class Real, class Conservative, class Thermostat, class WallModel = NoWallModel>
MESO_HD MESO_INLINE void forces_of_pairs(const StepView<Real>& v, int i, const int* first,
                                         const int* last) {
  Real fx = 0, fy = 0, fz = 0;
  const PairSide<Real> self = pair_side<Real, Conservative, Thermostat>(v, i);
  for (const int* p = first; p < last; ++p) {
    const int j = *p;
    Real dx, dy, dz;
    const Real r2 = separation2(v, i, j, dx, dy, dz);
    if (!(r2 < Real(1))) continue;
    const Real s =
        pair_force_over_r<Real, Conservative, Thermostat, WallModel>(v, self, j, dx, dy, dz, r2);
    fx += s * dx;
    fy += s * dy;
    fz += s * dz;
    v.fx[j] -= s * dx;
    v.fy[j] -= s * dy;
    v.fz[j] -= s * dz;
  }
  v.fx[i] += fx;
  v.fy[i] += fy;
  v.fz[i] += fz;
}

// After the pairs: frozen particles and ghosts get f = 0 (their pairs' forces went to the
// others), the rest their body force.
template <class Real, class BodyForce>
MESO_HD MESO_INLINE void finish_forces(const StepView<Real>& v, int i) {
  if (v.frozen(i) || v.ghost(i)) {
    begin_forces(v, i);
    return;
  }
  add_body_force<Real, BodyForce>(v, i, v.fx[i], v.fy[i], v.fz[i]);
}

// ---------------------------------------------------------------------------------------------
// Integration.

// Reflective face: mirror the position back inside and reverse the normal velocity components
// (v~ too when the run keeps one).
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void apply_boundary(const StepView<Real>& v, int i, Real* pos, Real* vel,
                                        Real* vel_est, int axis) {
  const Real lo = v.box.lo[axis];
  const Real hi = lo + v.box.length[axis];
  Real p = pos[i];
  if (v.box.periodic[axis]) {
    if (p >= hi) p -= v.box.length[axis];
    if (p < lo) p += v.box.length[axis];
    // A particle that moved more than a box length per step is caught by the watchdog; keep the
    // position in range so the cell lookup stays valid until then.
    if (p >= hi || p < lo) p = lo;
  } else {
    // An open face (a rank's face inside a decomposed box) lets the particle out: the
    // decomposition hands it to its new owner before the next force pass.
    const bool open_lo = v.box.open_lo[axis], open_hi = v.box.open_hi[axis];
    if (p < lo && !open_lo) {
      p = lo + (lo - p);
      vel[i] = -vel[i];
      if constexpr (kVelocityEstimate) vel_est[i] = -vel_est[i];
    } else if (p >= hi && !open_hi) {
      p = hi - (p - hi);
      vel[i] = -vel[i];
      if constexpr (kVelocityEstimate) vel_est[i] = -vel_est[i];
    }
    if ((p < lo && !open_lo) || (p >= hi && !open_hi)) p = lo + Real(0.5) * v.box.length[axis];
  }
  pos[i] = p;
}

// Virtual walls: a plane that keeps the particles of some types on one side until a given step
// (the 2020 paper's wall at the face of the pore block, removed when flooding starts). A blocked
// particle found on the wrong side after its drift is mirrored back, its normal velocity (and
// v~) reversed. A scene without virtual walls has count = 0: one uniform compare per particle
// in the drift, nothing in the pair loop.
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void apply_virtual_walls(const StepView<Real>& v, int i) {
  const VirtualWalls<Real>& w = v.virtual_walls;
  for (int k = 0; k < w.count; ++k) {
    if (v.current_step() >= w.until_step[k] || !((w.type_mask[k] >> v.type[i]) & 1u)) continue;
    const int a = w.axis[k];
    Real* pos = a == 0 ? v.x : (a == 1 ? v.y : v.z);
    const Real d = pos[i] - w.position[k];
    if (w.keep_below[k] ? !(d >= Real(0)) : !(d < Real(0))) continue;
    pos[i] = w.position[k] - d;
    if (w.keep_below[k] && !(pos[i] < w.position[k])) pos[i] = w.position[k] - Real(1e-4);
    Real* vel = a == 0 ? v.vx : (a == 1 ? v.vy : v.vz);
    vel[i] = -vel[i];
    if constexpr (kVelocityEstimate) {
      Real* est = a == 0 ? v.vex : (a == 1 ? v.vey : v.vez);
      est[i] = -est[i];
    }
  }
}

// The solid grid's bounce-back (sim/solid_grid.h). A particle whose move ended inside a solid
// voxel is sent back: its velocity (and v~) reversed, v' = -v (no slip on a resting wall, like
// the halfway bounce-back of lattice Boltzmann), and the move redone from where it started,
// x = x0 + dt v'; if that lands in the solid too (a corner, a thin gap), it stays at x0, which is
// in the pore. So no particle that starts a step in the pore ends it in the solid, whatever the
// wall particles around it. One byte is read per particle and step; nothing more unless it hit.
// Returns whether it turned the particle.
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE bool bounce_off_solid(const StepView<Real>& v, int i, Real x0, Real y0,
                                          Real z0) {
  if (!v.solid.in_solid(v.x[i], v.y[i], v.z[i])) return false;
  v.vx[i] = -v.vx[i];
  v.vy[i] = -v.vy[i];
  v.vz[i] = -v.vz[i];
  if constexpr (kVelocityEstimate) {
    v.vex[i] = -v.vex[i];
    v.vey[i] = -v.vey[i];
    v.vez[i] = -v.vez[i];
  }
  v.x[i] = x0 + v.dt * v.vx[i];
  v.y[i] = y0 + v.dt * v.vy[i];
  v.z[i] = z0 + v.dt * v.vz[i];
  apply_boundary<Real, kVelocityEstimate>(v, i, v.x, v.vx, v.vex, 0);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.y, v.vy, v.vey, 1);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.z, v.vz, v.vez, 2);
  apply_virtual_walls<Real, kVelocityEstimate>(v, i);
  if (v.solid.in_solid(v.x[i], v.y[i], v.z[i])) {
    v.x[i] = x0;
    v.y[i] = y0;
    v.z[i] = z0;
  }
  return true;
}

// First half: v~ = v + lambda dt f; v += dt/2 f; x += dt v; boundaries.
// v~ feeds only the dissipative force: without a thermostat (kVelocityEstimate false) it is
// neither computed nor stored.
// A slab particle's velocity (and v~) is its slab's V along the slab's axis.
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void set_slab_velocity(const StepView<Real>& v, int i, Real V, int axis) {
  v.vx[i] = axis == 0 ? V : Real(0);
  v.vy[i] = axis == 1 ? V : Real(0);
  v.vz[i] = axis == 2 ? V : Real(0);
  if constexpr (kVelocityEstimate) {
    v.vex[i] = v.vx[i];
    v.vey[i] = v.vy[i];
    v.vez[i] = v.vz[i];
  }
}

template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void kick_drift(const StepView<Real>& v, int i) {
  if (v.frozen(i) || v.ghost(i)) return;
  if (v.slabs.count > 0 && v.slabs.is_slab(v.type[i])) {
    const int k = v.slabs.slab_of(v.type[i]);
    const int a = v.slabs.axis[k];
    const Real V = v.slabs.half_velocity[k];
    set_slab_velocity<Real, kVelocityEstimate>(v, i, V, a);
    Real* pos = a == 0 ? v.x : (a == 1 ? v.y : v.z);
    pos[i] += v.dt * V;
    Real* vel = a == 0 ? v.vx : (a == 1 ? v.vy : v.vz);
    Real* est = a == 0 ? v.vex : (a == 1 ? v.vey : v.vez);
    apply_boundary<Real, kVelocityEstimate>(v, i, pos, vel, est, a);
    return;
  }
  const Real dt = v.dt;
  const Real half = Real(0.5) * dt;
  if constexpr (kVelocityEstimate) {
    const Real ld = v.lambda * dt;
    v.vex[i] = v.vx[i] + ld * v.fx[i];
    v.vey[i] = v.vy[i] + ld * v.fy[i];
    v.vez[i] = v.vz[i] + ld * v.fz[i];
  }
  v.vx[i] += half * v.fx[i];
  v.vy[i] += half * v.fy[i];
  v.vz[i] += half * v.fz[i];
  const Real x0 = v.x[i], y0 = v.y[i], z0 = v.z[i];
  v.x[i] += dt * v.vx[i];
  v.y[i] += dt * v.vy[i];
  v.z[i] += dt * v.vz[i];
  apply_boundary<Real, kVelocityEstimate>(v, i, v.x, v.vx, v.vex, 0);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.y, v.vy, v.vey, 1);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.z, v.vz, v.vez, 2);
  apply_virtual_walls<Real, kVelocityEstimate>(v, i);
  if (v.solid.bounce && v.solid.enabled()) {
    // phi at the step's start: the last sums were taken where the particle stood.
    const bool started_inside = v.left_to_grid && v.bvf[i] > v.walls.phi_c;
    const bool turned = bounce_off_solid<Real, kVelocityEstimate>(v, i, x0, y0, z0);
    if (v.left_to_grid) v.left_to_grid[i] = turned || started_inside;
  }
}

// Second half: v += dt/2 f(t + dt).
template <class Real>
MESO_HD MESO_INLINE void kick(const StepView<Real>& v, int i) {
  if (v.frozen(i) || v.ghost(i)) return;
  if (v.slabs.count > 0 && v.slabs.is_slab(v.type[i])) {
    const int k = v.slabs.slab_of(v.type[i]);
    set_slab_velocity<Real, false>(v, i, v.slabs.velocity[k], v.slabs.axis[k]);
    return;
  }
  const Real half = Real(0.5) * v.dt;
  v.vx[i] += half * v.fx[i];
  v.vy[i] += half * v.fy[i];
  v.vz[i] += half * v.fz[i];
}

// Applies a correction found by penetration_correction: v += dv, the same change to v~ (with
// lambda = 1/2 v~ is the half-step velocity the corrector turned, so both stay equal), and
// x += dt dv, then the box faces.
template <class Real, bool kVelocityEstimate>
MESO_HD MESO_INLINE void apply_penetration_correction(const StepView<Real>& v, int i,
                                                      const Real dv[3]) {
  const Real x0 = v.x[i], y0 = v.y[i], z0 = v.z[i];  // the predictor's (in the pore)
  v.vx[i] += dv[0];
  v.vy[i] += dv[1];
  v.vz[i] += dv[2];
  if constexpr (kVelocityEstimate) {
    v.vex[i] += dv[0];
    v.vey[i] += dv[1];
    v.vez[i] += dv[2];
  }
  v.x[i] += v.dt * dv[0];
  v.y[i] += v.dt * dv[1];
  v.z[i] += v.dt * dv[2];
  apply_boundary<Real, kVelocityEstimate>(v, i, v.x, v.vx, v.vex, 0);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.y, v.vy, v.vey, 1);
  apply_boundary<Real, kVelocityEstimate>(v, i, v.z, v.vz, v.vez, 2);
  apply_virtual_walls<Real, kVelocityEstimate>(v, i);
  // The solid grid has the last word: a correction that would end in a solid voxel keeps the
  // turned velocity but not the move.
  if (v.solid.bounce && v.solid.enabled() && v.solid.in_solid(v.x[i], v.y[i], v.z[i])) {
    v.x[i] = x0;
    v.y[i] = y0;
    v.z[i] = z0;
  }
}

// Particle i's force along slab k's axis if it belongs to slab k, else 0 (the rigid-body
// reduction sums it over all particles).
template <class Real>
MESO_HD MESO_INLINE Real slab_force_of(const StepView<Real>& v, int i, int k) {
  if (v.type[i] != v.slabs.type[k] || v.ghost(i)) return Real(0);
  const int a = v.slabs.axis[k];
  return a == 0 ? v.fx[i] : (a == 1 ? v.fy[i] : v.fz[i]);
}

// Particle i's coordinate along slab k's axis if it belongs to slab k, else 0 (the slab's position
// is their mean: Simulation::rigid_slabs).
template <class Real>
MESO_HD MESO_INLINE Real slab_coordinate_of(const StepView<Real>& v, int i, int k) {
  if (v.type[i] != v.slabs.type[k] || v.ghost(i)) return Real(0);
  const int a = v.slabs.axis[k];
  return a == 0 ? v.x[i] : (a == 1 ? v.y[i] : v.z[i]);
}

// ---------------------------------------------------------------------------------------------
// Injection and ejection (sim/injection.h): the pick key of particle i, and the move of the
// picked particle to the inlet as the injected type. Its force is zeroed (the next force pass
// computes it at the new place) and v~ follows v. The type array is written only here, between
// steps; the pass kernels read it as const.
template <class Real>
MESO_HD MESO_INLINE std::uint64_t injection_key_of(const StepView<Real>& v,
                                                   const InjectionView<Real>& inj, int i,
                                                   int pick) {
  if (v.ghost(i)) return kNoInjectionCandidate;
  return injection_key(inj, v.x[i], v.y[i], v.z[i], v.type[i], v.id[i], v.current_step(), pick);
}

template <class Real>
MESO_HD MESO_INLINE void inject_particle(const StepView<Real>& v, const InjectionView<Real>& inj,
                                         int i, int pick) {
  Real pos[3], vel[3];
  injection_placement(inj, v.current_step(), pick, pos, vel);
  v.x[i] = pos[0];
  v.y[i] = pos[1];
  v.z[i] = pos[2];
  v.vx[i] = vel[0];
  v.vy[i] = vel[1];
  v.vz[i] = vel[2];
  if (v.vex != nullptr) {
    v.vex[i] = vel[0];
    v.vey[i] = vel[1];
    v.vez[i] = vel[2];
  }
  v.fx[i] = Real(0);
  v.fy[i] = Real(0);
  v.fz[i] = Real(0);
  const_cast<std::int32_t*>(v.type)[i] = inj.inject_type;
}

// The particles a stress sum covers: all of them, or (active) those of some types inside a box,
// for the pressure of a region (each particle contributes its kinetic term and half of each of
// its pair virials, the per-particle convention of LAMMPS compute stress/atom).
template <class Real>
struct VirialRegion {
  bool active = false;
  std::uint32_t type_mask = ~0u;
  Real lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};

  MESO_HD MESO_INLINE bool contains(const StepView<Real>& v, int i) const {
    if (v.ghost(i)) return false;  // each rank sums its own particles
    if (!active) return true;
    return ((type_mask >> v.type[i]) & 1u) && v.x[i] >= lo[0] && v.x[i] < hi[0] &&
           v.y[i] >= lo[1] && v.y[i] < hi[1] && v.z[i] >= lo[2] && v.z[i] < hi[2];
  }
};

// Neighbours of particle i within rc (0 for a ghost): the load-balance cost measure.
template <class Real>
MESO_HD MESO_INLINE int neighbour_count(const StepView<Real>& v, int i) {
  if (v.ghost(i)) return 0;
  int c = 0;
  for_each_neighbour(v, i, [&](int, Real, Real, Real, Real) { ++c; });
  return c;
}

// ---------------------------------------------------------------------------------------------
// Stress observable: per-particle half of the pair virial, split into conservative, dissipative
// and random parts: W_i^{ab} = 1/2 sum_j r_ij^a F_ij^b. Summed over i and divided by the volume
// it is the configurational stress; the kinetic part is added by the caller.
template <class Real>
struct ParticleVirial {
  Real conservative[6] = {0, 0, 0, 0, 0, 0};  // xx yy zz xy xz yz
  Real dissipative[6] = {0, 0, 0, 0, 0, 0};
  Real random[6] = {0, 0, 0, 0, 0, 0};
};

template <class Real, class Conservative, class Thermostat, class WallModel = NoWallModel>
MESO_HD MESO_INLINE ParticleVirial<Real> virial_of_particle(const StepView<Real>& v, int i) {
  ParticleVirial<Real> w;
  const PairSide<Real> self = pair_side<Real, Conservative, Thermostat>(v, i);
  for_each_neighbour(v, i, [&](int j, Real dx, Real dy, Real dz, Real r2) {
    // Frozen-frozen pairs exert no force that matters (neither moves) and are left out.
    if (v.frozen(i) && v.frozen(j)) return;
    const PairForce<Real> f = pair_force<Real, Conservative, Thermostat, WallModel>(
        v, self, pair_side<Real, Conservative, Thermostat>(v, j), dx, dy, dz, r2);
    if (f.r == Real(0)) return;
    // r_ij^a F_ij^b = f d^a d^b / r with F_ij = f e and e = d / r; half to each particle.
    const Real rr[6] = {dx * dx, dy * dy, dz * dz, dx * dy, dx * dz, dy * dz};
    const Real h = Real(0.5) / f.r;
    for (int c = 0; c < 6; ++c) {
      w.conservative[c] += h * f.conservative * rr[c];
      w.dissipative[c] += h * f.dissipative * rr[c];
      w.random[c] += h * f.random * rr[c];
    }
  });
  return w;
}

// ---------------------------------------------------------------------------------------------
// Binned observables: the bin particle i adds to, or -1 when its type is not counted or it lies
// outside the grid.
template <class Real>
MESO_HD MESO_INLINE int bin_of_particle(const StepView<Real>& v, const BinView<Real>& b, int i) {
  if (!((b.type_mask >> v.type[i]) & 1u) || v.ghost(i)) return -1;
  return b.bin_of(v.x[i], v.y[i], v.z[i]);
}

// What particle i adds to its bin: 1, v and v*v per component (BinField order).
template <class Real>
MESO_HD MESO_INLINE void bin_terms(const StepView<Real>& v, int i, double t[kBinFields]) {
  const double vel[3] = {double(v.vx[i]), double(v.vy[i]), double(v.vz[i])};
  t[kBinCount] = 1;
  for (int a = 0; a < 3; ++a) {
    t[kBinVx + a] = vel[a];
    t[kBinVxx + a] = vel[a] * vel[a];
  }
}

// ---------------------------------------------------------------------------------------------
// A thermo row's terms per particle (Engine::solid_intrusion and the kinetic part of virial;
// temperature and momentum are a one-bin bin_sums), summed where the particles are: a row then
// moves a few numbers per thread block off the GPU, not the whole state. Counted: the particles
// that move and this rank owns.
template <class Real>
MESO_HD MESO_INLINE bool thermal(const StepView<Real>& v, int i) {
  return !(((v.frozen_mask | v.slabs.mask) >> v.type[i]) & 1u) && !v.ghost(i);
}

// m v^a v^b of particle i (m = 1; Voigt order xx yy zz xy xz yz), added to k.
template <class Real>
MESO_HD MESO_INLINE void add_kinetic_stress(const StepView<Real>& v, int i, double k[6]) {
  const double u[3] = {double(v.vx[i]), double(v.vy[i]), double(v.vz[i])};
  k[0] += u[0] * u[0], k[1] += u[1] * u[1], k[2] += u[2] * u[2];
  k[3] += u[0] * u[1], k[4] += u[0] * u[2], k[5] += u[1] * u[2];
}

// The leak invariant's sums: the particles inside solid voxels and the deepest of them, ties to
// the smaller id, so that blocks merged in any order give the serial loop's answer.
struct SolidIntrusionSums {
  unsigned long long inside = 0;
  double depth = 0;
  long long id = -1;
  double position[3] = {0, 0, 0};

  MESO_HD MESO_INLINE void merge(const SolidIntrusionSums& o) {
    inside += o.inside;
    if (o.id >= 0 && (id < 0 || o.depth > depth || (o.depth == depth && o.id < id))) {
      depth = o.depth;
      id = o.id;
      for (int a = 0; a < 3; ++a) position[a] = o.position[a];
    }
  }
};

// The observable of merged sums (a run with a solid grid).
inline SolidIntrusion solid_intrusion_from(const SolidIntrusionSums& s) {
  SolidIntrusion r;
  r.available = true;
  r.inside = s.inside;
  if (s.id >= 0) {
    r.max_depth = s.depth;
    r.deepest_id = s.id;
    r.deepest_position = {s.position[0], s.position[1], s.position[2]};
  }
  return r;
}

// Particle i's share: empty unless it is thermal and inside a solid voxel.
template <class Real>
MESO_HD MESO_INLINE SolidIntrusionSums solid_intrusion_of_particle(const StepView<Real>& v, int i) {
  SolidIntrusionSums s;
  if (!thermal(v, i) || !v.solid.in_solid(v.x[i], v.y[i], v.z[i])) return s;
  s.inside = 1;
  s.depth = double(v.solid.depth(v.x[i], v.y[i], v.z[i]));
  s.id = static_cast<long long>(v.id[i]);
  s.position[0] = double(v.x[i]), s.position[1] = double(v.y[i]), s.position[2] = double(v.z[i]);
  return s;
}

}  // namespace mesorock::sim
