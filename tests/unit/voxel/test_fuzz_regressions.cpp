// Replays the image-loader inputs that crashed the fuzzers (tests/data/fuzz/<target>/, found by
// scripts/fuzz.sh and fixed since): each must now load or be refused with a one-line
// mesorock::Error (tests/fuzz/voxel_harness.h), in the normal build as well as the fuzz build.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "fuzz/voxel_harness.h"

namespace {

namespace fs = std::filesystem;
namespace mf = mesorock::fuzz;

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

using Harness = std::function<void(const std::uint8_t*, std::size_t)>;

class LoaderFuzzRegressions : public ::testing::TestWithParam<std::pair<const char*, Harness>> {};

TEST_P(LoaderFuzzRegressions, EveryKeptCrashInputIsNowRefusedCleanly) {
  const fs::path dir = fs::path(MESOROCK_SOURCE_DIR) / "tests/data/fuzz" / GetParam().first;
  if (!fs::exists(dir)) GTEST_SKIP() << "no crash was found for this loader: " << dir;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string bytes = bytes_of(entry.path());
    EXPECT_NO_THROW(
        GetParam().second(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()))
        << entry.path();
  }
}

INSTANTIATE_TEST_SUITE_P(Loaders, LoaderFuzzRegressions,
                         ::testing::Values(std::pair<const char*, Harness>{"tiff", mf::fuzz_tiff},
                                           std::pair<const char*, Harness>{"npy", mf::fuzz_npy},
                                           std::pair<const char*, Harness>{"npz", mf::fuzz_npz},
                                           std::pair<const char*, Harness>{"mhd", mf::fuzz_mhd},
                                           std::pair<const char*, Harness>{"raw", mf::fuzz_raw},
                                           std::pair<const char*, Harness>{"hdf5", mf::fuzz_hdf5}),
                         [](const auto& info) { return std::string(info.param.first); });

}  // namespace
