#pragma once
// Memory a run will need, and memory the machine has, asked before anything is allocated: a scene
// of 2^31 particles used to grow until the kernel killed it (5 minutes), or to fail with "out of
// memory" naming nothing (issue 22, item 2). The callers (pipeline/scene.h check_memory_for,
// rockflow bench) name the key that asked for the particles.
#include <optional>
#include <string>

#include "sim/model.h"

namespace mesorock::sim {

// Host bytes per particle at the peak of a single-rank run, from what the code allocates:
//   ParticleSet (x y z vx vy vz double, type int32, id int64)      60 B, twice: the initial set is
//     alive while make_simulation builds the state, and outputs (particle files, checkpoints)
//     take another copy in the original order                     120 B
//   HostState (x..rho: 13 Real, phi 1 Real, type, origin int32,
//     id int64, the solid grid's turn flag uint8)                  14 Real + 17 B
//   the cell sorter (cell_of, dest int; scratch Real, int32,
//     int64, uint8)                                                1 Real + 21 B
//   the CPU engine's half list (sim/half_list.h: offset and force end, int; at rho = 7 about 15
//     pairs within rc of 4 B each, doubled for the vectors' growth; a skin of 0.3 rc doubles
//     the pairs)                                                   128 B
// = 286 + 15 Real: 406 B in double precision, 346 B in single. The CUDA engine keeps the same
// host mirror (without the list: the estimate is then on the safe side). Per cell: cell_start and
// the sorter's fill cursor, 8 B.
double host_bytes_per_particle(Precision p);
inline constexpr double kHostBytesPerCell = 8;

// Device bytes per particle of the CUDA engine (its buffers, see CudaEngine::device_bytes()):
//   28 Real (x..rho 13, the second buffers of the 9 that a sort moves, phi, the positions at
//   the last sort x0 y0 z0, a frozen particle's static rho and phi),
//   type, origin and their second buffers (int32) 16 B, id and its second buffer (int64) 16 B,
//   the cell sort's key, rank, slot and permutation (int) 16 B, the solid grid's turn flag and
//   its second buffer (uint8) 2 B, the neighbour list (72 slots and a count, int) 292 B
// = 342 + 28 Real: 566 B in double precision, 454 B in single. Per cell: cell_start and the
// sort's count, 8 B, twice with frozen types (their own part of the cell list), and the count
// sum's scratch (CUB, under 1 B); the solid grid: 1 B per voxel. A small system (up to
// kTwoLanesUpTo particles, several threads per particle) has a longer list: 328 B per particle
// with 2 lanes, 400 with 4, 544 with 8 (never near a device's limit at that size).
double device_bytes_per_particle(Precision p);
inline constexpr double kDeviceBytesPerCell = 17;

// Memory available now, or nullopt where it cannot be read; `source` names the limit that set it
// ("MemAvailable", "cgroup memory.max", "RLIMIT_AS (ulimit -v)", "cudaMemGetInfo, device 0").
struct MemoryAvailable {
  std::optional<double> bytes;
  std::string source;
};

// The smallest of /proc/meminfo's MemAvailable, the cgroup's limit less its usage (v2 memory.max
// and memory.current, v1 memory.limit_in_bytes and memory.usage_in_bytes) and RLIMIT_AS less the
// process's virtual size (/proc/self/status VmSize).
MemoryAvailable host_memory_available();

// Free memory of CUDA device `device` (cudaMemGetInfo, sim/cuda/device_memory.cu); unknown
// (nullopt) in a build without CUDA or when the device cannot be asked.
MemoryAvailable device_memory_available(int device);

// "5.93e+11 bytes (552.4 GiB)".
std::string bytes_text(double bytes);

// The reason a need of `needed` bytes does not fit `available` ("" when it fits or when the
// available memory is unknown), e.g. "needs about 5.93e+11 bytes (552.4 GiB) of host memory,
// 2.1e+10 bytes (19.6 GiB) available (MemAvailable)". `what`: "host" or "device".
std::string memory_shortfall(double needed, const MemoryAvailable& available,
                             const std::string& what);

}  // namespace mesorock::sim
