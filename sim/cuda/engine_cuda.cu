// CUDA engine. Per step: kick_drift; cell index per particle; stable radix sort of the particle
// storage by cell (CUB), so neighbours are contiguous in memory exactly as on the CPU; density
// (only with a many-body term); forces; kick. Nothing crosses to the host unless an output asks.
#include <cuda_runtime.h>

#include <cub/block/block_reduce.cuh>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "mesorock/errors.h"
#include "sim/cuda/engine_cuda.h"
#include "sim/kernels.h"
#include "sim/simulation.h"
#include "sim/terms.h"

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
  }

 private:
  void release() {
    if (ptr_) cudaFree(ptr_);
    ptr_ = nullptr;
    size_ = 0;
  }
  T* ptr_ = nullptr;
  size_t size_ = 0;
};

constexpr int kBlock = 128;
inline int blocks_for(int n) {
  return (n + kBlock - 1) / kBlock;
}

template <class Real, bool kVelocityEstimate>
__global__ void kick_drift_kernel(StepView<Real> v) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) kick_drift<Real, kVelocityEstimate>(v, i);
}

template <class Real>
__global__ void kick_kernel(StepView<Real> v) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) kick(v, i);
}

template <class Real>
__global__ void cell_index_kernel(StepView<Real> v, int* cell, int* index) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= v.n) return;
  cell[i] = v.grid.index(v.grid.coordinate(v.x[i], v.box.lo[0], 0),
                         v.grid.coordinate(v.y[i], v.box.lo[1], 1),
                         v.grid.coordinate(v.z[i], v.box.lo[2], 2));
  index[i] = i;
}

// cell_start[c] = first sorted position with cell >= c (sorted_cell is non-decreasing).
__global__ void cell_start_kernel(const int* sorted_cell, int n, int ncells, int* cell_start) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k > n) return;
  const int prev = k == 0 ? -1 : sorted_cell[k - 1];
  const int cur = k == n ? ncells : sorted_cell[k];
  for (int c = prev + 1; c <= cur; ++c) cell_start[c] = k;
}

template <class T>
__global__ void gather_kernel(const T* __restrict__ in, T* __restrict__ out, const int* perm,
                              int n) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < n) out[k] = in[perm[k]];
}

// Each thread's neighbour stash (sim/kernels.h) in shared memory, slot k at k * blockDim.x so
// that a warp's stores hit 32 different banks.
constexpr size_t kStashBytes = sizeof(int) * NeighbourStash::kCapacity * kBlock;
__device__ MESO_INLINE NeighbourStash thread_stash() {
  extern __shared__ int stash_slots[];
  return NeighbourStash{stash_slots + threadIdx.x, static_cast<int>(blockDim.x)};
}

template <class Real, class DensityKernel>
__global__ void density_kernel(StepView<Real> v) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) density_of_particle<Real, DensityKernel>(v, i);
}

template <class Real, class DensityKernel>
__global__ void density_and_bvf_kernel(StepView<Real> v) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) density_and_bvf_of_particle<Real, DensityKernel>(v, i);
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
  if (penetration_correction(v, i, dv)) {
    apply_penetration_correction<Real, kVelocityEstimate>(v, i, dv);
    atomicAdd(count, 1u);
  }
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

template <class Real>
__global__ void slab_partials_kernel(StepView<Real> v, double* partials) {
  using BlockReduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename BlockReduce::TempStorage temp;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  for (int k = 0; k < v.slabs.count; ++k) {
    const double f = i < v.n ? static_cast<double>(slab_force_of(v, i, k)) : 0.0;
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

template <class Real, class C, class T, class B, class W>
__global__ void force_kernel(StepView<Real> v) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < v.n) force_on_particle<Real, C, T, B, W>(v, i, thread_stash());
}

// Virial of each particle, summed per thread block (fixed tree order, so the result is the same
// every run); the host adds the per-block partials in block order. 18 doubles per block instead
// of per particle keeps the stress observable within the memory budget.
template <class Real, class C, class T, class W>
__global__ void virial_kernel(StepView<Real> v, double* block_sums) {
  using BlockReduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename BlockReduce::TempStorage temp;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  ParticleVirial<Real> w;
  if (i < v.n) w = virial_of_particle<Real, C, T, W>(v, i);
  const Real* parts[3] = {w.conservative, w.dissipative, w.random};
  for (int p = 0; p < 3; ++p)
    for (int c = 0; c < 6; ++c) {
      const double total = BlockReduce(temp).Sum(static_cast<double>(parts[p][c]));
      if (threadIdx.x == 0) block_sums[18 * blockIdx.x + 6 * p + c] = total;
      __syncthreads();  // temp is reused by the next reduction
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
  const double vel[3] = {double(v.vx[i]), double(v.vy[i]), double(v.vz[i])};
  atomicAdd(s + kBinCount, 1.0);
  for (int a = 0; a < 3; ++a) {
    atomicAdd(s + kBinVx + a, vel[a]);
    atomicAdd(s + kBinVxx + a, vel[a] * vel[a]);
  }
}

template <class Real, class Terms>
class CudaEngine final : public Engine<Real> {
  using C = typename Terms::conservative;
  using T = typename Terms::thermostat;
  using B = typename Terms::body_force;
  using W = typename Terms::wall_model;

 public:
  CudaEngine(int device, bool profile) : profile_(profile) {
    check(cudaSetDevice(device), "cudaSetDevice");
    if (profile_)
      for (auto& e : events_) check(cudaEventCreate(&e), "cudaEventCreate");
  }
  ~CudaEngine() override {
    if (profile_)
      for (auto& e : events_) cudaEventDestroy(e);
    if (count_host_) cudaFreeHost(count_host_);
  }

  const char* name() const override { return "cuda"; }

  void initialize(HostState<Real>& host) override {
    upload(host);
    compute_forces();
    if (nslabs_ > 0) slab_forces(false);
    check(cudaDeviceSynchronize(), "initial forces");
  }

  void restore(HostState<Real>& host, std::uint64_t wall_corrections) override {
    upload(host);
    corrected_ = wall_corrections;
    sort_by_cell();  // the saved storage is already sorted (stable sort: no particle moves)
    check(cudaDeviceSynchronize(), "restore");
  }

  void upload(HostState<Real>& host) {
    host_ = &host;
    const int n = host.size();
    n_ = n;
    upload_real_arrays(host);
    type_.upload(host.type);
    id_.upload(host.id);
    origin_.upload(host.origin);
    table_.upload(host.table);
    body_force_.upload(host.body_force);
    if constexpr (W::enabled) {
      bvf_.upload(host.bvf);
      kappa_.upload(host.kappa);
      count_.resize(1);
      check(cudaMallocHost(&count_host_, sizeof(unsigned int)), "cudaMallocHost");
    }
    ncells_ = host.grid.count();
    cell_start_.resize(static_cast<size_t>(ncells_) + 1);
    cell_.resize(static_cast<size_t>(n));
    cell_sorted_.resize(static_cast<size_t>(n));
    index_.resize(static_cast<size_t>(n));
    perm_.resize(static_cast<size_t>(n));
    scratch_real_.resize(static_cast<size_t>(n));
    scratch_int_.resize(static_cast<size_t>(n));
    scratch_id_.resize(static_cast<size_t>(n));
    size_t temp = 0;
    check(cub::DeviceRadixSort::SortPairs(nullptr, temp, cell_.get(), cell_sorted_.get(),
                                          index_.get(), perm_.get(), n),
          "radix sort sizing");
    sort_temp_.resize(temp);
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

  // The slabs' total forces from the last force pass, then (kick) their second half kick.
  void slab_forces(bool kick) {
    const int g = blocks_for(n_);
    slab_partials_kernel<Real><<<g, kBlock>>>(view(), slab_partials_.get());
    slab_finish_kernel<Real><<<1, 256>>>(slab_partials_.get(), g, slab_bodies_.get(), nslabs_,
                                         static_cast<double>(dt_), kick, slab_velocity_.get());
  }

  void advance(std::uint64_t steps) override {
    const int g = blocks_for(n_);
    for (std::uint64_t k = 0; k < steps; ++k) {
      mark(0);
      if (nslabs_ > 0)
        slab_half_kick_kernel<Real><<<1, kMaxRigidSlabs>>>(
            slab_bodies_.get(), nslabs_, static_cast<double>(dt_), slab_half_velocity_.get());
      kick_drift_kernel<Real, T::enabled><<<g, kBlock>>>(view());
      ++step_;
      compute_forces();
      if (nslabs_ > 0) slab_forces(true);
      mark(4);
      kick_kernel<<<g, kBlock>>>(view());
      mark(5);
      if (profile_) accumulate();
    }
    check(cudaGetLastError(), "step kernels");
  }

  void set_dt(Real dt) override { dt_ = dt; }
  std::uint64_t step() const override { return step_; }

  void download(HostState<Real>& host) override {
    check(cudaDeviceSynchronize(), "step");
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

  VirialSums virial() override {
    // Allocated on first use only: runs that never ask for stress own no such buffer.
    const int g = blocks_for(n_);
    virial_.resize(static_cast<size_t>(18) * g);
    virial_kernel<Real, C, T, W><<<g, kBlock>>>(view(), virial_.get());
    check(cudaGetLastError(), "virial kernel");
    std::vector<double> h;
    virial_.download(h);
    VirialSums s;
    for (int b = 0; b < g; ++b)
      for (int c = 0; c < 6; ++c) {
        s.conservative[c] += h[18 * static_cast<size_t>(b) + c];
        s.dissipative[c] += h[18 * static_cast<size_t>(b) + 6 + c];
        s.random[c] += h[18 * static_cast<size_t>(b) + 12 + c];
      }
    return s;
  }

  void bin_sums(const BinGrid& grid, std::vector<double>& sums) override {
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
    v.walls.kappa = kappa_.get();
    v.slabs.half_velocity = slab_half_velocity_.get();
    v.slabs.velocity = slab_velocity_.get();
    v.type = type_.get();
    v.id = id_.get();
    v.cell_start = cell_start_.get();
    v.table = table_.get();
    v.body_force = body_force_.get();
    v.dt = dt_;
    v.inv_sqrt_dt = Real(1) / static_cast<Real>(std::sqrt(static_cast<double>(dt_)));
    v.step = step_;
    return v;
  }

  // Stable sort of the storage by cell, then density (and the wall model's phi and corrector)
  // and forces for step_.
  void compute_forces() {
    const int g = blocks_for(n_);
    mark(1);
    sort_by_cell();
    mark(2);
    local_sums();
    if constexpr (W::enabled) {
      // The re-sort decision needs the count on the host: one small synchronising copy per step,
      // paid only by scenes with the wall model.
      check(cudaMemsetAsync(count_.get(), 0, sizeof(unsigned int)), "count reset");
      correction_kernel<Real, T::enabled><<<g, kBlock>>>(view(), count_.get());
      check(cudaMemcpy(count_host_, count_.get(), sizeof(unsigned int), cudaMemcpyDeviceToHost),
            "correction count");
      if (*count_host_ > 0) {
        corrected_ += *count_host_;
        sort_by_cell();
        local_sums();
      }
    }
    mark(3);
    force_kernel<Real, C, T, B, W><<<g, kBlock, kStashBytes>>>(view());
  }

  void local_sums() {
    const int g = blocks_for(n_);
    const StepView<Real> v = view();
    if constexpr (W::enabled) {
      using K = std::conditional_t<C::needs_density, typename C::density_kernel, void>;
      density_and_bvf_kernel<Real, K><<<g, kBlock>>>(v);
    } else if constexpr (C::needs_density) {
      density_kernel<Real, typename C::density_kernel><<<g, kBlock>>>(v);
    }
  }

  void sort_by_cell() {
    const int g = blocks_for(n_);
    cell_index_kernel<<<g, kBlock>>>(view(), cell_.get(), index_.get());
    size_t temp = sort_temp_.size();
    int bits = 1;
    while ((1 << bits) < ncells_ + 1) ++bits;
    check(cub::DeviceRadixSort::SortPairs(sort_temp_.get(), temp, cell_.get(), cell_sorted_.get(),
                                          index_.get(), perm_.get(), n_, 0, bits),
          "radix sort");
    cell_start_kernel<<<blocks_for(n_ + 1), kBlock>>>(cell_sorted_.get(), n_, ncells_,
                                                      cell_start_.get());
    for (DeviceBuffer<Real>* a : {&x_, &y_, &z_, &vx_, &vy_, &vz_, &vex_, &vey_, &vez_}) {
      if (a->size() == 0) continue;  // v~ without a thermostat
      gather_kernel<<<g, kBlock>>>(a->get(), scratch_real_.get(), perm_.get(), n_);
      a->swap(scratch_real_);
    }
    gather_kernel<<<g, kBlock>>>(type_.get(), scratch_int_.get(), perm_.get(), n_);
    type_.swap(scratch_int_);
    gather_kernel<<<g, kBlock>>>(origin_.get(), scratch_int_.get(), perm_.get(), n_);
    origin_.swap(scratch_int_);
    gather_kernel<<<g, kBlock>>>(id_.get(), scratch_id_.get(), perm_.get(), n_);
    id_.swap(scratch_id_);
  }

 public:
  std::uint64_t wall_corrections() const override { return corrected_; }

 private:
  // Profiling: events 0..5 bound kick_drift | sort | density | force | kick.
  void mark(int k) {
    if (profile_) check(cudaEventRecord(events_[k]), "cudaEventRecord");
  }
  void accumulate() {
    check(cudaEventSynchronize(events_[5]), "profile sync");
    for (int k = 0; k < 5; ++k) {
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
         {&x_, &y_, &z_, &vx_, &vy_, &vz_, &vex_, &vey_, &vez_, &fx_, &fy_, &fz_, &rho_,
          &scratch_real_, &body_force_, &bvf_, &kappa_})
      b += a->size() * sizeof(Real);
    for (const DeviceBuffer<std::int32_t>* a : {&type_, &origin_, &scratch_int_})
      b += a->size() * sizeof(std::int32_t);
    b += (id_.size() + scratch_id_.size()) * sizeof(std::int64_t);
    for (const DeviceBuffer<int>* a : {&cell_, &cell_sorted_, &index_, &perm_, &cell_start_})
      b += a->size() * sizeof(int);
    b += sort_temp_.size() + table_.size() * sizeof(PairParams<Real>) +
         (virial_.size() + bins_.size()) * sizeof(double);
    return b;
  }

  std::string profile_report() const override {
    if (!profile_ || profiled_steps_ == 0) return "";
    static const char* names[5] = {"kick_drift", "cell_sort", "density", "force", "kick"};
    std::ostringstream s;
    double total = 0;
    for (double v : pass_ms_) total += v;
    s << "per-step GPU time over " << profiled_steps_ << " steps (ms):";
    for (int k = 0; k < 5; ++k)
      s << " " << names[k] << " " << pass_ms_[k] / profiled_steps_ << " ("
        << static_cast<int>(100 * pass_ms_[k] / total + 0.5) << "%)";
    return s.str();
  }

 private:
  HostState<Real>* host_ = nullptr;
  int n_ = 0, ncells_ = 0;
  std::uint64_t step_ = 0;
  Real dt_ = Real(0.01);
  DeviceBuffer<Real> x_, y_, z_, vx_, vy_, vz_, vex_, vey_, vez_, fx_, fy_, fz_, rho_;
  DeviceBuffer<std::int32_t> type_, origin_, scratch_int_;
  DeviceBuffer<std::int64_t> id_, scratch_id_;
  DeviceBuffer<Real> scratch_real_;
  DeviceBuffer<int> cell_, cell_sorted_, index_, perm_, cell_start_;
  DeviceBuffer<unsigned char> sort_temp_;
  DeviceBuffer<PairParams<Real>> table_;
  DeviceBuffer<Real> body_force_;
  DeviceBuffer<double> virial_, bins_;
  DeviceBuffer<Real> bvf_, kappa_;  // wall model only
  int nslabs_ = 0;                  // rigid slabs only:
  DeviceBuffer<RigidSlabBody> slab_bodies_;
  DeviceBuffer<Real> slab_half_velocity_, slab_velocity_;
  DeviceBuffer<double> slab_partials_;
  DeviceBuffer<unsigned int> count_;
  unsigned int* count_host_ = nullptr;
  std::uint64_t corrected_ = 0;
  bool profile_ = false;
  cudaEvent_t events_[6] = {};
  double pass_ms_[5] = {0, 0, 0, 0, 0};
  std::uint64_t profiled_steps_ = 0;
};

}  // namespace

template <class Real>
std::unique_ptr<Engine<Real>> make_cuda_engine(const Model& model, int device, bool profile) {
  std::unique_ptr<Engine<Real>> engine;
  dispatch_terms(model, [&](auto terms) {
    engine = std::make_unique<CudaEngine<Real, decltype(terms)>>(device, profile);
  });
  return engine;
}

template std::unique_ptr<Engine<float>> make_cuda_engine<float>(const Model&, int, bool);
template std::unique_ptr<Engine<double>> make_cuda_engine<double>(const Model&, int, bool);

std::string cuda_unavailable_reason() {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess)
    return std::string("backend cuda: no usable CUDA device (") + cudaGetErrorString(e) + ")";
  if (count == 0) return "backend cuda: no CUDA device found";
  return "";
}

}  // namespace mesorock::sim
