// The CUDA backend of the lattice Boltzmann reference: one thread per node runs update_node
// (lbm/node_update.h, the CPU loop's body); the measured step reduces each thread block's sums
// in double into its own slot, added in block order on the host (the same doubles every run).
#include <cuda_runtime.h>

#include <string>
#include <vector>

#include "lbm/steps.h"
#include "mesorock/errors.h"

namespace mesorock::lbm {

namespace {

constexpr int kThreads = 256;

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw DeviceError(std::string("lbm: CUDA error in ") + what + ": " + cudaGetErrorString(e));
}

template <class Real, bool Measure>
__global__ void __launch_bounds__(kThreads)
    step_kernel(StepParams<Real> p, const std::uint32_t* __restrict__ src,
                const Real* __restrict__ from, Real* __restrict__ to, int axis,
                double* __restrict__ block_sums) {
  const std::uint64_t n = static_cast<std::uint64_t>(blockIdx.x) * kThreads + threadIdx.x;
  double u = 0, rho = 0, u2 = 0;
  if (n < p.nodes) {
    const NodeMoments<Real> m = update_node(n, src, from, to, p);
    if constexpr (Measure) {
      u = static_cast<double>(m.j[axis]);
      rho = static_cast<double>(m.drho);
      u2 = static_cast<double>(m.j[0]) * m.j[0] + static_cast<double>(m.j[1]) * m.j[1] +
           static_cast<double>(m.j[2]) * m.j[2];
    }
  }
  if constexpr (Measure) {
    __shared__ double s_u[kThreads], s_rho[kThreads], s_u2[kThreads];
    s_u[threadIdx.x] = u;
    s_rho[threadIdx.x] = rho;
    s_u2[threadIdx.x] = u2;
    __syncthreads();
    for (int half = kThreads / 2; half > 0; half /= 2) {
      if (static_cast<int>(threadIdx.x) < half) {
        s_u[threadIdx.x] += s_u[threadIdx.x + half];
        s_rho[threadIdx.x] += s_rho[threadIdx.x + half];
        s_u2[threadIdx.x] = fmax(s_u2[threadIdx.x], s_u2[threadIdx.x + half]);
      }
      __syncthreads();
    }
    if (threadIdx.x == 0) {
      block_sums[3 * blockIdx.x] = s_u[0];
      block_sums[3 * blockIdx.x + 1] = s_rho[0];
      block_sums[3 * blockIdx.x + 2] = s_u2[0];
    }
  }
}

template <class Real>
__global__ void moments_kernel(StepParams<Real> p, const Real* __restrict__ g,
                               float* __restrict__ out) {
  const std::uint64_t n = static_cast<std::uint64_t>(blockIdx.x) * kThreads + threadIdx.x;
  if (n >= p.nodes) return;
  const NodeMoments<Real> m = node_moments(n, g, p);
  out[n] = static_cast<float>(m.drho);
  out[p.nodes + n] = static_cast<float>(m.j[0]);
  out[2 * p.nodes + n] = static_cast<float>(m.j[1]);
  out[3 * p.nodes + n] = static_cast<float>(m.j[2]);
}

template <class T>
class DeviceArray {
 public:
  DeviceArray(std::size_t count, const char* what) : count_(count) {
    check(cudaMalloc(&ptr_, count * sizeof(T) + 1), what);
  }
  ~DeviceArray() { cudaFree(ptr_); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  T* get() const { return ptr_; }
  std::size_t count() const { return count_; }

 private:
  T* ptr_ = nullptr;
  std::size_t count_;
};

template <class Real>
class CudaRunner final : public StepRunner<Real> {
 public:
  CudaRunner(const std::vector<std::uint32_t>& source, const std::vector<Real>& initial,
             const StepParams<Real>& p)
      : p_(p),
        blocks_((p.nodes + kThreads - 1) / kThreads),
        src_(source.size(), "cudaMalloc (the link table)"),
        fa_(initial.size(), "cudaMalloc (the populations)"),
        fb_(initial.size(), "cudaMalloc (the populations' second copy)"),
        sums_(3 * blocks_, "cudaMalloc (the block sums)"),
        host_sums_(3 * blocks_) {
    check(cudaMemcpy(src_.get(), source.data(), source.size() * sizeof(std::uint32_t),
                     cudaMemcpyHostToDevice),
          "cudaMemcpy (the link table)");
    check(cudaMemcpy(fa_.get(), initial.data(), initial.size() * sizeof(Real),
                     cudaMemcpyHostToDevice),
          "cudaMemcpy (the populations)");
    from_ = fa_.get();
    to_ = fb_.get();
  }

  void run(std::int64_t count, bool measure, int axis, StepSums& sums) override {
    const unsigned grid = static_cast<unsigned>(blocks_);
    for (std::int64_t s = 0; s < count; ++s) {
      if (measure && s == count - 1)
        step_kernel<Real, true><<<grid, kThreads>>>(p_, src_.get(), from_, to_, axis, sums_.get());
      else
        step_kernel<Real, false><<<grid, kThreads>>>(p_, src_.get(), from_, to_, axis, nullptr);
      std::swap(from_, to_);
    }
    check(cudaGetLastError(), "the step kernel's launch");
    if (!measure) return;
    check(cudaMemcpy(host_sums_.data(), sums_.get(), host_sums_.size() * sizeof(double),
                     cudaMemcpyDeviceToHost),
          "the step kernel");
    sums = StepSums{};
    for (std::size_t b = 0; b < blocks_; ++b) {
      sums.u_axis += host_sums_[3 * b];
      sums.drho += host_sums_[3 * b + 1];
      sums.u2_max = std::max(sums.u2_max, host_sums_[3 * b + 2]);
    }
  }

  void moments(std::vector<float>& drho, std::vector<float>& jx, std::vector<float>& jy,
               std::vector<float>& jz) override {
    const std::size_t N = p_.nodes;
    DeviceArray<float> out(4 * N, "cudaMalloc (the moments)");
    moments_kernel<Real><<<static_cast<unsigned>(blocks_), kThreads>>>(p_, from_, out.get());
    check(cudaGetLastError(), "the moments kernel's launch");
    std::vector<float> host(4 * N);
    check(cudaMemcpy(host.data(), out.get(), host.size() * sizeof(float), cudaMemcpyDeviceToHost),
          "the moments kernel");
    drho.assign(host.begin(), host.begin() + N);
    jx.assign(host.begin() + N, host.begin() + 2 * N);
    jy.assign(host.begin() + 2 * N, host.begin() + 3 * N);
    jz.assign(host.begin() + 3 * N, host.end());
  }

 private:
  StepParams<Real> p_;
  std::size_t blocks_;
  DeviceArray<std::uint32_t> src_;
  DeviceArray<Real> fa_, fb_;
  DeviceArray<double> sums_;
  std::vector<double> host_sums_;
  Real* from_ = nullptr;
  Real* to_ = nullptr;
};

}  // namespace

template <class Real>
std::unique_ptr<StepRunner<Real>> make_cuda_runner(const std::vector<std::uint32_t>& source,
                                                   const std::vector<Real>& initial,
                                                   const StepParams<Real>& params) {
  return std::make_unique<CudaRunner<Real>>(source, initial, params);
}

template std::unique_ptr<StepRunner<float>> make_cuda_runner<float>(
    const std::vector<std::uint32_t>&, const std::vector<float>&, const StepParams<float>&);
template std::unique_ptr<StepRunner<double>> make_cuda_runner<double>(
    const std::vector<std::uint32_t>&, const std::vector<double>&, const StepParams<double>&);

}  // namespace mesorock::lbm
