// GoogleTest under mpirun: every rank runs every test (the decomposed simulation's calls are
// collective); rank 0 alone prints; the program fails on every rank if a test failed on any.
#include <gtest/gtest.h>

#include "mpi_world.h"
#include "sim/domain/communicator.h"

namespace mesorock::test {
std::shared_ptr<sim::Communicator> g_world;
}

int main(int argc, char** argv) {
  mesorock::sim::MpiSession mpi(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  mesorock::test::g_world = mpi.world();
  auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
  if (mpi.world() && mpi.world()->rank() != 0)
    delete listeners.Release(listeners.default_result_printer());
  int failed = RUN_ALL_TESTS() != 0 ? 1 : 0;
  if (mpi.world()) {
    double f = failed;
    mpi.world()->max(&f, 1);
    failed = f > 0 ? 1 : 0;
  }
  mesorock::test::g_world.reset();
  return failed;
}
