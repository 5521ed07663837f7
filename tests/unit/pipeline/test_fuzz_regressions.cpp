// Replays the scene-parser inputs that crashed the fuzzer (tests/data/fuzz/scene/, found by
// scripts/fuzz.sh and fixed since): each must now parse or be refused with a one-line
// ConfigError/IoError naming the file (tests/fuzz/scene_harness.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "fuzz/scene_harness.h"
#include "support/test_support.h"

namespace {

namespace fs = std::filesystem;

TEST(SceneFuzzRegressions, EveryKeptCrashInputIsNowRefusedCleanly) {
  const fs::path dir = fs::path(MESOROCK_SOURCE_DIR) / "tests/data/fuzz/scene";
  if (!fs::exists(dir)) GTEST_SKIP() << "no crash was found for the scene parser: " << dir;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string bytes = mesorock::test::read_file(entry.path());
    EXPECT_NO_THROW(mesorock::fuzz::fuzz_scene(reinterpret_cast<const std::uint8_t*>(bytes.data()),
                                               bytes.size()))
        << entry.path();
  }
}

}  // namespace
