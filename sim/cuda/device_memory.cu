// Free device memory, asked before a run allocates (sim/memory_budget.h). The CPU-only build's
// stub in memory_budget.cpp answers "unknown".
#include <cuda_runtime.h>

#include <string>

#include "sim/memory_budget.h"

namespace mesorock::sim {

MemoryAvailable device_memory_available(int device) {
  MemoryAvailable m;
  int current = 0;
  if (cudaGetDevice(&current) != cudaSuccess) return m;
  if (cudaSetDevice(device) != cudaSuccess) {
    cudaGetLastError();  // clear it: a later call reports the bad device itself
    return m;
  }
  size_t free_bytes = 0, total_bytes = 0;
  if (cudaMemGetInfo(&free_bytes, &total_bytes) == cudaSuccess) {
    m.bytes = static_cast<double>(free_bytes);
    m.source = "cudaMemGetInfo, device " + std::to_string(device);
  } else {
    cudaGetLastError();
  }
  cudaSetDevice(current);
  return m;
}

}  // namespace mesorock::sim
