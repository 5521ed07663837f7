// CUDA engine. Per step: kick_drift; a stable counting sort of the particle storage by cell
// (sort_by_cell), so neighbours are contiguous in memory exactly as on the CPU; density
// (only with a many-body term); forces; kick. Nothing crosses to the host unless an output asks.
#include <cuda_runtime.h>

#include <thrust/iterator/counting_iterator.h>
#include <algorithm>
#include <array>
#include <cstring>
#include <cub/block/block_reduce.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_select.cuh>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "mesorock/errors.h"
#include "sim/cuda/engine_cuda.h"
#include "sim/kernels.h"
#include "sim/simulation.h"
#include "sim/stepper.h"
#include "sim/terms.h"
#include "sim/watchdog.h"

namespace mesorock::sim {

namespace {

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw DeviceError(std::string("CUDA error in ") + what + ": " + cudaGetErrorString(e));
}

// A typed device buffer that owns its memory.
template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() { release(); }
  void resize(size_t n) {
    if (n == size_) return;
    release();
    if (n > 0) check(cudaMalloc(&ptr_, n * sizeof(T)), "cudaMalloc");
    size_ = capacity_ = n;
  }
  // Changes the size keeping the first min(old, n) elements; grows the allocation by a quarter
  // beyond n when it must grow (a decomposed run's particle count changes every step).
  void set_size(size_t n) {
    if (n > capacity_) {
      const size_t cap = n + n / 4 + 64;
      T* p = nullptr;
      check(cudaMalloc(&p, cap * sizeof(T)), "cudaMalloc");
      if (size_) check(cudaMemcpy(p, ptr_, size_ * sizeof(T), cudaMemcpyDeviceToDevice), "grow");
      if (ptr_) cudaFree(ptr_);
      ptr_ = p;
      capacity_ = cap;
    }
    size_ = n;
  }
  void upload(const std::vector<T>& h) {
    resize(h.size());
    if (size_)
      check(cudaMemcpy(ptr_, h.data(), size_ * sizeof(T), cudaMemcpyHostToDevice), "upload");
  }
  void download(std::vector<T>& h) const {
    h.resize(size_);
    if (size_)
      check(cudaMemcpy(h.data(), ptr_, size_ * sizeof(T), cudaMemcpyDeviceToHost), "download");
  }
  T* get() const { return ptr_; }
  size_t size() const { return size_; }
  void swap(DeviceBuffer& o) {
    std::swap(ptr_, o.ptr_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
  }
  size_t capacity() const { return capacity_; }

 private:
  void release() {
    if (ptr_) cudaFree(ptr_);
    ptr_ = nullptr;
    size_ = capacity_ = 0;
  }
  T* ptr_ = nullptr;
  size_t size_ = 0, capacity_ = 0;
};

constexpr int kBlock = 128;
// The penetration mask's cells (StepView::penetration): rc / 8 or more, at most 2^28 of them
// (32 MiB of bits).
constexpr double kPenetrationCell = 0.125;
constexpr double kPenetrationCells = double(1 << 28);

// Timing bounds, never results (where_users_run.sh RES_BINS; docs/benchmarks.md, "What the frozen
// particles' sums and the corrector cost"): builds with these definitions compute wrong physics on
// purpose, to measure what a rock step would cost if a part of its work were free.
// MESOROCK_BOUND_NO_FROZEN_SUMS: the pair passes visit the mobile part alone, so the frozen
// particles' rho and phi miss their mobile neighbours. MESOROCK_BOUND_NO_CORRECTOR: no wall
// correction.
#ifdef MESOROCK_BOUND_NO_FROZEN_SUMS
constexpr bool kBoundNoFrozenSums = true;
#else
constexpr bool kBoundNoFrozenSums = false;
#endif
#ifdef MESOROCK_BOUND_NO_CORRECTOR
constexpr bool kBoundNoCorrector = true;
#else
constexpr bool kBoundNoCorrector = false;
#endif

// At least one block: kernels test i < n, and a rank of a decomposed run may hold no particle.
inline int blocks_for(int n) {
  return n <= 0 ? 1 : (n + kBlock - 1) / kBlock;
}

// The step sequence's per-particle passes (sim/stepper.h): body(v, i), one thread per particle.
template <class Real, class Body>
__global__ void for_each_kernel(StepView<Real> v, Body body) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) body(v, i);
}

// The end of a captured run of steps: the next replay's first step.
__global__ void step_base_kernel(std::uint64_t* base, std::uint64_t steps) {
  *base += steps;
}

// The cell sort, a counting sort in three passes (sort_by_cell). Why not a radix sort: at the
// sizes of tiles, calibrations and sweep points (20,000 particles) CUB's onesweep passes ran on
// three thread blocks, 21 of a step's 115 us (H200; docs/benchmarks.md).
//
// First: each particle's key (its cell, offset by the cell count for a frozen one:
// StepView::frozen_part, and by twice that for a buried one in a full sort with `bury`:
// StepView::buried_part) and its arrival rank among the particles of that key. The ranks come
// from atomics, in no fixed order; order_in_cell_kernel makes the order that of the indices.
template <class Real>
__global__ void cell_count_kernel(StepView<Real> v, int count, int* cell, int* rank,
                                  int* cell_count, bool bury) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const int part = v.frozen_part > 0 && v.frozen(i) ? (bury && buried(v, i) ? 2 : 1) : 0;
  const int key = cell_of(v, i) + part * v.frozen_part;
  cell[i] = key;
  rank[i] = atomicAdd(cell_count + key, 1);
}

// Second, after the exclusive sum of the counts into cell_start: each particle into a slot of its
// cell, in arrival order. Threads up to keys also clear the counts for the next sort.
__global__ void cell_scatter_kernel(const int* cell, const int* rank, int count,
                                    const int* cell_start, int keys, int* cell_count,
                                    int* slot_particle) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t < count) slot_particle[cell_start[cell[t]] + rank[t]] = t;
  if (t <= keys) cell_count[t] = 0;
}

template <class T>
__global__ void gather_kernel(const T* __restrict__ in, T* __restrict__ out, const int* perm,
                              int n) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < n) out[k] = in[perm[k]];
}

// The arrays a cell sort moves (positions, velocities, v~, type, origin, id), each with the buffer
// it is gathered into: one launch moves them all.
template <class Real>
struct PermuteTable {
  static constexpr int kMaxReal = 9;
  const Real* in[kMaxReal] = {};
  Real* out[kMaxReal] = {};
  int reals = 0;
  const std::int32_t* in_int[2] = {};
  std::int32_t* out_int[2] = {};
  const std::int64_t* in_id = nullptr;
  std::int64_t* out_id = nullptr;
  const std::uint8_t* in_flag = nullptr;  // StepView::left_to_grid, when there is one
  std::uint8_t* out_flag = nullptr;
};

// Entry `from` of every array of t into entry `to` of its second buffer.
template <class Real>
__device__ MESO_INLINE void move_entry(const PermuteTable<Real>& t, int from, int to) {
#pragma unroll
  for (int a = 0; a < PermuteTable<Real>::kMaxReal; ++a)
    if (a < t.reals) t.out[a][to] = t.in[a][from];
  t.out_int[0][to] = t.in_int[0][from];
  t.out_int[1][to] = t.in_int[1][from];
  t.out_id[to] = t.in_id[from];
  if (t.out_flag) t.out_flag[to] = t.in_flag[from];
}

// out[k] = in[perm[k]] for k < m, in[k] for m <= k < count (a sort of the first m entries, the
// rest copied as they are).
template <class Real>
__global__ void permute_kernel(PermuteTable<Real> t, const int* __restrict__ perm, int m,
                               int count) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < count) move_entry(t, k < m ? perm[k] : k, k);
}

// Third: the stable order, and the move. A stable sort by cell keeps the particles of one cell in
// the order of their indices, so a particle's place in its cell is the number of its cell-mates
// with a smaller index. perm is then exactly the permutation of a stable sort, whatever order the
// atomics took: the same bits downstream, run after run. Each of the m sorted particles moves to
// its place in the second buffers (PermuteTable); entries m to count are copied as they are.
template <class Real>
__global__ void order_in_cell_kernel(PermuteTable<Real> t, const int* cell,
                                     const int* slot_particle, int m, int count,
                                     const int* cell_start, int* perm) {
  const int s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= count) return;
  if (s >= m) {
    move_entry(t, s, s);
    return;
  }
  const int p = slot_particle[s];
  const int c = cell[p];
  const int first = cell_start[c], last = cell_start[c + 1];
  int before = 0;
  for (int k = first; k < last; ++k) before += slot_particle[k] < p;
  perm[first + before] = p;
  move_entry(t, p, first + before);
}

// Each thread's neighbour stash (sim/kernels.h) in shared memory, slot k at k * blockDim.x so
// that a warp's stores hit 32 different banks.
constexpr size_t kStashBytes = sizeof(int) * NeighbourStash::kCapacity * kBlock;
__device__ MESO_INLINE NeighbourStash thread_stash() {
  extern __shared__ int stash_slots[];
  return NeighbourStash{stash_slots + threadIdx.x, static_cast<int>(blockDim.x)};
}

// L consecutive threads of a warp that share one particle's neighbour scan (OneLane in
// sim/kernels.h): lane k takes every L-th candidate; sum() adds the lanes' partial sums with a
// butterfly of shuffles, which gives every lane the same total in a fixed order.
template <int L>
struct LaneGroup {
  static_assert(L == 2 || L == 4 || L == 8, "a lane group divides a warp");
  static constexpr int kCount = L;
  static constexpr bool kReplays = false;
  int lane;
  __device__ int index() const { return lane; }
  __device__ bool leader() const { return lane == 0; }
  __device__ void record(int) const {}
  template <class T>
  __device__ T sum(T x) const {
    const unsigned group = ((1u << L) - 1u) << ((threadIdx.x & 31u) & ~unsigned(L - 1));
    for (int o = L / 2; o > 0; o /= 2) x += __shfl_xor_sync(group, x, o, L);
    return x;
  }
};

// The neighbour list (OneLane in sim/kernels.h): the density pass's lanes write the neighbours
// they find and the force pass's lanes visit them, so the force pass skips its scan (two thirds
// of it at 20,000 particles). Each thread t of the L * n keeps its own: slot k at
// slots[k * threads + t] (a warp's writes side by side), its count at counts[t]. A lane that
// finds more than lane_list_capacity(L) neighbours keeps counting, and scans in the force pass
// instead; the visits are the same either way.
struct LaneList {
  int* slots = nullptr;
  int* counts = nullptr;
  int threads = 0;
};
// Slots per lane: 72 of one lane, 40 of 2, 24 of 4, 16 of 8 (a liquid at rho = 7 has about 29
// neighbours).
__host__ __device__ constexpr int lane_list_capacity(int lanes) {
  return 8 + 64 / lanes;
}
template <int L>
using LaneBase = std::conditional_t<L == 1, OneLane, LaneGroup<L>>;
template <int L>
__device__ MESO_INLINE LaneBase<L> lane_base(int t) {
  if constexpr (L == 1)
    return OneLane{};
  else
    return LaneGroup<L>{t % L};
}
// The slots a lane fills: lane_list_capacity(L); with kListed (a sums range with the frozen
// density list) `limit`, none for a frozen particle (its force pass replays nothing). Without a
// list the bound stays a constant: the runtime one cost the 20,000-particle bulk liquid 8% of
// its step on an H100 (docs/benchmarks.md, "Issue 24's acceptance in one call").
template <int L, bool kListed>
struct RecordingLanes : LaneBase<L> {
  LaneList list;
  int thread;
  int limit;
  mutable int count = 0;
  __device__ void record(int j) const {
    if (count < (kListed ? limit : lane_list_capacity(L)))
      list.slots[static_cast<std::size_t>(count) * list.threads + thread] = j;
    ++count;
  }
};
template <int L>
struct ReplayingLanes : LaneBase<L> {
  static constexpr bool kReplays = true;
  static constexpr int kListCapacity = lane_list_capacity(L);
  LaneList list;
  int thread;
  __device__ int recorded_count() const { return list.counts[thread]; }
  __device__ int recorded(int k) const {
    return list.slots[static_cast<std::size_t>(k) * list.threads + thread];
  }
};

// The particles of a sums pass: the first `first` stored ones, then first + listed[k] for
// k < count - first (the frozen density list; without one, first = count = the particles a
// step visits).
struct SumsRange {
  int first = 0;
  int count = 0;
  const int* listed = nullptr;
};
// The gather passes with L threads per particle: the p-th particle of the range for thread t,
// p = t / L, lane t % L. The sums pass records each lane's neighbours in `list` at its thread;
// the force pass replays them (kReplay) or scans.
template <int L, bool kListed, class Real, class Body>
__global__ void for_each_lanes_kernel(StepView<Real> v, Body body, LaneList list, SumsRange r) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int p = t / L;
  if (p >= r.count) return;
  int i = p, limit = lane_list_capacity(L);
  if constexpr (kListed) {
    if (p >= r.first) i = r.first + r.listed[p - r.first];
    if (v.frozen(i)) limit = 0;
  }
  const RecordingLanes<L, kListed> lanes{lane_base<L>(t), list, t, limit};
  body(v, i, lanes);
  list.counts[t] = lanes.count;
}
// The force pass scanning, with the thread's neighbour stash (launched with kStashBytes).
template <int L, class Real, class Body>
__global__ void for_each_stashed_lanes_kernel(StepView<Real> v, Body body) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int i = t / L;
  if (i < v.n) body(v, i, thread_stash(), lane_base<L>(t));
}
// The force pass over the list: no scan, so no stash (launched without shared memory).
template <int L, class Real, class Body>
__global__ void for_each_replaying_kernel(StepView<Real> v, Body body, LaneList list) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int i = t / L;
  if (i < v.n) body(v, i, NeighbourStash{}, ReplayingLanes<L>{lane_base<L>(t), list, t});
}

// The wall model's corrector. Decisions read phi, the particle's own velocity and the positions
// of wall particles, none of which this kernel writes (the distance test also reads the positions
// of mobile candidates, which may be being corrected, but only to discard them as not wall); so
// each particle's correction is the same as on the CPU, where decisions and changes are split.
template <class Real, bool kVelocityEstimate>
__global__ void correction_kernel(StepView<Real> v, unsigned int* count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n) return;
  Real dv[3];
  if (penetration_correction(v, i, v.bvf[i], dv)) {
    apply_penetration_correction<Real, kVelocityEstimate>(v, i, dv);
    atomicAdd(count, 1u);
  }
}

// The corrector before the sort (sim/stepper.h correct_before_sort): phi and the wall normal at
// the predicted position from the frozen part alone, whose cell list holds while the mobile
// part's is a step old. Only wall particles are read, and none is written.
// Which particles need phi: not frozen, not left to the solid grid (which needs no phi), and
// where the frozen part may put phi past phi_c (StepView::penetration; true without a mask).
template <class Real>
__device__ bool needs_frozen_phi(const StepView<Real>& v, int i) {
  return !v.frozen(i) && !v.left_to_grid_at(i) && v.penetration.may_exceed(v.x[i], v.y[i], v.z[i]);
}
template <class Real, bool kVelocityEstimate>
__device__ void correct_against_frozen(const StepView<Real>& v, int i, unsigned long long* count) {
  Real dv[3];
  if (penetration_correction(v, i, wall_fraction(v, i, Parts::FrozenOnly), dv, Parts::FrozenOnly)) {
    apply_penetration_correction<Real, kVelocityEstimate>(v, i, dv);
    atomicAdd(count, 1ull);
  }
}
// Every particle (no penetration mask).
template <class Real, bool kVelocityEstimate>
__global__ void correction_before_sort_kernel(StepView<Real> v, unsigned long long* count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n && needs_frozen_phi(v, i))
    correct_against_frozen<Real, kVelocityEstimate>(v, i, count);
}
// needs_frozen_phi as flags, for the selection of correction_listed_kernel. (A CUB selection
// with the predicate holding the StepView was as slow as the scans it saved: the view, some 600
// bytes, is likely copied per thread.)
template <class Real>
__global__ void needs_frozen_phi_kernel(StepView<Real> v, int m, unsigned char* flag) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < m) flag[i] = needs_frozen_phi(v, i);
}
// The particles a selection listed (needs_frozen_phi; *listed of them): a warp's lanes all scan.
// Why not skip in place: the fluid is sorted by cell, and a warp of neighbours nearly always has
// a lane near the wall, which held the whole warp (the mask alone saved 14% of the corrector's
// time at 0.5 rc per voxel, docs/benchmarks.md).
// `listed_total` (profiling; else null) adds up the listed counts.
template <class Real, bool kVelocityEstimate>
__global__ void correction_listed_kernel(StepView<Real> v, const int* list, const int* listed,
                                         unsigned long long* count,
                                         unsigned long long* listed_total) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t == 0 && listed_total) *listed_total += static_cast<unsigned long long>(*listed);
  if (t < *listed) correct_against_frozen<Real, kVelocityEstimate>(v, list[t], count);
}

// The penetration mask's words (sim/penetration_mask.h), one per thread.
template <class Real>
__global__ void penetration_mask_kernel(StepView<Real> v, PenetrationMask<Real> m,
                                        std::uint32_t* bits) {
  const std::size_t w = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (w < m.words()) bits[w] = penetration_mask_word(v, m, w);
}

// The buried particles' rho and phi (StepView::buried_part): their static sums, with no mobile
// neighbour to add, set once after the full sort; the steps' passes never reach them.
template <class Real, class Sums>
__global__ void buried_sums_kernel(StepView<Real> v, int first, Sums sums) {
  const int i = first + blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) sums(v, i);
}

// Flags the frozen particles [first, first + count) whose density a step may change: those with
// a pore voxel within rd (and the margin of buried()), where the solid grid's bounce keeps every
// mobile particle. The others' sums stay the static ones (the frozen density list).
template <class Real>
__global__ void density_may_change_kernel(StepView<Real> v, int first, int count,
                                          unsigned char* flag) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  const int i = first + k;
  flag[k] = v.solid.pore_within(v.x[i], v.y[i], v.z[i], v.rd + Real(0.001));
}

// The frozen particles' static sums over their frozen neighbours (StepView::frozen_rho).
template <class Real, class DensityKernel, bool kWalls>
__global__ void frozen_sums_kernel(StepView<Real> v, Real* rho, Real* wall) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n && v.frozen_index(i) >= 0)
    frozen_sums_of_particle<Real, DensityKernel, kWalls>(v, i, rho, wall);
}

// Rigid slabs (sim/rigid_slabs.h): the bodies live on the device; a step adds a one-thread half
// kick, a per-block reduction of the slab particles' forces and a one-block kernel that finishes
// the sum in a fixed order (so the motion is the same every run) and applies the second kick.
template <class Real>
__global__ void slab_half_kick_kernel(RigidSlabBody* bodies, int count, double dt, Real* half) {
  const int k = threadIdx.x;
  if (k >= count) return;
  slab_half_kick(bodies[k], dt);
  half[k] = static_cast<Real>(bodies[k].half_velocity);
}

// kCoordinates: the same reduction of the slab particles' coordinates along the axis (their
// positions for Simulation::rigid_slabs), not of their forces.
template <class Real, bool kCoordinates = false>
__global__ void slab_partials_kernel(StepView<Real> v, double* partials) {
  using BlockReduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename BlockReduce::TempStorage temp;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  for (int k = 0; k < v.slabs.count; ++k) {
    double f = 0;
    if (i < v.n)
      f = static_cast<double>(kCoordinates ? slab_coordinate_of(v, i, k) : slab_force_of(v, i, k));
    const double sum = BlockReduce(temp).Sum(f);
    if (threadIdx.x == 0) partials[static_cast<size_t>(k) * gridDim.x + blockIdx.x] = sum;
    __syncthreads();
  }
}

template <class Real>
__global__ void slab_finish_kernel(const double* partials, int blocks, RigidSlabBody* bodies,
                                   int count, double dt, bool kick, Real* velocity) {
  using BlockReduce = cub::BlockReduce<double, 256>;
  __shared__ typename BlockReduce::TempStorage temp;
  for (int k = 0; k < count; ++k) {
    double part = 0;
    for (int b = threadIdx.x; b < blocks; b += blockDim.x)
      part += partials[static_cast<size_t>(k) * blocks + b];
    const double sum = BlockReduce(temp).Sum(part);
    if (threadIdx.x == 0) {
      slab_set_force(bodies[k], sum);
      if (kick) slab_full_kick(bodies[k], dt);
      velocity[k] = static_cast<Real>(bodies[k].velocity);
    }
    __syncthreads();
  }
}

// Injection/ejection (sim/injection.h), one pick at a time: the smallest key among the
// candidates, then the particle holding it moves (counts: injected, missed per boundary).
template <class Real>
__global__ void injection_key_kernel(StepView<Real> v, InjectionView<Real> inj, int pick,
                                     unsigned long long* best) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n) return;
  const std::uint64_t key = injection_key_of(v, inj, i, pick);
  if (key != kNoInjectionCandidate) atomicMin(best, static_cast<unsigned long long>(key));
}

template <class Real>
__global__ void injection_apply_kernel(StepView<Real> v, InjectionView<Real> inj, int pick,
                                       const unsigned long long* best, unsigned long long* counts) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const unsigned long long b = *best;
  if (b == kNoInjectionCandidate) {
    if (i == 0) atomicAdd(counts + 2 * inj.index + 1, 1ull);
    return;
  }
  if (i < v.n && injection_key_of(v, inj, i, pick) == b) {
    inject_particle(v, inj, i, pick);
    atomicAdd(counts + 2 * inj.index, 1ull);
  }
}

template <class Real>
__global__ void neighbour_count_kernel(StepView<Real> v, int* counts) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) counts[i] = neighbour_count(v, i);
}

// ---- Domain decomposition (sim/domain/exchange.h): the storage operations, on the device. ----
// flag: 0 owned and inside the region (position wrapped across periodic faces), 1 leaving, 2 a
// ghost; keep/leave are the 0/1 flags CUB's stable selection takes.
template <class Real>
__global__ void migrate_flag_kernel(StepView<Real> v, LocalRegion<Real> region, unsigned char* keep,
                                    unsigned char* leave) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n) return;
  keep[i] = leave[i] = 0;
  if (v.origin[i] < 0) return;
  Real x[3] = {v.x[i], v.y[i], v.z[i]};
  region.wrap(x);
  v.x[i] = x[0], v.y[i] = x[1], v.z[i] = x[2];
  const bool inside = region.contains(x);
  keep[i] = inside;
  leave[i] = !inside;
}

template <class Real>
__global__ void pack_migrants_kernel(StepView<Real> v, const int* idx, int m,
                                     MigrantRecord<Real>* out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= m) return;
  const int i = idx[k];
  MigrantRecord<Real> r;
  r.x[0] = v.x[i], r.x[1] = v.y[i], r.x[2] = v.z[i];
  r.v[0] = v.vx[i], r.v[1] = v.vy[i], r.v[2] = v.vz[i];
  const bool est = v.vex != nullptr;
  r.ve[0] = est ? v.vex[i] : r.v[0];
  r.ve[1] = est ? v.vey[i] : r.v[1];
  r.ve[2] = est ? v.vez[i] : r.v[2];
  r.f[0] = v.fx[i], r.f[1] = v.fy[i], r.f[2] = v.fz[i];
  r.type = v.type[i];
  r.id = v.id[i];
  r.left_to_grid = v.left_to_grid ? v.left_to_grid[i] : 0;
  out[k] = r;
}

template <class Real>
__global__ void unpack_migrants_kernel(StepView<Real> v, const MigrantRecord<Real>* in, int m,
                                       int base, std::int32_t* origin) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= m) return;
  const int i = base + k;
  const MigrantRecord<Real>& r = in[k];
  v.x[i] = r.x[0], v.y[i] = r.x[1], v.z[i] = r.x[2];
  v.vx[i] = r.v[0], v.vy[i] = r.v[1], v.vz[i] = r.v[2];
  if (v.vex != nullptr) v.vex[i] = r.ve[0], v.vey[i] = r.ve[1], v.vez[i] = r.ve[2];
  v.fx[i] = r.f[0], v.fy[i] = r.f[1], v.fz[i] = r.f[2];
  v.rho[i] = Real(0);
  if (v.bvf != nullptr) v.bvf[i] = Real(0);
  const_cast<std::int32_t*>(v.type)[i] = r.type;
  const_cast<std::int64_t*>(v.id)[i] = r.id;
  if (v.left_to_grid) v.left_to_grid[i] = r.left_to_grid;
  origin[i] = base + k;
}

__global__ void iota_kernel(std::int32_t* a, int n) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) a[i] = i;
}

template <class Real>
__global__ void ghost_flag_kernel(StepView<Real> v, HaloBox<Real> box, unsigned char* flag) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) flag[i] = v.origin[i] >= 0 && box.contains(v.x[i], v.y[i], v.z[i]);
}

template <class Real>
__device__ MESO_INLINE GhostRecord<Real> ghost_record_of(const StepView<Real>& v, int i,
                                                         const Real* shift) {
  GhostRecord<Real> r;
  r.x[0] = v.x[i] + shift[0], r.x[1] = v.y[i] + shift[1], r.x[2] = v.z[i] + shift[2];
  const bool est = v.vex != nullptr;
  r.ve[0] = est ? v.vex[i] : Real(0);
  r.ve[1] = est ? v.vey[i] : Real(0);
  r.ve[2] = est ? v.vez[i] : Real(0);
  r.type = v.type[i];
  r.id = v.id[i];
  return r;
}

template <class Real>
__global__ void pack_ghosts_kernel(StepView<Real> v, const int* idx, int m, HaloBox<Real> box,
                                   int box_index, GhostRecord<Real>* out, std::int32_t* slots,
                                   int* boxes) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= m) return;
  const int i = idx[k];
  out[k] = ghost_record_of(v, i, box.shift);
  slots[k] = v.origin[i];
  boxes[k] = box_index;
}

template <class Real>
__global__ void unpack_ghosts_kernel(StepView<Real> v, const GhostRecord<Real>* in, int m, int base,
                                     std::int32_t* origin) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= m) return;
  const int i = base + k;
  const GhostRecord<Real>& r = in[k];
  v.x[i] = r.x[0], v.y[i] = r.x[1], v.z[i] = r.x[2];
  v.vx[i] = v.vy[i] = v.vz[i] = Real(0);
  if (v.vex != nullptr) v.vex[i] = r.ve[0], v.vey[i] = r.ve[1], v.vez[i] = r.ve[2];
  v.fx[i] = v.fy[i] = v.fz[i] = Real(0);
  v.rho[i] = Real(0);
  if (v.bvf != nullptr) v.bvf[i] = Real(0);
  const_cast<std::int32_t*>(v.type)[i] = r.type;
  const_cast<std::int64_t*>(v.id)[i] = r.id;
  origin[i] = -1 - k;
}

// Where each owned slot stands in the cell-sorted storage now.
__global__ void slot_index_kernel(const std::int32_t* origin, int n, int* slot_index) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n && origin[i] >= 0) slot_index[origin[i]] = i;
}

template <class Real>
__global__ void pack_sums_kernel(StepView<Real> v, const int* slot_index, const std::int32_t* slots,
                                 int m, Real* out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= m) return;
  const int i = slot_index[slots[k]];
  const int per = v.bvf != nullptr ? 2 : 1;
  out[k * per] = v.rho[i];
  if (per == 2) out[k * per + 1] = v.bvf[i];
}

template <class Real>
__global__ void set_ghost_sums_kernel(StepView<Real> v, const Real* in) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n || v.origin[i] >= 0) return;
  const int per = v.bvf != nullptr ? 2 : 1;
  const int k = -1 - v.origin[i];
  v.rho[i] = in[k * per];
  if (per == 2) v.bvf[i] = in[k * per + 1];
}

template <class Real>
__global__ void pack_refresh_kernel(StepView<Real> v, const int* slot_index,
                                    const std::int32_t* slots, const int* boxes,
                                    const HaloBox<Real>* box_list, int m, GhostRecord<Real>* out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < m) out[k] = ghost_record_of(v, slot_index[slots[k]], box_list[boxes[k]].shift);
}

template <class Real>
__global__ void set_ghost_refresh_kernel(StepView<Real> v, const GhostRecord<Real>* in) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n || v.origin[i] >= 0) return;
  const GhostRecord<Real>& r = in[-1 - v.origin[i]];
  v.x[i] = r.x[0], v.y[i] = r.x[1], v.z[i] = r.x[2];
  if (v.vex != nullptr) v.vex[i] = r.ve[0], v.vey[i] = r.ve[1], v.vez[i] = r.ve[2];
}

// Slab forces of a decomposed run: the per-slab sums go to the host to be summed over the ranks,
// then come back for the kicks.
__global__ void slab_sums_kernel(const double* partials, int blocks, int count, double* sums) {
  using BlockReduce = cub::BlockReduce<double, 256>;
  __shared__ typename BlockReduce::TempStorage temp;
  for (int k = 0; k < count; ++k) {
    double part = 0;
    for (int b = threadIdx.x; b < blocks; b += blockDim.x)
      part += partials[static_cast<size_t>(k) * blocks + b];
    const double sum = BlockReduce(temp).Sum(part);
    if (threadIdx.x == 0) sums[k] = sum;
    __syncthreads();
  }
}

template <class Real>
__global__ void slab_apply_kernel(const double* sums, RigidSlabBody* bodies, int count, double dt,
                                  bool kick, Real* velocity) {
  const int k = threadIdx.x;
  if (k >= count) return;
  slab_set_force(bodies[k], sums[k]);
  if (kick) slab_full_kick(bodies[k], dt);
  velocity[k] = static_cast<Real>(bodies[k].velocity);
}

// Reorder interval: flags when any particle has moved beyond limit2 since the last sort.
template <class Real>
__global__ void moved_kernel(StepView<Real> v, const Real* x0, const Real* y0, const Real* z0,
                             Real limit2, int* moved) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n && displacement2(v, x0, y0, z0, i) > limit2) *moved = 1;
}

// Virial of each particle and, for the thermal ones, its kinetic stress, summed per thread block
// (fixed tree order, so the result is the same every run); the host adds the per-block partials in
// block order. 24 doubles per block instead of per particle keeps the stress observable within the
// memory budget.
constexpr int kVirialSumsPerBlock = 24;  // VirialSums: conservative, dissipative, random, kinetic
template <class Real, class C, class T, class W>
__global__ void virial_kernel(StepView<Real> v, VirialRegion<Real> region, double* block_sums) {
  using BlockReduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename BlockReduce::TempStorage temp;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  ParticleVirial<Real> w;
  double kinetic[6] = {0, 0, 0, 0, 0, 0};
  if (i < v.n && region.contains(v, i)) {
    w = virial_of_particle<Real, C, T, W>(v, i);
    if (thermal(v, i)) add_kinetic_stress(v, i, kinetic);
  }
  double parts[4][6];  // in the order of kVirialSumsPerBlock
  for (int c = 0; c < 6; ++c) {
    parts[0][c] = static_cast<double>(w.conservative[c]);
    parts[1][c] = static_cast<double>(w.dissipative[c]);
    parts[2][c] = static_cast<double>(w.random[c]);
    parts[3][c] = kinetic[c];
  }
  for (int p = 0; p < 4; ++p)
    for (int c = 0; c < 6; ++c) {
      const double total = BlockReduce(temp).Sum(parts[p][c]);
      if (threadIdx.x == 0) block_sums[kVirialSumsPerBlock * blockIdx.x + 6 * p + c] = total;
      __syncthreads();  // temp is reused by the next reduction
    }
}

// The leak invariant per thread block: a tree in shared memory (raw storage: a __shared__ array
// of a type with member initialisers is not allowed), merged by the host in block order.
template <class Real>
__global__ void solid_intrusion_kernel(StepView<Real> v, SolidIntrusionSums* block_sums) {
  __shared__ alignas(SolidIntrusionSums) unsigned char raw[kBlock * sizeof(SolidIntrusionSums)];
  auto* s = reinterpret_cast<SolidIntrusionSums*>(raw);
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  s[threadIdx.x] = i < v.n ? solid_intrusion_of_particle(v, i) : SolidIntrusionSums{};
  __syncthreads();
  for (int stride = kBlock / 2; stride > 0; stride /= 2) {
    if (static_cast<int>(threadIdx.x) < stride) s[threadIdx.x].merge(s[threadIdx.x + stride]);
    __syncthreads();
  }
  if (threadIdx.x == 0) block_sums[blockIdx.x] = s[0];
}

// The watchdog's check after a step (sim/watchdog.h); hits go to the record in device memory.
// kKickFirst: the step's second kick first, in the same launch (one kernel fewer per step, which
// small systems and ensembles feel).
template <class Real, bool kKickFirst>
__global__ void watchdog_kernel(StepView<Real> v, Real max_speed2, WatchdogRecord* record) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n) return;
  if constexpr (kKickFirst) kick(v, i);
  double value = 0;
  const int q = watchdog_check(v, i, max_speed2, value);
  if (q != kWatchdogOk)
    watchdog_record(record, v.current_step(), v.id[i], q, value, double(v.x[i]), double(v.y[i]),
                    double(v.z[i]));
}

// Runs right after watchdog_kernel in the same step: returns at once unless this step's hits
// overflowed the slots; then finds the particle of the smallest id and puts its hit in slot 0,
// so the report names the same particle as the CPU's.
template <class Real>
__global__ void watchdog_resolve_kernel(StepView<Real> v, Real max_speed2, WatchdogRecord* record) {
  if (record->count <= static_cast<unsigned int>(kWatchdogSlots) || record->resolved ||
      record->first_step != static_cast<unsigned long long>(v.current_step()))
    return;
  for (int i = threadIdx.x; i < v.n; i += blockDim.x) {
    if (static_cast<unsigned long long>(v.id[i]) != record->min_id) continue;
    double value = 0;
    const int q = watchdog_check(v, i, max_speed2, value);
    if (q == kWatchdogOk) continue;  // a ghost copy of it in a decomposed run
    WatchdogHit& h = record->slots[0];
    h.step = v.current_step();
    h.id = v.id[i];
    h.quantity = q;
    h.value = value;
    h.position[0] = double(v.x[i]);
    h.position[1] = double(v.y[i]);
    h.position[2] = double(v.z[i]);
    record->resolved = 1;
  }
}

// Binned sums (count, v, v*v) with atomics. The order of the atomic additions varies, so the last
// bits of a GPU profile may differ between runs; the trajectory itself does not.
template <class Real>
__global__ void bin_kernel(StepView<Real> v, BinView<Real> b, double* sums) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n) return;
  const int bin = bin_of_particle(v, b, i);
  if (bin < 0) return;
  double* s = sums + static_cast<size_t>(kBinFields) * bin;
  double t[kBinFields];
  bin_terms(v, i, t);
  for (int c = 0; c < kBinFields; ++c) atomicAdd(s + c, t[c]);
}

// A grid of one bin (a region's sums, the sweep's flux): every counted particle would add to the
// same seven doubles, and those atomics serialise. Summed per thread block instead, added by the
// host in block order: faster, and the same bits every run.
template <class Real>
__global__ void one_bin_kernel(StepView<Real> v, BinView<Real> b, double* block_sums) {
  using BlockReduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename BlockReduce::TempStorage temp;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  double s[kBinFields] = {0, 0, 0, 0, 0, 0, 0};
  if (i < v.n && bin_of_particle(v, b, i) == 0) bin_terms(v, i, s);
  for (int c = 0; c < kBinFields; ++c) {
    const double total = BlockReduce(temp).Sum(s[c]);
    if (threadIdx.x == 0) block_sums[kBinFields * blockIdx.x + c] = total;
    __syncthreads();
  }
}

template <class Real, class Terms>
class CudaEngine final : public Engine<Real>,
                         public DomainStore<Real>,
                         private Stepper<Real, Terms, CudaEngine<Real, Terms>> {
  using Steps = Stepper<Real, Terms, CudaEngine<Real, Terms>>;
  friend Steps;
  using C = typename Terms::conservative;
  using T = typename Terms::thermostat;
  using W = typename Terms::wall_model;

 public:
  explicit CudaEngine(const CudaEngineOptions& o)
      : device_(o.device),
        profile_(o.profile),
        frozen_part_(o.frozen_part),
        burying_(o.buried_part),
        graphs_(o.graphs),
        lanes_(o.lanes),
        masking_(o.penetration_mask),
        listing_density_(o.frozen_density_list) {
    check(cudaSetDevice(device_), "cudaSetDevice");
    if (profile_)
      for (auto& e : events_) check(cudaEventCreate(&e), "cudaEventCreate");
  }
  ~CudaEngine() override {
    if (profile_)
      for (auto& e : events_) cudaEventDestroy(e);
    if (count_host_) cudaFreeHost(count_host_);
    if (watchdog_host_) cudaFreeHost(watchdog_host_);
    if (watchdog_event_) cudaEventDestroy(watchdog_event_);
    for (CapturedSteps& g : graphs_kept_)
      if (g.exec) cudaGraphExecDestroy(g.exec);
    for (cudaEvent_t e : launch_done_)
      if (e) cudaEventDestroy(e);
  }

  const char* name() const override { return "cuda"; }

  void initialize(HostState<Real>& host, StepHooks<Real>& hooks) override {
    this->attach_hooks(hooks);
    upload(host);
    this->initial_forces();
    check(cudaStreamSynchronize(cudaStreamPerThread), "initial forces");
  }

  void restore(HostState<Real>& host, std::uint64_t wall_corrections,
               StepHooks<Real>& hooks) override {
    this->attach_hooks(hooks);
    upload(host);
    corrected_ = wall_corrections;
    // A single-rank checkpoint is already sorted (stable sort: no particle moves); a gathered one
    // (decomposed run) is in the original order, so the last forces move with their particles.
    this->sort(true);
    check(cudaStreamSynchronize(cudaStreamPerThread), "restore");
  }

  void upload(HostState<Real>& host) {
    lane_list_ready_ = false;
    host_ = &host;
    frozen_sums_valid_ = false;
    buried_part_ = false;
    buried_count_ = 0;
    warmed_ = false;
    ++epoch_;
    corrected_ = wall_corrections();  // the count before the sort, kept
    if (early_count_.size() > 0)
      check(cudaMemset(early_count_.get(), 0, sizeof(unsigned long long)), "count reset");
    const int n = host.size();
    n_ = n;
    upload_real_arrays(host);
    type_.upload(host.type);
    id_.upload(host.id);
    origin_.upload(host.origin);
    table_.upload(host.table);
    body_force_.upload(host.body_force);
    if (host.solid.enabled()) {  // the solid grid's bytes, once (they never change)
      const std::size_t voxels =
          static_cast<std::size_t>(host.solid.dims[0]) * host.solid.dims[1] * host.solid.dims[2];
      if (solid_.size() != voxels)
        solid_.upload(std::vector<std::uint8_t>(host.solid.solid, host.solid.solid + voxels));
    }
    if constexpr (W::enabled) {
      bvf_.upload(host.bvf);
      kappa_.upload(host.kappa);
      left_to_grid_.upload(host.left_to_grid);  // empty unless the solid grid bounces too
      left_to_grid_alt_.resize(host.left_to_grid.size());
      count_.resize(1);
      check(cudaMallocHost(&count_host_, sizeof(unsigned int)), "cudaMallocHost");
    }
    ncells_ = host.grid.count();
    size_cell_arrays();
    cell_.resize(static_cast<size_t>(n));
    cell_slots_.resize(static_cast<size_t>(n));
    index_.resize(static_cast<size_t>(n));
    perm_.resize(static_cast<size_t>(n));
    const auto moved = moved_reals();
    for (size_t a = 0; a < moved.size(); ++a) moved_alt_[a].resize(moved[a]->size());
    type_alt_.resize(static_cast<size_t>(n));
    origin_alt_.resize(static_cast<size_t>(n));
    id_alt_.resize(static_cast<size_t>(n));
    step_base_.resize(1);
    step_ = host.step;
    dt_ = host.dt;
    nslabs_ = static_cast<int>(host.slab_bodies.size());
    if (nslabs_ > 0) {
      slab_bodies_.upload(host.slab_bodies);
      slab_half_velocity_.upload(host.slab_half_velocity);
      slab_velocity_.upload(host.slab_velocity);
      slab_partials_.resize(static_cast<size_t>(nslabs_) * blocks_for(n));
    }
  }

  // The slabs' total forces from the last force pass, then (kick) their second half kick. A
  // decomposed run sums them over the ranks on the host in between.
  void slab_forces(bool kick) {
    if (nslabs_ == 0) return;
    const int g = blocks_for(n_);
    slab_partials_.set_size(static_cast<size_t>(nslabs_) * g);
    slab_partials_kernel<Real><<<g, kBlock>>>(view(), slab_partials_.get());
    if (!this->hooks().distributed()) {
      slab_finish_kernel<Real><<<1, 256>>>(slab_partials_.get(), g, slab_bodies_.get(), nslabs_,
                                           static_cast<double>(dt_), kick, slab_velocity_.get());
      return;
    }
    slab_sums_.set_size(static_cast<size_t>(nslabs_));
    slab_sums_kernel<<<1, 256>>>(slab_partials_.get(), g, nslabs_, slab_sums_.get());
    std::vector<double> sums;
    slab_sums_.download(sums);
    this->hooks().sum(sums.data(), nslabs_);
    slab_sums_.upload(sums);
    slab_apply_kernel<Real><<<1, kMaxRigidSlabs>>>(slab_sums_.get(), slab_bodies_.get(), nslabs_,
                                                   static_cast<double>(dt_), kick,
                                                   slab_velocity_.get());
  }

  // With graphs: runs of up to kGraphSteps steps (an even number) captured once and replayed
  // while nothing they bake in changes (graph_state_key); the first steps after set-up (until
  // the frozen part is sorted) and a last odd step step as usual. The watchdog polls between
  // replays.
  void advance(std::uint64_t steps) override {
    check(cudaSetDevice(device_), "cudaSetDevice");
    if (!graphs_possible()) {
      this->run_steps(steps);
      return;
    }
    defer_poll_ = true;
    try {
      for (std::uint64_t done = 0; done < steps;) {
        const std::uint64_t run = std::min(steps - done, kGraphSteps) & ~std::uint64_t(1);
        if (!graph_ready() || run == 0) {
          this->run_steps(1);
          ++done;
        } else {
          run_graph(run);
          done += run;
        }
      }
    } catch (...) {
      defer_poll_ = false;
      throw;
    }
    defer_poll_ = false;
    this->finish_steps(steps);
  }

  void set_dt(Real dt) override { dt_ = dt; }
  void set_watchdog(const WatchdogOptions& o) override {
    this->watchdog_ = o;
    ++epoch_;
  }

  // The watchdog: a check kernel per step; the host reads the record every poll_steps steps
  // through pinned memory (reading the copy enqueued at the previous poll, long done by then) and
  // synchronously at the end of run().
  void kick_and_watchdog() { watchdog_step(true); }
  void watchdog_step(bool kick_first = false) {
    if (!this->watchdog_.enabled) {
      if (kick_first) for_each(view(), KickPass<Real>{});
      return;
    }
    if (!watchdog_host_) {
      watchdog_record_.upload(std::vector<WatchdogRecord>(1));
      check(cudaMallocHost(&watchdog_host_, sizeof(WatchdogRecord)), "cudaMallocHost");
      // Blocking: a host thread that waits for a poll sleeps instead of spinning, so the threads
      // of an ensemble (sim/ensemble.h) leave the cores to the others' launches.
      check(cudaEventCreateWithFlags(&watchdog_event_,
                                     cudaEventDisableTiming | cudaEventBlockingSync),
            "cudaEventCreate");
    }
    const double limit = watchdog_speed_limit(this->watchdog_, static_cast<double>(dt_));
    const Real limit2 = static_cast<Real>(limit * limit);
    if (kick_first)
      watchdog_kernel<Real, true>
          <<<blocks_for(n_), kBlock>>>(view(), limit2, watchdog_record_.get());
    else
      watchdog_kernel<Real, false>
          <<<blocks_for(n_), kBlock>>>(view(), limit2, watchdog_record_.get());
    watchdog_resolve_kernel<Real><<<1, 256>>>(view(), limit2, watchdog_record_.get());
    if (capturing_) return;  // counted when the graph is launched
    if (++watchdog_since_poll_ >= this->watchdog_.poll_steps) watchdog_poll(false);
  }
  void watchdog_poll(bool now) {
    watchdog_since_poll_ = 0;
    if (watchdog_pending_) {
      check(cudaEventSynchronize(watchdog_event_), "watchdog poll");
      watchdog_pending_ = false;
      watchdog_throw_if_hit();
    }
    if (now) {
      check(cudaMemcpy(watchdog_host_, watchdog_record_.get(), sizeof(WatchdogRecord),
                       cudaMemcpyDeviceToHost),
            "watchdog read");
      watchdog_throw_if_hit();
    } else {
      check(cudaMemcpyAsync(watchdog_host_, watchdog_record_.get(), sizeof(WatchdogRecord),
                            cudaMemcpyDeviceToHost),
            "watchdog copy");
      check(cudaEventRecord(watchdog_event_), "watchdog event");
      watchdog_pending_ = true;
    }
  }
  void watchdog_throw_if_hit() const {
    WatchdogHit hit;
    if (first_watchdog_hit(*watchdog_host_, hit))
      throw NumericalError(watchdog_message(hit, this->watchdog_, static_cast<double>(dt_)));
  }
  std::uint64_t step() const override { return step_; }

  void download(HostState<Real>& host) override {
    check(cudaStreamSynchronize(cudaStreamPerThread), "step");
    DeviceBuffer<Real>* arrays[] = {&x_,   &y_,   &z_,  &vx_, &vy_, &vz_, &vex_,
                                    &vey_, &vez_, &fx_, &fy_, &fz_, &rho_};
    std::vector<Real>* targets[] = {&host.x,  &host.y,   &host.z,   &host.vx,  &host.vy,
                                    &host.vz, &host.vex, &host.vey, &host.vez, &host.fx,
                                    &host.fy, &host.fz,  &host.rho};
    for (int a = 0; a < 13; ++a) arrays[a]->download(*targets[a]);
    type_.download(host.type);
    id_.download(host.id);
    origin_.download(host.origin);
    if constexpr (W::enabled) bvf_.download(host.bvf);
    if (nslabs_ > 0) {
      slab_bodies_.download(host.slab_bodies);
      slab_half_velocity_.download(host.slab_half_velocity);
      slab_velocity_.download(host.slab_velocity);
    }
    host.step = step_;
    host.dt = dt_;
  }

  // The injection/ejection events due at this step; the key search and the move stay on the
  // device (no synchronisation), the counters are read only when asked for.
  void inject() {
    const int g = blocks_for(n_);
    const StepView<Real> v = view();
    for (const InjectionPlan<Real>& plan : host_->injections) {
      if (!plan.due(step_)) continue;
      frozen_sums_valid_ = false;  // a pick may change a particle's type (the next sort is full)
      if (injection_best_.size() == 0) {
        injection_best_.resize(1);
        injection_counts_.resize(2 * kMaxInjections);
        check(cudaMemset(injection_counts_.get(), 0, 2 * kMaxInjections * sizeof(std::uint64_t)),
              "injection counters");
      }
      for (int pick = 0; pick < plan.per_event; ++pick) {
        check(cudaMemsetAsync(injection_best_.get(), 0xFF, sizeof(std::uint64_t)), "pick reset");
        auto* best = reinterpret_cast<unsigned long long*>(injection_best_.get());
        injection_key_kernel<<<g, kBlock>>>(v, plan.view, pick, best);
        if (this->hooks().distributed()) {  // the smallest key over the ranks
          std::vector<std::uint64_t> b;
          injection_best_.download(b);
          b[0] = this->hooks().min(b[0]);
          injection_best_.upload(b);
        }
        injection_apply_kernel<<<g, kBlock>>>(
            v, plan.view, pick, best,
            reinterpret_cast<unsigned long long*>(injection_counts_.get()));
      }
    }
  }

 public:
  std::vector<InjectionCounts> injection_counts() const override {
    std::vector<InjectionCounts> out(host_->injections.size());
    if (injection_counts_.size() == 0) return out;
    std::vector<std::uint64_t> c;
    injection_counts_.download(c);
    for (size_t k = 0; k < out.size(); ++k) {
      out[k].injected = c[2 * k];
      out[k].missed = c[2 * k + 1];
    }
    return out;
  }

  void neighbour_counts(std::vector<int>& counts) override {
    DeviceBuffer<int> d;
    d.resize(static_cast<size_t>(n_));
    if (n_ > 0) neighbour_count_kernel<<<blocks_for(n_), kBlock>>>(view(), d.get());
    check(cudaGetLastError(), "neighbour count kernel");
    d.download(counts);
  }

  VirialSums virial(const VirialRegion<Real>& region) override {
    // Allocated on first use only: runs that never ask for stress own no such buffer.
    const int g = blocks_for(n_);
    const std::vector<double> t = summed_blocks(
        virial_, kVirialSumsPerBlock, g, "virial kernel",
        [&](double* out) { virial_kernel<Real, C, T, W><<<g, kBlock>>>(view(), region, out); });
    VirialSums s;
    for (int c = 0; c < 6; ++c) {
      s.conservative[c] = t[c];
      s.dissipative[c] = t[6 + c];
      s.random[c] = t[12 + c];
      s.kinetic[c] = t[18 + c];
    }
    return s;
  }

  std::vector<RigidSlabBody> slab_bodies(std::vector<double>& coordinate_sums) override {
    std::vector<RigidSlabBody> bodies;
    if (nslabs_ > 0) slab_bodies_.download(bodies);
    coordinate_sums.assign(bodies.size(), 0.0);
    if (bodies.empty()) return bodies;
    const int g = blocks_for(n_);
    slab_coordinates_.resize(bodies.size() * static_cast<size_t>(g));
    slab_partials_kernel<Real, true><<<g, kBlock>>>(view(), slab_coordinates_.get());
    check(cudaGetLastError(), "slab coordinates kernel");
    std::vector<double> h;
    slab_coordinates_.download(h);
    for (size_t k = 0; k < bodies.size(); ++k)
      for (int b = 0; b < g; ++b) coordinate_sums[k] += h[k * static_cast<size_t>(g) + b];
    return bodies;
  }

  SolidIntrusion solid_intrusion() override {
    if (!host_->solid.enabled()) return {};
    const int g = blocks_for(n_);
    intrusion_.resize(static_cast<size_t>(g));
    solid_intrusion_kernel<Real><<<g, kBlock>>>(view(), intrusion_.get());
    check(cudaGetLastError(), "solid intrusion kernel");
    std::vector<SolidIntrusionSums> h;
    intrusion_.download(h);
    SolidIntrusionSums total;
    for (const SolidIntrusionSums& b : h) total.merge(b);
    return solid_intrusion_from(total);
  }

  // A reduction that `launch` writes per thread block, `fields` doubles each, into `buffer`
  // (allocated on first use): each field summed over the blocks in block order, the same bits
  // every run.
  template <class Launch>
  std::vector<double> summed_blocks(DeviceBuffer<double>& buffer, int fields, int blocks,
                                    const char* what, Launch&& launch) {
    buffer.resize(static_cast<size_t>(fields) * static_cast<size_t>(blocks));
    launch(buffer.get());
    check(cudaGetLastError(), what);
    std::vector<double> h;
    buffer.download(h);
    std::vector<double> total(static_cast<size_t>(fields), 0.0);
    for (int b = 0; b < blocks; ++b)
      for (int c = 0; c < fields; ++c)
        total[static_cast<size_t>(c)] += h[static_cast<size_t>(fields) * b + c];
    return total;
  }

  void bin_sums(const BinGrid& grid, std::vector<double>& sums) override {
    if (grid.count() == 1) {
      const int g = blocks_for(n_);
      sums = summed_blocks(one_bin_, kBinFields, g, "one-bin kernel", [&](double* out) {
        one_bin_kernel<<<g, kBlock>>>(view(), BinView<Real>::make(grid), out);
      });
      return;
    }
    // Sized by the largest grid asked for so far; nothing is held before the first request.
    const size_t len = grid.count() * kBinFields;
    if (bins_.size() < len) bins_.resize(len);
    check(cudaMemset(bins_.get(), 0, len * sizeof(double)), "bin reset");
    bin_kernel<<<blocks_for(n_), kBlock>>>(view(), BinView<Real>::make(grid), bins_.get());
    check(cudaGetLastError(), "bin kernel");
    sums.resize(len);
    check(cudaMemcpy(sums.data(), bins_.get(), len * sizeof(double), cudaMemcpyDeviceToHost),
          "bin download");
  }

 private:
  void upload_real_arrays(const HostState<Real>& h) {
    x_.upload(h.x), y_.upload(h.y), z_.upload(h.z);
    vx_.upload(h.vx), vy_.upload(h.vy), vz_.upload(h.vz);
    vex_.upload(h.vex), vey_.upload(h.vey), vez_.upload(h.vez);
    fx_.upload(h.fx), fy_.upload(h.fy), fz_.upload(h.fz);
    rho_.upload(h.rho);
  }

  StepView<Real> view() const {
    StepView<Real> v = host_->view();  // box, grid, parameters
    v.n = n_;
    v.x = x_.get(), v.y = y_.get(), v.z = z_.get();
    v.vx = vx_.get(), v.vy = vy_.get(), v.vz = vz_.get();
    v.vex = vex_.get(), v.vey = vey_.get(), v.vez = vez_.get();
    v.fx = fx_.get(), v.fy = fy_.get(), v.fz = fz_.get();
    v.rho = rho_.get();
    v.bvf = bvf_.get();
    v.left_to_grid = left_to_grid_on() ? left_to_grid_.get() : nullptr;
    v.walls.kappa = kappa_.get();
    if (v.solid.enabled()) v.solid.solid = solid_.get();
    v.slabs.half_velocity = slab_half_velocity_.get();
    v.slabs.velocity = slab_velocity_.get();
    v.type = type_.get();
    v.id = id_.get();
    v.origin = origin_.get();
    v.cell_start = cell_start_.get();
    v.frozen_part = split_frozen() ? ncells_ : 0;
    v.buried_part = buried_part_;
    if (frozen_sums_valid_) {
      v.frozen_rho = frozen_rho_.size() > 0 ? frozen_rho_.get() : nullptr;
      v.frozen_bvf = frozen_bvf_.size() > 0 ? frozen_bvf_.get() : nullptr;
      if (penetration_built_) {
        v.penetration = penetration_;
        v.penetration.bits = penetration_bits_.get();
      }
    }
    v.table = table_.get();
    v.body_force = body_force_.get();
    v.dt = dt_;
    v.inv_sqrt_dt = Real(1) / static_cast<Real>(std::sqrt(static_cast<double>(dt_)));
    v.step = step_;
    if (capturing_) {  // StepView::step_base
      v.step = step_ - capture_first_step_;
      v.step_base = step_base_.get();
    }
    return v;
  }

  // ---- The backend primitives of the step sequence (sim/stepper.h). ----
  HostState<Real>& host_state() { return *host_; }
  void next_step() { ++step_; }
  void poll_setup() {}

  template <class Body>
  void for_each(const StepView<Real>& v, Body body) {
    for_each_kernel<<<blocks_for(v.n), kBlock>>>(v, body);
  }
  // The pair passes gather per particle (each pair from both sides): no atomics. The sums pass
  // records each thread's neighbours (LaneList) and the force pass visits them; without a sums
  // pass (no many-body term, no walls) the force pass scans, and its neighbour stash keeps a
  // warp's lanes in step. A small system shares each particle's scan among with_lanes(n) threads
  // (LaneGroup), so that it has threads enough to fill the GPU.
  // Both pair passes stop before the buried part (StepView::buried_part), with the same count,
  // so that they see one neighbour-list layout.
  // With the frozen density list (density_listed()), the sums pass visits the mobile part and
  // the listed frozen particles, and the force pass the mobile part (a frozen particle's force is
  // zero, set at the full sort).
  template <class Pass>
  void pair_sums(const StepView<Real>& all, Pass pass) {
    const StepView<Real> v = stepping(all);
    const SumsRange r = density_listed() ? SumsRange{mobile_count_, mobile_count_ + density_listed_,
                                                     density_list_.get()}
                                         : SumsRange{v.n, v.n, nullptr};
    with_lanes(v.n, [&](auto lanes) {
      constexpr int L = decltype(lanes)::value;
      const dim3 grid(blocks_for(L * r.count));
      if (r.listed)
        for_each_lanes_kernel<L, true><<<grid, kBlock>>>(v, pass, lane_list(L, v.n), r);
      else
        for_each_lanes_kernel<L, false><<<grid, kBlock>>>(v, pass, lane_list(L, v.n), r);
      lane_list_ready_ = true;
    });
  }
  template <class Pass>
  void pair_forces(const StepView<Real>& all, Pass pass) {
    const StepView<Real> v = stepping(all);
    with_lanes(v.n, [&](auto lanes) {
      constexpr int L = decltype(lanes)::value;
      const int g = blocks_for(L * (lane_list_ready_ && density_listed() ? mobile_count_ : v.n));
      if (lane_list_ready_)
        for_each_replaying_kernel<L><<<g, kBlock>>>(v, pass, lane_list(L, v.n));
      else
        for_each_stashed_lanes_kernel<L><<<g, kBlock, kStashBytes>>>(v, pass);
    });
    lane_list_ready_ = false;
  }
  // The frozen density list holds (update_density_list).
  bool density_listed() const {
    return !kBoundNoFrozenSums && frozen_sums_valid_ && density_list_built_;
  }
  // The particles a step's pair passes visit: all but the buried part.
  // (kBoundNoFrozenSums: the mobile part alone.)
  StepView<Real> stepping(StepView<Real> v) const {
    v.n = kBoundNoFrozenSums && frozen_sums_valid_ ? mobile_count_ : v.n - buried_count_;
    return v;
  }
  // The lanes' neighbour list (LaneList) for L lanes of n particles, grown when it must be (the
  // first step of a run, before any graph is captured; a decomposed run's count changes). The
  // sums pass and the force pass after it ask with the same L and n, so they see one layout.
  LaneList lane_list(int lanes, int n) {
    const size_t threads = static_cast<size_t>(lanes) * static_cast<size_t>(n);
    const size_t capacity = static_cast<size_t>(lane_list_capacity(lanes));
    if (lane_list_counts_.size() < threads) lane_list_counts_.set_size(threads);
    if (lane_list_slots_.size() < threads * capacity) lane_list_slots_.set_size(threads * capacity);
    return LaneList{lane_list_slots_.get(), lane_list_counts_.get(), static_cast<int>(threads)};
  }
  // Calls launch(L) with L, the threads per particle of the gather passes, as a compile-time
  // constant: SimulationOptions::lanes_per_particle, or by the particle count (sim/simulation.h).
  template <class Launch>
  void with_lanes(int n, Launch&& launch) const {
    const int lanes = lanes_ > 0             ? lanes_
                      : n <= kEightLanesUpTo ? 8
                      : n <= kFourLanesUpTo  ? 4
                      : n <= kTwoLanesUpTo   ? 2
                                             : 1;
    switch (lanes) {
      case 8:
        launch(std::integral_constant<int, 8>{});
        break;
      case 4:
        launch(std::integral_constant<int, 4>{});
        break;
      case 2:
        launch(std::integral_constant<int, 2>{});
        break;
      default:
        launch(std::integral_constant<int, 1>{});
    }
  }

  // The wall model's corrector after the sums. The re-sort decision needs the count on the host:
  // one small synchronising copy per step, paid only by scenes with the wall model.
  unsigned int correct_penetrations() {
    check(cudaMemsetAsync(count_.get(), 0, sizeof(unsigned int)), "count reset");
    correction_kernel<Real, T::enabled><<<blocks_for(n_), kBlock>>>(view(), count_.get());
    check(cudaMemcpy(count_host_, count_.get(), sizeof(unsigned int), cudaMemcpyDeviceToHost),
          "correction count");
    corrected_ += *count_host_;
    ++late_steps_;
    return *count_host_;
  }
  // The corrector before the sort, once the frozen part is sorted and its sums hold: no count
  // comes back (nothing waits for it; wall_corrections() reads the total).
  static constexpr bool kCorrectsBeforeSort = true;
  bool frozen_part_ready() const { return frozen_sums_valid_; }
  void correct_against_frozen_part() {
    if (kBoundNoCorrector) return;
    if (early_count_.size() == 0) {
      early_count_.resize(1);
      check(cudaMemset(early_count_.get(), 0, sizeof(unsigned long long)), "count reset");
    }
    ++early_steps_;
    const StepView<Real> v = view();
    if (!penetration_built_) {
      correction_before_sort_kernel<Real, T::enabled>
          <<<blocks_for(n_), kBlock>>>(v, early_count_.get());
      return;
    }
    needs_frozen_phi_kernel<<<blocks_for(mobile_count_), kBlock>>>(v, mobile_count_,
                                                                   penetration_flag_.get());
    select_flagged(penetration_flag_.get(), mobile_count_, penetration_list_.get(),
                   penetration_listed_.get(), penetration_temp_);
    if (profile_ && listed_total_.size() == 0) {
      listed_total_.resize(1);
      check(cudaMemset(listed_total_.get(), 0, sizeof(unsigned long long)), "listed reset");
    }
    correction_listed_kernel<Real, T::enabled><<<blocks_for(mobile_count_), kBlock>>>(
        v, penetration_list_.get(), penetration_listed_.get(), early_count_.get(),
        profile_ ? listed_total_.get() : nullptr);
    listed_steps_ += profile_;
  }

  // Reorder interval only: the positions at the last sort, and whether any particle has moved
  // beyond sqrt(limit2) since (one flag read back per step: only runs with an interval pay).
  bool sort_positions_stale() const { return x0_.size() != static_cast<size_t>(n_); }
  void remember_sort_positions() {
    for (auto [from, to] : {std::pair{&x_, &x0_}, std::pair{&y_, &y0_}, std::pair{&z_, &z0_}}) {
      to->set_size(static_cast<size_t>(n_));
      check(cudaMemcpyAsync(to->get(), from->get(), static_cast<size_t>(n_) * sizeof(Real),
                            cudaMemcpyDeviceToDevice),
            "sort positions");
    }
  }
  bool any_moved_beyond(Real limit2) {
    moved_.set_size(1);
    check(cudaMemsetAsync(moved_.get(), 0, sizeof(int)), "moved reset");
    moved_kernel<<<blocks_for(n_), kBlock>>>(view(), x0_.get(), y0_.get(), z0_.get(), limit2,
                                             moved_.get());
    std::vector<int> moved;
    moved_.download(moved);
    return moved[0] != 0;
  }

  void slab_half_kicks() {
    if (nslabs_ > 0)
      slab_half_kick_kernel<Real><<<1, kMaxRigidSlabs>>>(
          slab_bodies_.get(), nslabs_, static_cast<double>(dt_), slab_half_velocity_.get());
  }

  void finish_steps(std::uint64_t steps) {
    check(cudaGetLastError(), "step kernels");
    if (capturing_) return;
    warmed_ = true;
    if (this->watchdog_.enabled && steps > 0 && !defer_poll_) watchdog_poll(true);
  }

  // carry_forces: forces, densities and phi move with their particles too (a restored state; a
  // step's sort comes before its force pass, which writes them anew).
  // With a frozen part whose static sums hold, only the mobile part is sorted: the frozen
  // particles never move, so a stable sort would leave their part as it is.
  void sort_by_cell(bool carry_forces) {
    lane_list_ready_ = false;              // its indices are of the storage before the sort
    if (host_->grid.count() != ncells_) {  // a decomposed run re-balanced: a new cell grid
      ncells_ = host_->grid.count();
      size_cell_arrays();
      frozen_sums_valid_ = false;
    }
    const bool mobile_only = frozen_sums_valid_;
    ++(mobile_only ? mobile_sorts_ : full_sorts_);
    const int m = mobile_only ? mobile_count_ : n_;
    const int keys = mobile_only ? ncells_ : cell_keys();
    const bool bury = !mobile_only && may_bury();
    if (!mobile_only) buried_part_ = bury, buried_count_ = 0;
    // The counting sort (cell_count_kernel): keys and ranks (in index_), the counts summed into
    // cell_start, the particles into their cells' slots, then into index order within each cell.
    cell_count_kernel<<<blocks_for(m), kBlock>>>(view(), m, cell_.get(), index_.get(),
                                                 cell_count_.get(), bury);
    size_t temp = sort_temp_.size();
    check(cub::DeviceScan::ExclusiveSum(sort_temp_.get(), temp, cell_count_.get(),
                                        cell_start_.get(), keys + 1),
          "cell count sum");
    cell_scatter_kernel<<<blocks_for(std::max(m, keys + 1)), kBlock>>>(
        cell_.get(), index_.get(), m, cell_start_.get(), keys, cell_count_.get(),
        cell_slots_.get());
    // The frozen part behind the m sorted particles never changes while its sums hold, so it is
    // copied only until both buffers of each array hold it (the first sort after a full one).
    const int count = mobile_only && !tail_pending_ ? m : n_;
    order_in_cell_kernel<<<blocks_for(count), kBlock>>>(
        moved_table(), cell_.get(), cell_slots_.get(), m, count, cell_start_.get(), perm_.get());
    swap_moved();
    tail_pending_ = !mobile_only;
    if (carry_forces)  // through x's second buffer, free after the permutation
      for (DeviceBuffer<Real>* a : {&fx_, &fy_, &fz_, &rho_, &bvf_})
        if (a->size() > 0) {  // phi is empty without the wall model
          gather_kernel<<<blocks_for(n_), kBlock>>>(a->get(), moved_alt_[0].get(), perm_.get(), n_);
          a->swap(moved_alt_[0]);
        }
    if (!mobile_only && split_frozen()) update_frozen_sums();
  }

  // The arrays a sort moves: out[k] = in[perm[k]] for k < m, in[k] up to count; each into its
  // second buffer, then the two swap (every array is back in its own buffer after two sorts, which
  // lets a captured graph of an even number of steps be replayed).
  void permute_moved(int m, int count) {
    permute_kernel<<<blocks_for(count), kBlock>>>(moved_table(), perm_.get(), m, count);
    swap_moved();
  }
  // The arrays a sort moves, each with its second buffer; swap_moved makes the second the first.
  PermuteTable<Real> moved_table() {
    PermuteTable<Real> t;
    const auto reals = moved_reals();
    for (size_t a = 0; a < reals.size(); ++a)
      if (reals[a]->size() > 0) {  // v~ is empty without a thermostat
        t.in[t.reals] = reals[a]->get();
        t.out[t.reals++] = moved_alt_[a].get();
      }
    t.in_int[0] = type_.get(), t.out_int[0] = type_alt_.get();
    t.in_int[1] = origin_.get(), t.out_int[1] = origin_alt_.get();
    t.in_id = id_.get(), t.out_id = id_alt_.get();
    if (left_to_grid_on()) t.in_flag = left_to_grid_.get(), t.out_flag = left_to_grid_alt_.get();
    return t;
  }
  void swap_moved() {
    const auto reals = moved_reals();
    for (size_t a = 0; a < reals.size(); ++a)
      if (reals[a]->size() > 0) reals[a]->swap(moved_alt_[a]);
    type_.swap(type_alt_);
    origin_.swap(origin_alt_);
    id_.swap(id_alt_);
    if (left_to_grid_on()) left_to_grid_.swap(left_to_grid_alt_);
  }
  std::array<DeviceBuffer<Real>*, PermuteTable<Real>::kMaxReal> moved_reals() {
    return {&x_, &y_, &z_, &vx_, &vy_, &vz_, &vex_, &vey_, &vez_};
  }

  // After a full sort with a frozen part: where it starts, and its static sums (kept until the
  // frozen particles may have changed: a new state, particles added or removed, an injection).
  void update_frozen_sums() {
    check(cudaMemcpy(&mobile_count_, cell_start_.get() + ncells_, sizeof(int),
                     cudaMemcpyDeviceToHost),
          "mobile count");
    if (buried_part_) {
      int buried_start = n_;
      check(cudaMemcpy(&buried_start, cell_start_.get() + 2 * ncells_, sizeof(int),
                       cudaMemcpyDeviceToHost),
            "buried part");
      buried_count_ = n_ - buried_start;
    }
    const size_t frozen = static_cast<size_t>(n_ - mobile_count_);
    using K = std::conditional_t<C::needs_density, typename C::density_kernel, void>;
    if constexpr (C::needs_density || W::enabled) {
      if constexpr (C::needs_density) frozen_rho_.set_size(frozen > 0 ? frozen : 1);
      if constexpr (W::enabled) frozen_bvf_.set_size(frozen > 0 ? frozen : 1);
      frozen_sums_kernel<Real, K, W::enabled>
          <<<blocks_for(n_), kBlock>>>(view(), frozen_rho_.get(), frozen_bvf_.get());
    }
    frozen_sums_valid_ = true;
    if constexpr (W::enabled) update_penetration_mask(frozen > 0);
    if constexpr (C::needs_density || W::enabled) {
      update_density_list();
      // The sums no step changes, set here once: the buried part's, and with the density list
      // those of the frozen particles it leaves out (the listed ones' too, summed anew each step).
      const int first = density_list_built_ ? mobile_count_ : n_ - buried_count_;
      if (first < n_)
        buried_sums_kernel<<<blocks_for(n_ - first), kBlock>>>(view(), first,
                                                               typename Steps::Sums{});
    }
  }

  // The frozen density list, after a full sort that buried (the bounce holds the mobile part in
  // the pore): the frozen particles a step visits with a pore voxel within rd, the only ones whose
  // density a mobile particle can change (72-74% of them in the bench's Berea rock cases at 0.5
  // and 0.85 rc per voxel, 87% at 2.0; docs/benchmarks.md). Their indices from the frozen part's
  // start, in storage order; the count on the host, for the launches. The frozen forces, which the
  // force pass then leaves alone, are zeroed.
  void update_density_list() {
    density_list_built_ = false;
    density_listed_ = 0;
    const int visited = n_ - buried_count_ - mobile_count_;
    if (!listing_density_ || !buried_part_ || visited <= 0) return;
    flag_a_.set_size(static_cast<size_t>(visited));
    density_may_change_kernel<<<blocks_for(visited), kBlock>>>(view(), mobile_count_, visited,
                                                               flag_a_.get());
    density_listed_ = select(flag_a_, density_list_, visited);
    const size_t frozen_bytes = static_cast<size_t>(n_ - mobile_count_) * sizeof(Real);
    for (DeviceBuffer<Real>* f : {&fx_, &fy_, &fz_})
      check(cudaMemsetAsync(f->get() + mobile_count_, 0, frozen_bytes), "frozen forces");
    density_list_built_ = true;
  }

  // The penetration mask (StepView::penetration) of the frozen part just sorted: cells of
  // kPenetrationCell rc or more, at most kPenetrationCells of them.
  void update_penetration_mask(bool any_frozen) {
    penetration_built_ = false;
    // A decomposed run sorts its frozen part anew after every exchange: no mask to rebuild each
    // time.
    if (!masking_ || !any_frozen || this->hooks().distributed()) return;
    const Box<Real>& box = host_->box;
    penetration_ =
        penetration_mask_geometry<Real>(box.lo, box.length, kPenetrationCell, kPenetrationCells);
    const std::size_t words = penetration_.words();  // at most 2^28 / 32
    penetration_bits_.set_size(words);
    penetration_mask_kernel<<<blocks_for(static_cast<int>(words)), kBlock>>>(
        view(), penetration_, penetration_bits_.get());
    check(cudaGetLastError(), "penetration mask");
    // The selection's flags, list and scratch, sized here: a captured step may not allocate.
    const size_t m = static_cast<size_t>(mobile_count_ > 0 ? mobile_count_ : 1);
    penetration_list_.set_size(m);
    penetration_flag_.set_size(m);
    penetration_listed_.set_size(1);
    size_selection(mobile_count_, penetration_temp_);
    penetration_built_ = true;
  }
  // The mobile particles the corrector scanned, as a share of the mobile part (profiling).
  double listed_share() const {
    if (listed_steps_ == 0 || mobile_count_ == 0) return 0;
    std::vector<unsigned long long> total;
    listed_total_.download(total);
    return static_cast<double>(total[0]) / static_cast<double>(listed_steps_) / mobile_count_;
  }
  // The share of the mask's cells inside the box that are set (profiling).
  double penetration_share() const {
    std::vector<std::uint32_t> bits;
    penetration_bits_.download(bits);
    std::size_t set = 0;
    for (std::uint32_t w : bits) set += static_cast<std::size_t>(__builtin_popcount(w));
    double in_box = 1;
    for (int a = 0; a < 3; ++a)
      in_box *= std::ceil(static_cast<double>(host_->box.length[a]) * penetration_.inv_cell[a]);
    return static_cast<double>(set) / in_box;
  }

  // Whether a full sort may bury (StepView::buried_part; HostState::may_bury): with the frozen
  // part, on one rank, and no mobile particle in the solid now.
  bool may_bury() {
    return burying_ && split_frozen() && host_->may_bury() && !this->hooks().distributed() &&
           solid_intrusion().inside == 0;
  }

 public:
  // ---- DomainStore (sim/domain/exchange.h): stable selections (CUB) and pack/unpack kernels,
  // so the storage never leaves the device; only the packed records cross to the host for MPI.
  int owned_count() const override { return n_ - ghost_count_; }

  void drop_ghosts_take_leavers(const LocalRegion<Real>& region,
                                std::vector<MigrantRecord<Real>>& leavers) override {
    const int g = blocks_for(n_);
    flag_a_.set_size(static_cast<size_t>(n_));
    flag_b_.set_size(static_cast<size_t>(n_));
    migrate_flag_kernel<<<g, kBlock>>>(view(), region, flag_a_.get(), flag_b_.get());
    const int kept = select(flag_a_, perm_, n_);
    const int leaving = n_ - ghost_count_ - kept;
    if (leaving > 0) {
      select(flag_b_, index_, n_);
      migrants_.set_size(static_cast<size_t>(leaving));
      pack_migrants_kernel<<<blocks_for(leaving), kBlock>>>(view(), index_.get(), leaving,
                                                            migrants_.get());
      std::vector<MigrantRecord<Real>> out;
      migrants_.download(out);
      leavers.insert(leavers.end(), out.begin(), out.end());
    }
    ghost_count_ = 0;
    if (kept == n_) {  // nothing left and there were no ghosts: no compaction
      iota_kernel<<<g, kBlock>>>(origin_.get(), n_);
      return;
    }
    // Compact: the kept particles, in order, to the front (velocities, v~, positions, type, id;
    // origin is renumbered below; forces and sums are recomputed before they are read).
    permute_moved(kept, kept);
    resize_particles(kept);
    iota_kernel<<<blocks_for(kept), kBlock>>>(origin_.get(), kept);
  }

  void add_owned(const std::vector<MigrantRecord<Real>>& in) override {
    if (in.empty()) return;
    const int base = n_, m = static_cast<int>(in.size());
    resize_particles(base + m);
    migrants_.upload(in);
    unpack_migrants_kernel<<<blocks_for(m), kBlock>>>(view(), migrants_.get(), m, base,
                                                      origin_.get());
  }

  void pack_ghosts(const std::vector<HaloBox<Real>>& boxes, std::vector<GhostRecord<Real>>& out,
                   std::vector<int>& counts) override {
    counts.assign(boxes.size(), 0);
    send_count_ = 0;
    if (boxes.empty()) return;
    send_boxes_.upload(boxes);
    int total = 0;
    flag_a_.set_size(static_cast<size_t>(n_));
    for (size_t b = 0; b < boxes.size(); ++b) {
      ghost_flag_kernel<<<blocks_for(n_), kBlock>>>(view(), boxes[b], flag_a_.get());
      const int m = select(flag_a_, index_, n_);
      counts[b] = m;
      if (m == 0) continue;
      ghosts_out_.set_size(static_cast<size_t>(total + m));
      send_slots_.set_size(static_cast<size_t>(total + m));
      send_box_.set_size(static_cast<size_t>(total + m));
      pack_ghosts_kernel<<<blocks_for(m), kBlock>>>(
          view(), index_.get(), m, boxes[b], static_cast<int>(b), ghosts_out_.get() + total,
          send_slots_.get() + total, send_box_.get() + total);
      total += m;
    }
    send_count_ = total;
    ghosts_out_.set_size(static_cast<size_t>(total));
    std::vector<GhostRecord<Real>> h;
    ghosts_out_.download(h);
    out.insert(out.end(), h.begin(), h.end());
  }

  void add_ghosts(const std::vector<GhostRecord<Real>>& in) override {
    const int base = n_, m = static_cast<int>(in.size());
    ghost_count_ = m;
    if (m == 0) return;
    resize_particles(base + m);
    ghosts_in_.upload(in);
    unpack_ghosts_kernel<<<blocks_for(m), kBlock>>>(view(), ghosts_in_.get(), m, base,
                                                    origin_.get());
  }

  int sums_per_particle() const override { return W::enabled ? 2 : 1; }

  void pack_sums(std::vector<Real>& out) override {
    if (send_count_ == 0) return;
    map_slots();
    sums_out_.set_size(static_cast<size_t>(send_count_ * sums_per_particle()));
    pack_sums_kernel<<<blocks_for(send_count_), kBlock>>>(
        view(), slot_index_.get(), send_slots_.get(), send_count_, sums_out_.get());
    std::vector<Real> h;
    sums_out_.download(h);
    out.insert(out.end(), h.begin(), h.end());
  }

  void set_ghost_sums(const std::vector<Real>& in) override {
    if (in.empty()) return;
    sums_in_.upload(in);
    set_ghost_sums_kernel<<<blocks_for(n_), kBlock>>>(view(), sums_in_.get());
  }

  void pack_refresh(std::vector<GhostRecord<Real>>& out) override {
    if (send_count_ == 0) return;
    map_slots();
    ghosts_out_.set_size(static_cast<size_t>(send_count_));
    pack_refresh_kernel<<<blocks_for(send_count_), kBlock>>>(
        view(), slot_index_.get(), send_slots_.get(), send_box_.get(), send_boxes_.get(),
        send_count_, ghosts_out_.get());
    std::vector<GhostRecord<Real>> h;
    ghosts_out_.download(h);
    out.insert(out.end(), h.begin(), h.end());
  }

  void set_ghost_refresh(const std::vector<GhostRecord<Real>>& in) override {
    if (in.empty()) return;
    ghosts_in_.upload(in);
    frozen_sums_valid_ = false;
    set_ghost_refresh_kernel<<<blocks_for(n_), kBlock>>>(view(), ghosts_in_.get());
  }

 private:
  // Indices i < m with flag[i] = 1, in order (CUB's stable selection), into `out`; returns how
  // many. Host-synchronising: for the full sort and the decomposition's exchanges, not a step.
  int select(DeviceBuffer<unsigned char>& flag, DeviceBuffer<int>& out, int m) {
    out.set_size(static_cast<size_t>(m > 0 ? m : 1));
    selected_.set_size(1);
    size_selection(m, select_temp_);
    select_flagged(flag.get(), m, out.get(), selected_.get(), select_temp_);
    std::vector<int> count;
    selected_.download(count);
    return count[0];
  }
  // CUB's scratch for a selection among m flags, grown in `temp` when it must (a captured step
  // must find it grown: the corrector's is sized at the full sort, update_penetration_mask).
  static void size_selection(int m, DeviceBuffer<unsigned char>& temp) {
    size_t bytes = 0;
    check(cub::DeviceSelect::Flagged(nullptr, bytes, thrust::counting_iterator<int>(0),
                                     static_cast<const unsigned char*>(nullptr),
                                     static_cast<int*>(nullptr), static_cast<int*>(nullptr), m),
          "select sizing");
    bytes = std::max<size_t>(bytes, 1);
    if (temp.size() < bytes) temp.set_size(bytes);
  }
  // The selection on the stream, the count left in device memory at *count, with `temp` sized
  // by size_selection beforehand (not here: the corrector selects every step).
  void select_flagged(const unsigned char* flag, int m, int* out, int* count,
                      DeviceBuffer<unsigned char>& temp) {
    size_t bytes = temp.size();
    check(cub::DeviceSelect::Flagged(temp.get(), bytes, thrust::counting_iterator<int>(0), flag,
                                     out, count, m),
          "select");
  }

  void map_slots() {
    slot_index_.set_size(static_cast<size_t>(owned_count() > 0 ? owned_count() : 1));
    slot_index_kernel<<<blocks_for(n_), kBlock>>>(origin_.get(), n_, slot_index_.get());
  }

  // Every per-particle buffer to n entries (contents kept), and the sort's scratch to match.
  void resize_particles(int n) {
    const size_t s = static_cast<size_t>(n);
    frozen_sums_valid_ = false;
    warmed_ = false;
    for (DeviceBuffer<Real>* a : {&x_, &y_, &z_, &vx_, &vy_, &vz_, &fx_, &fy_, &fz_, &rho_})
      a->set_size(s);
    if constexpr (T::enabled)
      for (DeviceBuffer<Real>* a : {&vex_, &vey_, &vez_}) a->set_size(s);
    if constexpr (W::enabled) bvf_.set_size(s);
    const auto moved = moved_reals();
    for (size_t a = 0; a < moved.size(); ++a) moved_alt_[a].set_size(moved[a]->size());
    for (DeviceBuffer<std::int32_t>* a : {&type_, &origin_, &type_alt_, &origin_alt_})
      a->set_size(s);
    for (DeviceBuffer<std::int64_t>* a : {&id_, &id_alt_}) a->set_size(s);
    if (left_to_grid_on())
      for (DeviceBuffer<std::uint8_t>* a : {&left_to_grid_, &left_to_grid_alt_}) a->set_size(s);
    for (DeviceBuffer<int>* a : {&cell_, &cell_slots_, &index_, &perm_}) a->set_size(s);
    n_ = n;
  }

  // The cell sort's arrays that follow the cell grid: cell_start and the counts (keys + 1 each,
  // the counts zero between sorts) and the counts' sum's scratch.
  void size_cell_arrays() {
    const size_t keys = static_cast<size_t>(cell_keys());
    cell_start_.resize(keys + 1);
    cell_count_.resize(keys + 1);
    check(cudaMemset(cell_count_.get(), 0, (keys + 1) * sizeof(int)), "cell count reset");
    size_t temp = 0;
    check(cub::DeviceScan::ExclusiveSum(nullptr, temp, cell_count_.get(), cell_start_.get(),
                                        static_cast<int>(keys + 1)),
          "cell count sum sizing");
    sort_temp_.resize(temp);
  }

 public:
  std::uint64_t wall_corrections() const override {
    std::vector<unsigned long long> early;
    if (early_count_.size() > 0) early_count_.download(early);
    return corrected_ + (early.empty() ? 0 : early[0]);
  }

 private:
  // Profiling: events 0..7 (StepPhase) bound kick_drift | corrector | sort | density |
  // late_corrector | force | kick; the step's times are added up at its end.
  void mark(StepPhase phase) {
    if (!profile_) return;
    check(cudaEventRecord(events_[static_cast<int>(phase)]), "cudaEventRecord");
    if (phase == StepPhase::End) accumulate();
  }
  void accumulate() {
    check(cudaEventSynchronize(events_[kPasses]), "profile sync");
    for (int k = 0; k < kPasses; ++k) {
      float ms = 0;
      check(cudaEventElapsedTime(&ms, events_[k], events_[k + 1]), "cudaEventElapsedTime");
      pass_ms_[k] += ms;
    }
    ++profiled_steps_;
  }

 public:
  std::size_t device_bytes() const override {
    std::size_t b = 0;
    for (const DeviceBuffer<Real>* a :
         {&x_,          &y_,     &z_,  &vx_, &vy_, &vz_,         &vex_,
          &vey_,        &vez_,   &fx_, &fy_, &fz_, &rho_,        &bvf_,
          &body_force_, &kappa_, &x0_, &y0_, &z0_, &frozen_rho_, &frozen_bvf_})
      b += a->size() * sizeof(Real);
    for (const DeviceBuffer<Real>& a : moved_alt_) b += a.size() * sizeof(Real);
    for (const DeviceBuffer<std::int32_t>* a : {&type_, &origin_, &type_alt_, &origin_alt_})
      b += a->size() * sizeof(std::int32_t);
    b += (id_.size() + id_alt_.size()) * sizeof(std::int64_t);
    b += penetration_bits_.size() * sizeof(std::uint32_t) + penetration_temp_.size() +
         penetration_flag_.size() +
         (penetration_list_.size() + penetration_listed_.size()) * sizeof(int);
    b += density_list_.size() * sizeof(int) + flag_a_.size() + flag_b_.size() +
         select_temp_.size() + selected_.size() * sizeof(int);  // select()'s scratch
    for (const DeviceBuffer<int>* a : {&cell_, &cell_slots_, &index_, &perm_, &cell_start_,
                                       &cell_count_, &lane_list_slots_, &lane_list_counts_})
      b += a->size() * sizeof(int);
    b += sort_temp_.size() + solid_.size() + left_to_grid_.size() + left_to_grid_alt_.size() +
         table_.size() * sizeof(PairParams<Real>) +
         (virial_.size() + bins_.size() + one_bin_.size() + slab_coordinates_.size()) *
             sizeof(double) +
         intrusion_.size() * sizeof(SolidIntrusionSums);
    return b;
  }

  // Sort keys: the cells, three times with a frozen part (StepView::frozen_part; the third, the
  // buried part, is empty unless the full sort buries: StepView::buried_part).
  int cell_keys() const { return split_frozen() ? 3 * ncells_ : ncells_; }
  // Frozen particles in a part of their own (StepView::frozen_part): with frozen types, unless
  // switched off (SimulationOptions::frozen_part, to measure what it saves).
  bool split_frozen() const { return frozen_part_ && host_->frozen_mask != 0; }
  // StepView::left_to_grid: the solid grid's bounce and the wall model both on.
  bool left_to_grid_on() const { return W::enabled && host_->needs_left_to_grid(); }

  std::uint64_t graph_steps() const override { return graph_steps_; }
  std::uint64_t buried_particles() const override {
    return static_cast<std::uint64_t>(buried_count_);
  }

 private:
  // ---- CUDA graphs (SimulationOptions::graphs). ----
  // A run of steps is captured once and replayed while nothing it bakes in changes. Even: the
  // sort's buffers swap back every two steps (permute_moved), so the storage is where the
  // capture left it. A few lengths are kept (a sweep samples every 10 steps, say).
  static constexpr std::uint64_t kGraphSteps = 16;
  static constexpr size_t kGraphsKept = 4;

  // Runs whose steps read something back to the host (the corrector after the sums, a reorder
  // interval's check, injection picks, a decomposition, profiling) step without graphs.
  bool graphs_possible() const {
    return graphs_ && !profile_ && !this->hooks().distributed() && host_->injections.empty() &&
           host_->reorder_every <= 1 && (!W::enabled || split_frozen());
  }
  // Set-up is done (every buffer allocated, a step run since the last upload) and the frozen
  // part, if any, is sorted and copied into both buffers: no step of the run will differ.
  bool graph_ready() const {
    return warmed_ && (!split_frozen() || (frozen_sums_valid_ && !tail_pending_));
  }

  // What a captured graph bakes in: the buffers, the sizes and the parameters of the view.
  std::vector<std::uintptr_t> graph_state_key() {
    std::vector<std::uintptr_t> k;
    auto add = [&](const auto& buffer) {
      k.push_back(reinterpret_cast<std::uintptr_t>(buffer.get()));
    };
    for (DeviceBuffer<Real>* a : moved_reals()) add(*a);
    for (const DeviceBuffer<Real>& a : moved_alt_) add(a);
    for (const DeviceBuffer<Real>* a :
         {&fx_, &fy_, &fz_, &rho_, &bvf_, &kappa_, &body_force_, &slab_half_velocity_,
          &slab_velocity_, &frozen_rho_, &frozen_bvf_})
      add(*a);
    for (const DeviceBuffer<std::int32_t>* a : {&type_, &origin_, &type_alt_, &origin_alt_})
      add(*a);
    add(id_), add(id_alt_);
    for (const DeviceBuffer<int>* a : {&cell_, &cell_slots_, &index_, &perm_, &cell_start_,
                                       &cell_count_, &lane_list_slots_, &lane_list_counts_})
      add(*a);
    add(sort_temp_), add(table_), add(solid_), add(slab_bodies_), add(slab_partials_);
    add(left_to_grid_), add(left_to_grid_alt_);
    add(early_count_), add(watchdog_record_), add(step_base_), add(penetration_bits_);
    add(penetration_list_), add(penetration_listed_), add(penetration_flag_),
        add(penetration_temp_);
    add(density_list_);
    double dt = static_cast<double>(dt_);
    std::uint64_t dt_bits = 0;
    std::memcpy(&dt_bits, &dt, sizeof dt_bits);
    for (std::uint64_t x :
         {std::uint64_t(n_), std::uint64_t(mobile_count_), std::uint64_t(buried_count_),
          std::uint64_t(density_listed()), std::uint64_t(density_listed_), std::uint64_t(ncells_),
          std::uint64_t(frozen_sums_valid_), std::uint64_t(tail_pending_), dt_bits, epoch_})
      k.push_back(static_cast<std::uintptr_t>(x));
    return k;
  }

  // A captured run of steps: its length and what it baked in. (The profiler's step counters are
  // not advanced by replays: profiling steps without graphs.)
  struct CapturedSteps {
    std::uint64_t steps = 0;
    std::vector<std::uintptr_t> key;
    cudaGraphExec_t exec = nullptr;
  };

  void run_graph(std::uint64_t steps) {
    std::vector<std::uintptr_t> key = graph_state_key();
    auto g = std::find_if(graphs_kept_.begin(), graphs_kept_.end(),
                          [&](const CapturedSteps& c) { return c.steps == steps; });
    wait_for_a_free_launch_slot();
    if (g != graphs_kept_.end() && g->key == key) {
      if (device_base_step_ != step_) set_device_base(step_);
      check(cudaGraphLaunch(g->exec, cudaStreamPerThread), "graph launch");
      step_ += steps;
    } else {
      if (g == graphs_kept_.end()) {
        if (graphs_kept_.size() >= kGraphsKept) release_graph(graphs_kept_.begin());
        graphs_kept_.push_back({steps, {}, nullptr});
        g = graphs_kept_.end() - 1;
      }
      capture_graph(*g);  // and runs it
      g->key = std::move(key);
    }
    check(cudaEventRecord(launch_done_[launch_slot_], cudaStreamPerThread), "graph event");
    launch_slot_ = (launch_slot_ + 1) % kLaunchesInFlight;
    device_base_step_ = step_;
    graph_steps_ += steps;
    if (this->watchdog_.enabled) {
      watchdog_since_poll_ += static_cast<int>(steps);
      if (watchdog_since_poll_ >= this->watchdog_.poll_steps) watchdog_poll(false);
    }
  }

  // Captures g.steps steps of the step sequence (kernels only: graphs_possible), then launches
  // them from their first step.
  void capture_graph(CapturedSteps& g) {
    if (g.exec) check(cudaGraphExecDestroy(g.exec), "graph release");
    g.exec = nullptr;
    capture_first_step_ = step_;
    cudaGraph_t graph = nullptr;
    check(cudaStreamBeginCapture(cudaStreamPerThread, cudaStreamCaptureModeThreadLocal),
          "graph capture");
    capturing_ = true;
    try {
      this->run_steps(g.steps);
      step_base_kernel<<<1, 1>>>(step_base_.get(), g.steps);
    } catch (...) {
      capturing_ = false;
      cudaStreamEndCapture(cudaStreamPerThread, &graph);
      if (graph) cudaGraphDestroy(graph);
      throw;
    }
    capturing_ = false;
    check(cudaStreamEndCapture(cudaStreamPerThread, &graph), "graph capture");
    const cudaError_t e = cudaGraphInstantiate(&g.exec, graph, 0);
    cudaGraphDestroy(graph);
    check(e, "graph instantiation");
    set_device_base(capture_first_step_);
    check(cudaGraphLaunch(g.exec, cudaStreamPerThread), "graph launch");
  }

  // At most kLaunchesInFlight graphs queued: a thread that is ahead sleeps on the oldest one's
  // event (blocking sync) instead of spinning on a full launch queue. Why: 64 ensemble members
  // on 16 cores, with nothing to wait on (the watchdog off), ran at half the speed of the same
  // run whose watchdog polls made them wait (docs/benchmarks.md).
  void wait_for_a_free_launch_slot() {
    if (!launch_done_[0])
      for (cudaEvent_t& e : launch_done_)
        check(cudaEventCreateWithFlags(&e, cudaEventDisableTiming | cudaEventBlockingSync),
              "cudaEventCreate");
    check(cudaEventSynchronize(launch_done_[launch_slot_]), "graph wait");
  }

  void release_graph(typename std::vector<CapturedSteps>::iterator g) {
    if (g->exec) cudaGraphExecDestroy(g->exec);
    graphs_kept_.erase(g);
  }

  void set_device_base(std::uint64_t step) {
    check(cudaMemcpy(step_base_.get(), &step, sizeof step, cudaMemcpyHostToDevice), "step base");
  }

 public:
  std::string profile_report() const override {
    if (!profile_ || profiled_steps_ == 0) return "";
    static const char* names[kPasses] = {"kick_drift",     "corrector", "cell_sort", "density",
                                         "late_corrector", "force",     "kick"};
    std::ostringstream s;
    double total = 0;
    for (double v : pass_ms_) total += v;
    s << "per-step GPU time over " << profiled_steps_ << " steps (ms):";
    for (int k = 0; k < kPasses; ++k) {
      if (!W::enabled && (k == 1 || k == 4)) continue;  // no corrector: always 0
      s << " " << names[k] << " " << pass_ms_[k] / profiled_steps_ << " ("
        << static_cast<int>(100 * pass_ms_[k] / total + 0.5) << "%)";
    }
    if (W::enabled)
      s << "; the corrector ran before the sort on " << early_steps_ << " steps, after the sums on "
        << late_steps_;
    if (split_frozen())
      s << "; cell sorts: " << full_sorts_ << " full, " << mobile_sorts_ << " of the mobile part";
    if (density_listed())
      s << "; frozen density list: " << density_listed_ << " of the "
        << n_ - buried_count_ - mobile_count_ << " frozen particles a step visits";
    if (penetration_built_)
      s << "; penetration mask: cells of " << penetration_.cell[0] << " rc, "
        << 100 * penetration_share() << "% set, " << 100 * listed_share()
        << "% of the mobile particles scanned";
    return s.str();
  }

 private:
  int device_ = 0;
  HostState<Real>* host_ = nullptr;
  int n_ = 0, ncells_ = 0;
  std::uint64_t step_ = 0;
  Real dt_ = Real(0.01);
  DeviceBuffer<Real> x_, y_, z_, vx_, vy_, vz_, vex_, vey_, vez_, fx_, fy_, fz_, rho_;
  DeviceBuffer<std::int32_t> type_, origin_;
  DeviceBuffer<std::int64_t> id_;
  // The second buffer of each array a sort moves (permute_moved; moved_alt_ in moved_reals'
  // order), and whether the frozen part is still to be copied into them.
  DeviceBuffer<Real> moved_alt_[PermuteTable<Real>::kMaxReal];
  DeviceBuffer<std::int32_t> type_alt_, origin_alt_;
  DeviceBuffer<std::int64_t> id_alt_;
  bool tail_pending_ = true;
  // The cell sort (cell_count_kernel): keys, ranks (and migration's scratch), particles by slot,
  // the permutation, the cells' first slots and counts.
  DeviceBuffer<int> cell_, cell_slots_, index_, perm_, cell_start_, cell_count_;
  // The neighbour list (LaneList), and whether the last sums pass wrote it for the storage as
  // it is.
  DeviceBuffer<int> lane_list_slots_, lane_list_counts_;
  bool lane_list_ready_ = false;
  DeviceBuffer<unsigned char> sort_temp_;
  DeviceBuffer<PairParams<Real>> table_;
  DeviceBuffer<Real> body_force_;
  // Observables' buffers, allocated on first use.
  DeviceBuffer<double> virial_, bins_, one_bin_, slab_coordinates_;
  DeviceBuffer<SolidIntrusionSums> intrusion_;
  DeviceBuffer<Real> bvf_, kappa_;    // wall model only
  DeviceBuffer<std::uint8_t> solid_;  // the solid grid's voxels (scenes with one only)
  // StepView::left_to_grid and the second buffer a sort moves it into (solid grid and wall model)
  DeviceBuffer<std::uint8_t> left_to_grid_, left_to_grid_alt_;
  int nslabs_ = 0;  // rigid slabs only:
  DeviceBuffer<RigidSlabBody> slab_bodies_;
  DeviceBuffer<Real> slab_half_velocity_, slab_velocity_;
  DeviceBuffer<double> slab_partials_;
  DeviceBuffer<unsigned int> count_;
  DeviceBuffer<std::uint64_t> injection_best_, injection_counts_;  // injection only
  // A decomposed run's (sim/domain) exchange buffers; empty otherwise. flag_a_, select_temp_ and
  // selected_ are select()'s scratch, also for the full sort's frozen density list.
  int ghost_count_ = 0, send_count_ = 0;
  DeviceBuffer<unsigned char> flag_a_, flag_b_, select_temp_;
  DeviceBuffer<int> selected_, slot_index_, send_box_;
  DeviceBuffer<std::int32_t> send_slots_;
  DeviceBuffer<MigrantRecord<Real>> migrants_;
  DeviceBuffer<GhostRecord<Real>> ghosts_out_, ghosts_in_;
  DeviceBuffer<HaloBox<Real>> send_boxes_;
  DeviceBuffer<Real> sums_out_, sums_in_;
  DeviceBuffer<double> slab_sums_;
  // Reorder interval only: the positions at the last sort, the steps since, the moved flag.
  DeviceBuffer<Real> x0_, y0_, z0_;
  DeviceBuffer<int> moved_;
  unsigned int* count_host_ = nullptr;
  std::uint64_t corrected_ = 0;
  bool profile_ = false;
  static constexpr int kPasses = static_cast<int>(StepPhase::End);
  cudaEvent_t events_[kPasses + 1] = {};
  double pass_ms_[kPasses] = {};
  // Wall model only: the corrections before the sort (counted on the device), and the steps
  // whose corrector ran before the sort and after the sums (profiling).
  DeviceBuffer<unsigned long long> early_count_;
  std::uint64_t early_steps_ = 0, late_steps_ = 0;
  // Frozen types only: the frozen part's start and static sums (StepView::frozen_rho).
  bool frozen_part_ = true;
  // The buried part (StepView::buried_part) since the last full sort: whether there is one and
  // how many particles it holds (the steps' pair passes stop before them); burying_:
  // SimulationOptions::buried_part.
  bool burying_ = true;
  bool buried_part_ = false;
  int buried_count_ = 0;
  int mobile_count_ = 0;
  std::uint64_t full_sorts_ = 0, mobile_sorts_ = 0;  // profiling
  bool frozen_sums_valid_ = false;
  DeviceBuffer<Real> frozen_rho_,
      frozen_bvf_;  // the corrector moved a particle; no sums since (profiling)
  // Wall model with a frozen part: the penetration mask (StepView::penetration) of the frozen
  // part's last full sort; masking_: SimulationOptions::penetration_mask.
  bool masking_ = true;
  bool penetration_built_ = false;
  // With the buried part: the frozen density list (update_density_list) of the last full sort,
  // its indices and their count (flagged and selected through the selection scratch below);
  // listing_density_: SimulationOptions::frozen_density_list.
  bool listing_density_ = true;
  bool density_list_built_ = false;
  int density_listed_ = 0;
  DeviceBuffer<int> density_list_;
  PenetrationMask<Real> penetration_;
  DeviceBuffer<std::uint32_t> penetration_bits_;
  // The corrector's selection (needs_frozen_phi): the flags, the listed particles, their count,
  // CUB's scratch.
  DeviceBuffer<int> penetration_list_, penetration_listed_;
  DeviceBuffer<unsigned char> penetration_flag_, penetration_temp_;
  // Profiling: the listed particles summed over listed_steps_ steps.
  DeviceBuffer<unsigned long long> listed_total_;
  std::uint64_t listed_steps_ = 0;
  std::uint64_t profiled_steps_ = 0;
  DeviceBuffer<WatchdogRecord> watchdog_record_;  // allocated at the first checked step
  WatchdogRecord* watchdog_host_ = nullptr;       // pinned
  cudaEvent_t watchdog_event_ = nullptr;
  bool watchdog_pending_ = false;
  int watchdog_since_poll_ = 0;
  // CUDA graphs: on unless switched off; the captured runs, the first step of the one being
  // captured and the step the device's step base holds; launches in flight.
  bool graphs_ = true;
  bool capturing_ = false;
  bool defer_poll_ = false;  // advance() polls the watchdog once at its end
  bool warmed_ = false;      // a step run since the last upload or resize
  std::uint64_t epoch_ = 0;  // a new host state or watchdog: graphs captured before are stale
  std::vector<CapturedSteps> graphs_kept_;
  std::uint64_t capture_first_step_ = 0, device_base_step_ = ~std::uint64_t(0);
  DeviceBuffer<std::uint64_t> step_base_;
  std::uint64_t graph_steps_ = 0;
  static constexpr int kLaunchesInFlight = 3;
  cudaEvent_t launch_done_[kLaunchesInFlight] = {};
  int launch_slot_ = 0;
  // Threads per particle in the gather passes (0: by the particle count, with_lanes).
  int lanes_ = 0;
};

}  // namespace

template <class Real>
std::unique_ptr<Engine<Real>> make_cuda_engine(const Model& model, const CudaEngineOptions& o) {
  std::unique_ptr<Engine<Real>> engine;
  dispatch_terms(
      model, [&](auto terms) { engine = std::make_unique<CudaEngine<Real, decltype(terms)>>(o); });
  return engine;
}

template std::unique_ptr<Engine<float>> make_cuda_engine<float>(const Model&,
                                                                const CudaEngineOptions&);
template std::unique_ptr<Engine<double>> make_cuda_engine<double>(const Model&,
                                                                  const CudaEngineOptions&);

std::string cuda_unavailable_reason() {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess)
    return std::string("backend cuda: no usable CUDA device (") + cudaGetErrorString(e) + ")";
  if (count == 0) return "backend cuda: no CUDA device found";
  return "";
}

}  // namespace mesorock::sim
