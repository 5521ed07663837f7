// The lattice Boltzmann reference's CUDA backend against its CPU backend (label "gpu"; skipped
// without a device): the same node body (lbm/node_update.h) on the same lattice, so the same
// flow to rounding, in both precisions, and the same ladder.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "lbm/ladder.h"
#include "lbm/solver.h"
#include "sim/solid_grid.h"

namespace {

namespace ml = mesorock::lbm;
namespace ms = mesorock::sim;

// Solid spheres of radius 4.2 in a periodic cell of 12 voxels, and a solid plate that breaks the
// symmetry (so no velocity component vanishes identically).
ms::SolidMask spheres_and_plate() {
  ms::SolidMask m;
  m.dims = {12, 12, 12};
  m.solid.assign(12 * 12 * 12, 0);
  for (std::int64_t k = 0; k < 12; ++k)
    for (std::int64_t j = 0; j < 12; ++j)
      for (std::int64_t i = 0; i < 12; ++i)
        m.solid[m.index(i, j, k)] =
            std::hypot(i + 0.5 - 6, j + 0.5 - 6, k + 0.5 - 6) < 4.2 || (k == 0 && j < 5 && i > 2);
  return m;
}

void skip_without_device() {
  const std::string why = ml::cuda_unavailable_reason();
  if (!why.empty()) GTEST_SKIP() << why;
}

TEST(LbmGpu, SameFlowAsTheCpuInBothPrecisions) {
  skip_without_device();
  if (testing::Test::IsSkipped()) return;
  const ms::SolidMask m = spheres_and_plate();
  for (const ml::Precision p : {ml::Precision::Double, ml::Precision::Single}) {
    ml::LbmOptions o;
    o.tau = 0.9;
    o.max_steps = 600;
    o.check_every = 50;
    o.tolerance = 0;
    o.threads = 2;
    o.precision = p;
    const ml::LbmResult cpu = ml::lbm_permeability(m, o);
    o.backend = ml::Backend::CUDA;
    const ml::LbmResult gpu = ml::lbm_permeability(m, o);
    EXPECT_EQ(gpu.backend, ml::Backend::CUDA);
    ASSERT_EQ(cpu.history.size(), gpu.history.size());
    // Double: the same operations, fused multiply-adds aside. Single: rounding of the populations.
    const double tol = p == ml::Precision::Double ? 1e-10 : 1e-5;
    for (std::size_t i = 0; i < cpu.history.size(); ++i)
      EXPECT_NEAR(gpu.history[i].darcy_velocity / cpu.history[i].darcy_velocity - 1, 0, tol)
          << ml::to_string(p) << " check " << i;
    EXPECT_NEAR(gpu.max_velocity / cpu.max_velocity - 1, 0, tol);
    EXPECT_NEAR(gpu.mean_density - 1, 0, 1e-6);
  }
}

TEST(LbmGpu, SameLadderAsTheCpu) {
  skip_without_device();
  if (testing::Test::IsSkipped()) return;
  const ms::SolidMask m = spheres_and_plate();
  ml::LadderOptions o;
  o.refines = {1, 2, 3};
  o.base.tau = 0.9;
  o.base.tolerance = 1e-9;
  o.base.threads = 2;
  const ml::LadderResult cpu = ml::lbm_ladder(m, o);
  o.base.backend = ml::Backend::CUDA;
  const ml::LadderResult gpu = ml::lbm_ladder(m, o);
  ASSERT_EQ(cpu.rungs.size(), gpu.rungs.size());
  for (std::size_t i = 0; i < cpu.rungs.size(); ++i) {
    // Each rung stops at its tolerance (1e-9 per check): a check earlier or later is allowed.
    EXPECT_NEAR(gpu.rungs[i].k_voxel2 / cpu.rungs[i].k_voxel2 - 1, 0, 1e-6) << i;
  }
  EXPECT_NEAR(gpu.extrapolation.k_voxel2 / cpu.extrapolation.k_voxel2 - 1, 0, 1e-5);
}

}  // namespace
