// libFuzzer target: see tests/fuzz/scene_harness.h (fuzz_scene) and scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>

#include "scene_harness.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mesorock::fuzz::fuzz_scene(data, size);
  return 0;
}
