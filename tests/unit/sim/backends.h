#pragma once
// One test body for every backend (Cabana-style): TEST_P over the backends, CUDA skipped cleanly
// when this build or machine has none.
#include <gtest/gtest.h>

#include <string>

#include "sim/simulation.h"

namespace mesorock::test {

class OnEveryBackend : public ::testing::TestWithParam<sim::BackendKind> {
 protected:
  void SetUp() override {
    if (GetParam() == sim::BackendKind::CUDA) {
      const std::string why = sim::cuda_unavailable_reason();
      if (!why.empty()) GTEST_SKIP() << "no CUDA backend here: " << why;
    }
  }
  sim::SimulationOptions options() const {
    sim::SimulationOptions o;
    o.backend = GetParam();
    return o;
  }
};

inline std::string backend_test_name(const ::testing::TestParamInfo<sim::BackendKind>& info) {
  return sim::to_string(info.param);
}

#define MESOROCK_ON_EVERY_BACKEND(suite)                                                        \
  INSTANTIATE_TEST_SUITE_P(                                                                     \
      Backends, suite,                                                                          \
      ::testing::Values(::mesorock::sim::BackendKind::CPU, ::mesorock::sim::BackendKind::CUDA), \
      ::mesorock::test::backend_test_name)

}  // namespace mesorock::test
