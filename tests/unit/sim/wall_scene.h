#pragma once
// A scene of frozen wall particles and mobile fluid for the kernels' tests, stored as the GPU
// stores it (the mobile part, then the frozen one, each sorted by cell: StepView::frozen_part),
// with its penetration mask (sim/penetration_mask.h) built on the CPU.
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "sim/kernels.h"
#include "sim/penetration_mask.h"
#include "sim/state.h"

namespace mesorock::test {

namespace ms = mesorock::sim;

// Stores s as the GPU does (StepView::frozen_part): the mobile particles, then those of type
// frozen_type, each part sorted by cell (stable), with the cell list of both parts.
template <class Real>
void split_by_cell(ms::HostState<Real>& s, int frozen_type) {
  const int n = s.size(), cells = s.grid.count();
  std::vector<int> key(n), order(n);
  for (int i = 0; i < n; ++i)
    key[i] = ms::cell_of(s.view(), i) + (s.type[i] == frozen_type ? cells : 0);
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
    split_by_cell(s, 1);
    mask = ms::penetration_mask_geometry<Real>(s.box.lo, s.box.length, 0.125, 1 << 22);
    bits.resize(mask.words());
    const ms::StepView<Real> v = view();
    for (std::size_t w = 0; w < bits.size(); ++w) bits[w] = ms::penetration_mask_word(v, mask, w);
    mask.bits = bits.data();
  }

  ms::StepView<Real> view() {
    auto v = s.view();
    v.frozen_part = s.grid.count();
    return v;
  }
};

}  // namespace mesorock::test
