#pragma once
// Marks functions that compile for both the host (CPU backend) and the device (CUDA backend).
#if defined(__CUDACC__)
#define MESO_HD __host__ __device__
#define MESO_INLINE __forceinline__
#define MESO_UNROLL _Pragma("unroll")
#else
#define MESO_HD
#define MESO_INLINE inline
#define MESO_UNROLL
#endif

#include <cmath>

namespace mesorock::sim {
// Precision-preserving square root for kernel bodies (a bare sqrt(float) on the host would
// promote to double).
MESO_HD MESO_INLINE float real_sqrt(float v) {
  return sqrtf(v);
}
MESO_HD MESO_INLINE double real_sqrt(double v) {
  return sqrt(v);
}
}  // namespace mesorock::sim
