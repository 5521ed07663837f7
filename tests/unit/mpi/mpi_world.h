#pragma once
// The ranks of the unit_mpi run (null when the program was not started by mpirun: the tests then
// skip).
#include <memory>

#include "sim/domain/communicator.h"

namespace mesorock::test {
extern std::shared_ptr<sim::Communicator> g_world;
}  // namespace mesorock::test

#define MESOROCK_REQUIRE_RANKS()                                              \
  do {                                                                        \
    if (!::mesorock::test::g_world || ::mesorock::test::g_world->size() < 2)  \
      GTEST_SKIP() << "needs mpirun with at least 2 ranks (ctest label mpi)"; \
  } while (0)
