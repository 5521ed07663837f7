// libFuzzer target: see tests/fuzz/voxel_harness.h (fuzz_npz) and scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>

#include "voxel_harness.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mesorock::fuzz::fuzz_npz(data, size);
  return 0;
}
