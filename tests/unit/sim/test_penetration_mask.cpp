// The penetration mask (sim/penetration_mask.h): wherever a cell's bit is clear, phi over the
// frozen part (what the GPU's corrector before the sort computes, Parts::FrozenOnly) is at most
// phi_c, so skipping the scan there changes no decision. Checked at random points against the
// scan itself, in float and double, on periodic and reflective axes, an axis too short for the
// 3-cell stencil and 2 cells per cutoff; and the mask must leave most of the fluid clear, or it
// saves nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "sim/kernels.h"
#include "sim/penetration_mask.h"
#include "sim/state.h"

namespace ms = mesorock::sim;

namespace {

struct Case {
  double length[3] = {7, 6, 8};
  bool periodic[3] = {true, true, true};
  int reach = 1;
};

// Types: 0 fluid, 1 frozen wall. Wall particles at n_w = 6 fill z < wall_top and a ball of
// radius 1.2 in the fluid, whose concave side and edges give phi of every size; the fluid fills
// the rest. The storage holds the mobile part, then the frozen one, each sorted by cell (the
// GPU's layout, StepView::frozen_part).
template <class Real>
struct WallScene {
  ms::HostState<Real> s;
  std::vector<std::uint32_t> bits;
  ms::PenetrationMask<Real> mask;
  static constexpr double kWallTop = 2.5;

  explicit WallScene(const Case& c, unsigned seed = 5) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (int a = 0; a < 3; ++a) {
      s.box.lo[a] = Real(-0.5);
      s.box.length[a] = Real(c.length[a]);
      s.box.periodic[a] = c.periodic[a];
    }
    const double ball[3] = {c.length[0] / 2, c.length[1] / 2, kWallTop + 2.2};
    const int n = static_cast<int>(6 * c.length[0] * c.length[1] * c.length[2]);
    for (int i = 0; i < n; ++i) {
      const double p[3] = {c.length[0] * u(rng), c.length[1] * u(rng), c.length[2] * u(rng)};
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += (p[a] - ball[a]) * (p[a] - ball[a]);
      const bool wall = p[2] < kWallTop || d2 < 1.44;
      s.x.push_back(Real(p[0] - 0.5)), s.y.push_back(Real(p[1] - 0.5));
      s.z.push_back(Real(p[2] - 0.5));
      for (auto* v : {&s.vx, &s.vy, &s.vz}) v->push_back(Real(0));
      s.type.push_back(wall ? 1 : 0);
      s.id.push_back(i);
      s.origin.push_back(i);
    }
    s.fx.assign(n, 0), s.fy.assign(n, 0), s.fz.assign(n, 0), s.rho.assign(n, 0);
    s.bvf.assign(n, 0);
    s.ntypes = 2;
    s.frozen_mask = 1u << 1;
    s.walls.wall_mask = 1u << 1;
    s.walls.inv_wall_density = Real(1.0 / 6);
    s.grid = ms::CellGrid<Real>::make(s.box, Real(1), c.reach);
    split_by_cell();
    mask = ms::penetration_mask_geometry<Real>(s.box.lo, s.box.length, 0.125, 1 << 22);
    bits.resize(mask.words());
    const ms::StepView<Real> v = view();
    for (std::size_t w = 0; w < bits.size(); ++w) bits[w] = ms::penetration_mask_word(v, mask, w);
    mask.bits = bits.data();
  }

  void split_by_cell() {
    const int n = s.size(), cells = s.grid.count();
    std::vector<int> key(n), order(n);
    for (int i = 0; i < n; ++i) key[i] = ms::cell_of(s.view(), i) + (s.type[i] == 1 ? cells : 0);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return key[a] < key[b]; });
    s.for_each_particle_array([&](auto& v) {
      auto copy = v;
      for (int k = 0; k < n; ++k) v[k] = copy[order[k]];
    });
    s.cell_start.assign(2 * cells + 1, 0);
    for (int k : key) ++s.cell_start[k + 1];
    for (int k = 0; k < 2 * cells; ++k) s.cell_start[k + 1] += s.cell_start[k];
  }

  ms::StepView<Real> view() {
    auto v = s.view();
    v.frozen_part = s.grid.count();
    return v;
  }
};

struct Sampled {
  int points = 0, scanned = 0, past_phi_c = 0, missed = 0;
  double worst_missed_phi = 0;
};

// phi over the frozen part at random points (particle 0, a fluid one, moved there), and what the
// mask says of each.
template <class Real>
Sampled sample(WallScene<Real>& scene, int points, unsigned seed = 9) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  auto v = scene.view();
  Sampled out;
  for (int k = 0; k < points; ++k) {
    Real* p[3] = {v.x, v.y, v.z};
    for (int a = 0; a < 3; ++a)
      p[a][0] = v.box.lo[a] + static_cast<Real>(u(rng) * static_cast<double>(v.box.length[a]));
    const Real phi = ms::wall_fraction(v, 0, ms::Parts::FrozenOnly);
    const bool may = scene.mask.may_exceed(v.x[0], v.y[0], v.z[0]);
    ++out.points;
    out.scanned += may;
    if (phi > v.walls.phi_c) {
      ++out.past_phi_c;
      if (!may) {
        ++out.missed;
        out.worst_missed_phi = std::max(out.worst_missed_phi, static_cast<double>(phi));
      }
    }
  }
  return out;
}

template <class Real>
void expect_sound(const Case& c) {
  WallScene<Real> scene(c);
  ASSERT_EQ(scene.view().type[0], 0);  // particle 0 is mobile fluid (the mobile part comes first)
  const Sampled s = sample(scene, 60000);
  // The test has teeth only if some points are past phi_c (inside the wall slab and the ball).
  EXPECT_GT(s.past_phi_c, s.points / 10);
  EXPECT_EQ(s.missed, 0) << "worst phi in a clear cell: " << s.worst_missed_phi;
  // Most of the pore (z above the wall slab by more than rc, away from the ball) is clear: the
  // slab and the ball take about 45% of the box, so a mask that saved nothing would scan all.
  EXPECT_LT(s.scanned, s.points * 3 / 4);
}

template <class Real>
class PenetrationMaskTest : public ::testing::Test {};
using Reals = ::testing::Types<float, double>;
TYPED_TEST_SUITE(PenetrationMaskTest, Reals);

TYPED_TEST(PenetrationMaskTest, AClearCellNeverHidesPhiPastPhiC) {
  expect_sound<TypeParam>(Case{});
}

TYPED_TEST(PenetrationMaskTest, HoldsOnReflectiveAxesAndAShortPeriodicAxis) {
  Case c;
  c.periodic[2] = false;  // the wall slab against a reflective face
  c.length[0] = 2.5;      // 2 cells along x: the stencil takes the whole axis
  expect_sound<TypeParam>(c);
}

TYPED_TEST(PenetrationMaskTest, HoldsWithTwoCellsPerCutoff) {
  Case c;
  c.reach = 2;
  expect_sound<TypeParam>(c);
}

// A point deep in the wall is set, one more than rc from every wall particle is clear.
TEST(PenetrationMask, SetsTheWallAndClearsThePore) {
  WallScene<double> scene(Case{});
  EXPECT_TRUE(scene.mask.may_exceed(3.0, 2.5, 0.0));   // z = 0.5 before the shift: deep in the slab
  EXPECT_FALSE(scene.mask.may_exceed(0.0, 0.0, 4.5));  // 2.5 rc from the slab, 2.7 from the ball
  EXPECT_TRUE(scene.mask.may_exceed(-10, 0, 0));       // outside the grid: scanned
  EXPECT_TRUE(scene.mask.may_exceed(0, std::nan(""), 0));
}

TEST(PenetrationMask, GeometryCoversTheBoxInWholeWordsWithinItsCellCap) {
  const double lo[3] = {-1, 0, 2}, length[3] = {50, 40, 30};
  const auto fine = ms::penetration_mask_geometry<double>(lo, length, 0.125, 1e9);
  EXPECT_EQ(fine.dims[0] % 32, 0);
  EXPECT_EQ(fine.dims[1], 320);
  EXPECT_EQ(fine.dims[2], 240);
  EXPECT_GE(fine.dims[0] * fine.cell[0], 50);
  const auto capped = ms::penetration_mask_geometry<double>(lo, length, 0.125, 1e6);
  EXPECT_LE(static_cast<double>(capped.words()) * 32, 1e6);
  for (int a = 0; a < 3; ++a) EXPECT_GE(capped.dims[a] * capped.cell[a], length[a]);
  EXPECT_GT(capped.cell[0], 0.125);
}

}  // namespace
