#pragma once
// The backends of the lattice Boltzmann reference: what differs between the CPU's OpenMP loop
// (solver.cpp) and the CUDA kernel (cuda/steps_cuda.cu). Both run update_node (node_update.h)
// on every node per step; the convergence loop that calls them is written once (solver.cpp).
#include <cstdint>
#include <memory>
#include <vector>

#include "lbm/node_update.h"

namespace mesorock::lbm {

// Sums over the nodes of one measured step, in double.
struct StepSums {
  double u_axis = 0;  // sum of j along the flow axis
  double drho = 0;    // sum of the density deviations
  double u2_max = 0;  // largest |j|^2 of a node
};

template <class Real>
class StepRunner {
 public:
  virtual ~StepRunner() = default;
  // Runs `count` >= 1 steps; with `measure`, sums the moments of the last one's pulled
  // populations (time t of that step) into `sums`.
  virtual void run(std::int64_t count, bool measure, int axis, StepSums& sums) = 0;
  // The moments of the current populations, per node.
  virtual void moments(std::vector<float>& drho, std::vector<float>& jx, std::vector<float>& jy,
                       std::vector<float>& jz) = 0;
};

#ifdef MESOROCK_HAVE_CUDA
// The CUDA runner: copies `source` (18 x nodes links) and `initial` (19 x nodes populations) to
// the device; DeviceError when the device refuses (out of memory, no device).
template <class Real>
std::unique_ptr<StepRunner<Real>> make_cuda_runner(const std::vector<std::uint32_t>& source,
                                                   const std::vector<Real>& initial,
                                                   const StepParams<Real>& params);
#endif

}  // namespace mesorock::lbm
