// The geometry of the domain decomposition (sim/domain/decomposition.h): regions tile the box,
// RCB splits a weight in proportion to the ranks, owners and ghost sends (halo targets) are
// right across periodic faces. The decomposed runs themselves are tested under mpirun
// (tests/unit/mpi).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/domain/decomposition.h"

namespace ms = mesorock::sim;

namespace {

ms::BoxSpec box(double x, double y, double z, bool periodic = true) {
  ms::BoxSpec b;
  b.hi = {x, y, z};
  b.periodic = {periodic, periodic, periodic};
  return b;
}

double volume(const ms::Region& r) {
  return r.width(0) * r.width(1) * r.width(2);
}

TEST(Decomposition, SlabsTileTheBox) {
  const ms::Decomposition d = ms::Decomposition::slabs(box(12, 4, 4), 3, 1u);
  ASSERT_EQ(d.size(), 3);
  EXPECT_DOUBLE_EQ(d.region(0).lo[0], 0.0);
  EXPECT_DOUBLE_EQ(d.region(1).lo[0], 4.0);
  EXPECT_DOUBLE_EQ(d.region(2).hi[0], 12.0);
  const double x[3] = {5.0, 1.0, 1.0};
  EXPECT_EQ(d.owner(x), 1);
  const double outside[3] = {12.0, 1.0, 1.0};
  EXPECT_EQ(d.owner(outside), -1);
}

// A weight that is all in x < 4 of a 16-long box: RCB puts every cut there, slabs would not.
TEST(Decomposition, RcbSplitsTheWeightNotTheVolume) {
  const ms::BoxSpec b = box(16, 4, 4);
  auto weight = [](const ms::Region& g, int axis, int bins) {
    std::vector<double> h(static_cast<size_t>(bins), 0.0);
    for (int k = 0; k < bins; ++k) {
      const double c = g.lo[static_cast<size_t>(axis)] + (k + 0.5) * g.width(axis) / bins;
      const double x = axis == 0 ? c : 0.5 * (g.lo[0] + g.hi[0]);
      h[static_cast<size_t>(k)] = x < 4 ? g.width(axis) / bins : 0.0;  // uniform in x < 4
    }
    return h;
  };
  const ms::Decomposition d = ms::Decomposition::rcb(b, 4, weight, 1u, 0.5);
  ASSERT_EQ(d.size(), 4);
  double total = 0;
  for (int r = 0; r < 4; ++r) total += volume(d.region(r));
  EXPECT_NEAR(total, 16 * 16, 1e-9);
  // Cuts at 1, 2, 3: each rank gets a quarter of the weight.
  EXPECT_NEAR(d.region(0).hi[0], 1.0, 0.02);
  EXPECT_NEAR(d.region(1).hi[0], 2.0, 0.02);
  EXPECT_NEAR(d.region(2).hi[0], 3.0, 0.02);
  EXPECT_DOUBLE_EQ(d.region(3).hi[0], 16.0);
}

TEST(Decomposition, RcbWithUnevenRankCountsAndEveryAxis) {
  const ms::BoxSpec b = box(12, 6, 6);
  auto uniform = [](const ms::Region& g, int, int bins) {
    return std::vector<double>(static_cast<size_t>(bins), volume(g) / bins);
  };
  const ms::Decomposition d = ms::Decomposition::rcb(b, 3, uniform, 7u, 0.5);
  ASSERT_EQ(d.size(), 3);
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(volume(d.region(r)), 12 * 36 / 3.0, 0.5);
  // Every point of the box has exactly one owner.
  for (double x = 0.05; x < 12; x += 0.7)
    for (double y = 0.05; y < 6; y += 0.7) {
      const double p[3] = {x, y, 3.0};
      EXPECT_GE(d.owner(p), 0);
    }
}

// Two slabs of a periodic box: rank 0 = [0, 5) sends its particles within the halo of x = 5 to
// rank 1 unshifted, and those within the halo of x = 0 shifted by +10 (rank 1's periodic
// neighbour across x = 10); y and z are spanned by both, so no images there.
TEST(Decomposition, HaloTargetsCrossPeriodicFaces) {
  const ms::BoxSpec b = box(10, 4, 4);
  const ms::Decomposition d = ms::Decomposition::slabs(b, 2, 1u);
  const auto t = ms::halo_targets(d, b, 0, 1.1);
  ASSERT_EQ(t.size(), 2u);
  for (const auto& h : t) {
    EXPECT_EQ(h.rank, 1);
    EXPECT_DOUBLE_EQ(h.box.lo[1], 0.0);
    EXPECT_DOUBLE_EQ(h.box.hi[1], 4.0);
    EXPECT_DOUBLE_EQ(h.shift[1], 0.0);
  }
  const auto& near = t[0].shift[0] == 0 ? t[0] : t[1];
  const auto& wrapped = t[0].shift[0] == 0 ? t[1] : t[0];
  EXPECT_NEAR(near.box.lo[0], 3.9, 1e-12);
  EXPECT_DOUBLE_EQ(near.box.hi[0], 5.0);
  EXPECT_DOUBLE_EQ(wrapped.shift[0], 10.0);
  EXPECT_DOUBLE_EQ(wrapped.box.lo[0], 0.0);
  EXPECT_NEAR(wrapped.box.hi[0], 1.1, 1e-12);
  // Reflective x: no image across the faces.
  const ms::BoxSpec r = box(10, 4, 4, false);
  const auto u = ms::halo_targets(ms::Decomposition::slabs(r, 2, 1u), r, 0, 1.1);
  ASSERT_EQ(u.size(), 1u);
  EXPECT_DOUBLE_EQ(u[0].shift[0], 0.0);
}

}  // namespace
