// The CPU's half neighbour list (sim/half_list.h) and the Newton pair passes over it: each pair
// within the cutoff once; rho, phi and the forces those of the per-particle gather (the GPU's
// form, sim/kernels.h) to round-off; frozen-frozen pairs out of the force pass; the same bits on
// 1, 2 and 3 threads. Cases: periodic and reflective axes, an axis too short for the 3-cell
// stencil, 2 cells per cutoff, and a list of rc + skin kept while the particles move.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "sim/half_list.h"
#include "sim/state.h"
#include "sim/stepper.h"
#include "sim/terms.h"
#include "unit/sim/wall_scene.h"

namespace ms = mesorock::sim;

namespace {

using MDPD = ms::ConservativeMDPD<ms::DensityKernelWarren>;
using Terms =
    ms::TermSet<MDPD, ms::DPDThermostat, ms::PerTypeBodyForce, ms::BoundaryVolumeFractionWalls>;

struct Case {
  double length[3] = {9, 8, 7};
  bool periodic[3] = {true, true, true};
  int reach = 1;
  double skin = 0;
};

// Types: 0 fluid, 1 frozen wall, 2 a second fluid. Random positions at rho = 6, sorted by cell.
struct System {
  ms::HostState<double> s;
  std::vector<double> kappa_table{1.0, 2.0, 3.0, 4.0};

  explicit System(const Case& c, unsigned seed = 7) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (int a = 0; a < 3; ++a) {
      s.box.lo[a] = -1;
      s.box.length[a] = c.length[a];
      s.box.periodic[a] = c.periodic[a];
    }
    const int n = static_cast<int>(6 * c.length[0] * c.length[1] * c.length[2]);
    for (int i = 0; i < n; ++i) {
      s.x.push_back(-1 + c.length[0] * u(rng));
      s.y.push_back(-1 + c.length[1] * u(rng));
      s.z.push_back(-1 + c.length[2] * u(rng));
      for (auto* v : {&s.vx, &s.vy, &s.vz, &s.vex, &s.vey, &s.vez}) v->push_back(u(rng) - 0.5);
      const double t = u(rng);
      s.type.push_back(t < 0.4 ? 1 : (t < 0.7 ? 2 : 0));
      s.id.push_back(1000 + 3 * i);
      s.origin.push_back(i);
    }
    s.fx.assign(n, 0), s.fy.assign(n, 0), s.fz.assign(n, 0), s.rho.assign(n, 0);
    s.bvf.assign(n, 0);
    s.ntypes = 3;
    const double a[3][3] = {{-40, -30, -35}, {-30, -20, -25}, {-35, -25, -40}};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) s.table.push_back({a[i][j], 25, 4.5, 3});
    s.body_force = {0.1, 0, 0, 0, 0, 0, 0, 0.2, 0};
    s.frozen_mask = 1u << 1;
    s.walls.wall_mask = 1u << 1;
    s.walls.inv_wall_density = 1.0 / 6;
    s.kappa = kappa_table;
    s.walls.entries = 4;
    s.walls.phi_max = 0.5;
    s.seed = 11;
    s.step = 5;
    s.skin = c.skin;
    s.reorder_every = c.skin > 0 ? 10 : 1;
    s.grid = ms::CellGrid<double>::make(s.box, 1 + c.skin, c.reach);
    sort();
  }

  // A stable sort of the storage by cell, and the cell list.
  void sort() {
    const int n = s.size();
    std::vector<int> cell(n), order(n);
    for (int i = 0; i < n; ++i)
      cell[i] = s.grid.index(s.grid.coordinate(s.x[i], s.box.lo[0], 0),
                             s.grid.coordinate(s.y[i], s.box.lo[1], 1),
                             s.grid.coordinate(s.z[i], s.box.lo[2], 2));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cell[a] < cell[b]; });
    s.for_each_particle_array([&](auto& v) {
      auto copy = v;
      for (int k = 0; k < n; ++k) v[k] = copy[order[k]];
    });
    s.cell_start.assign(s.grid.count() + 1, 0);
    for (int c : cell) ++s.cell_start[c + 1];
    for (int c = 0; c < s.grid.count(); ++c) s.cell_start[c + 1] += s.cell_start[c];
  }

  virtual ~System() = default;
  System(const System&) = default;
  System& operator=(const System&) = default;
  // The kernels' view; kept_sums: with a frozen part's static sums where there are some.
  virtual ms::StepView<double> view(bool kept_sums = true) {
    (void)kept_sums;
    return s.view();
  }

  // rho, phi and f by the gather (one particle at a time, each pair from both sides, the static
  // sums not used).
  void gather() {
    const auto v = view(false);
    ms::SumsPass<double, ms::DensityKernelWarren, true> sums;
    ms::ForcePass<double, Terms> forces;
    for (int i = 0; i < v.n; ++i) sums(v, i);
    for (int i = 0; i < v.n; ++i) forces(v, i, ms::NeighbourStash{});
  }

  // The same by Newton's third law over the half list.
  template <class Pass>
  void newton(const ms::HalfList<double>& list, const Pass& pass) {
    const auto v = view();
    for (int i = 0; i < v.n; ++i) pass.begin(v, i);
    list.for_each_particle(v, pass, [] {});
    for (int i = 0; i < v.n; ++i) pass.finish(v, i);
  }
  void newton(const ms::HalfList<double>& list) {
    newton(list, ms::SumsPass<double, ms::DensityKernelWarren, true>{});
    newton(list, ms::ForcePass<double, Terms>{});
  }
};

double worst_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]) / (1 + std::abs(a[i])));
  return worst;
}

// Pairs within the cutoff by brute force (minimum image), and by the list.
int brute_pairs(ms::HostState<double>& s, double cutoff) {
  const auto v = s.view();
  int count = 0;
  for (int i = 0; i < v.n; ++i)
    for (int j = i + 1; j < v.n; ++j) {
      double dx, dy, dz;
      if (ms::separation2(v, i, j, dx, dy, dz) < cutoff * cutoff) ++count;
    }
  return count;
}

void expect_newton_matches_gather(const Case& c, const char* what) {
  System a(c);
  ms::HalfList<double> list;
  list.build(a.s.view(), 1 + c.skin);
  EXPECT_EQ(static_cast<int>(list.pair_count()), brute_pairs(a.s, 1 + c.skin)) << what;
  if (c.skin > 0) {
    // The list stays valid while nobody has moved more than skin / 2.
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-1, 1);
    const double step = 0.49 * c.skin / std::sqrt(3.0);
    for (int i = 0; i < a.s.size(); ++i) {
      if (a.s.type[i] == 1) continue;  // frozen
      a.s.x[i] += step * u(rng), a.s.y[i] += step * u(rng), a.s.z[i] += step * u(rng);
      for (int ax = 0; ax < 3; ++ax) {
        std::vector<double>& p = ax == 0 ? a.s.x : (ax == 1 ? a.s.y : a.s.z);
        p[i] = std::clamp(p[i], a.s.box.lo[ax], a.s.box.lo[ax] + a.s.box.length[ax] - 1e-9);
      }
    }
  }
  System b = a;
  a.gather();
  b.newton(list);
  EXPECT_LT(worst_difference(a.s.rho, b.s.rho), 1e-13) << what;
  EXPECT_LT(worst_difference(a.s.bvf, b.s.bvf), 1e-13) << what;
  EXPECT_LT(worst_difference(a.s.fx, b.s.fx), 1e-11) << what;
  EXPECT_LT(worst_difference(a.s.fy, b.s.fy), 1e-11) << what;
  EXPECT_LT(worst_difference(a.s.fz, b.s.fz), 1e-11) << what;
  double total = 0;
  for (int i = 0; i < b.s.size(); ++i) total += std::abs(b.s.fx[i]);
  EXPECT_GT(total, 1.0) << what;  // forces there are
  for (int i = 0; i < b.s.size(); ++i)
    if (b.s.type[i] == 1) ASSERT_EQ(b.s.fx[i], 0.0) << what;  // frozen: no force
}

TEST(HalfList, NewtonPassesMatchTheGatherOnEveryGeometry) {
  expect_newton_matches_gather(Case{}, "periodic box");
  Case reflective;
  reflective.periodic[2] = false;
  expect_newton_matches_gather(reflective, "reflective z");
  Case short_axis;
  short_axis.length[1] = 3.5;  // 3 cells: the stencil covers the axis whole
  short_axis.length[2] = 2.5;  // 2 cells
  expect_newton_matches_gather(short_axis, "short axes");
  Case fine;
  fine.reach = 2;
  expect_newton_matches_gather(fine, "2 cells per rc");
  Case skin;
  skin.skin = 0.3;
  expect_newton_matches_gather(skin, "skin 0.3, moved up to skin / 2");
}

TEST(HalfList, FrozenPairsComeLastAndOnlyFeedTheDensity) {
  System a(Case{});
  ms::HalfList<double> list;
  list.build(a.s.view(), 1);
  int frozen_pairs = 0, force_pairs = 0;
  struct Count {
    int* frozen;
    int* force;
    const std::int32_t* type;
    void pairs(const ms::StepView<double>&, int i, const int* first, const int* force_end,
               const int* last) const {
      for (const int* p = first; p < force_end; ++p) EXPECT_FALSE(type[i] == 1 && type[*p] == 1);
      for (const int* p = force_end; p < last; ++p) EXPECT_TRUE(type[i] == 1 && type[*p] == 1);
      *force += static_cast<int>(force_end - first);
      *frozen += static_cast<int>(last - force_end);
    }
  };
  omp_set_num_threads(1);
  list.for_each_particle(a.s.view(), Count{&frozen_pairs, &force_pairs, a.s.type.data()}, [] {});
  EXPECT_GT(frozen_pairs, 0);
  EXPECT_EQ(static_cast<size_t>(frozen_pairs + force_pairs), list.pair_count());
}

// The CPU engine's frozen part (StepView::frozen_part): the storage split into the mobile
// particles, then the frozen ones, each sorted by cell; each frozen particle's sums over its
// frozen neighbours kept (frozen_rho, frozen_bvf); the half list built from that storage holds
// the mobile particles' pairs only. rho, phi and the forces must be the gather's over every pair.
struct SplitSystem : System {
  std::vector<double> frozen_rho, frozen_bvf;
  bool sums_kept = false;

  explicit SplitSystem(const Case& c) : System(c) {
    mesorock::test::split_by_cell(s, 1);
    const int n = s.size(), cells = s.grid.count();
    const int start = s.cell_start[cells];
    frozen_rho.assign(n - start, 0);
    frozen_bvf.assign(n - start, 0);
    for (int i = start; i < n; ++i)
      ms::frozen_sums_of_particle<double, ms::DensityKernelWarren, true>(
          view(), i, frozen_rho.data(), frozen_bvf.data());
    sums_kept = true;
  }
  ms::StepView<double> view(bool kept_sums = true) override {
    auto v = s.view();
    v.frozen_part = s.grid.count();
    if (sums_kept && kept_sums) v.frozen_rho = frozen_rho.data(), v.frozen_bvf = frozen_bvf.data();
    return v;
  }
};

TEST(HalfList, AFrozenPartKeepsItsSumsAndListsOnlyTheMobilePairs) {
  for (const double skin : {0.0, 0.3}) {
    Case c;
    c.skin = skin;
    SplitSystem a(c);
    ms::HalfList<double> list;
    list.build(a.view(), 1 + skin);
    int frozen_pairs = 0;
    const auto v = a.view();
    for (int i = 0; i < v.n; ++i)
      for (int j = i + 1; j < v.n; ++j) {
        double dx, dy, dz;
        if (a.s.type[i] == 1 && a.s.type[j] == 1 &&
            ms::separation2(v, i, j, dx, dy, dz) < (1 + skin) * (1 + skin))
          ++frozen_pairs;
      }
    EXPECT_GT(frozen_pairs, 0);
    EXPECT_EQ(static_cast<int>(list.pair_count()), brute_pairs(a.s, 1 + skin) - frozen_pairs);
    SplitSystem b = a;
    a.gather();
    b.newton(list);
    EXPECT_LT(worst_difference(a.s.rho, b.s.rho), 1e-13) << "skin " << skin;
    EXPECT_LT(worst_difference(a.s.bvf, b.s.bvf), 1e-13) << "skin " << skin;
    EXPECT_LT(worst_difference(a.s.fx, b.s.fx), 1e-11) << "skin " << skin;
    EXPECT_LT(worst_difference(a.s.fz, b.s.fz), 1e-11) << "skin " << skin;
    // The static sums are a large part of a frozen particle's density (a mutant that ignored them
    // would fail the comparison above by far).
    double kept = 0, whole = 0;
    for (int i = a.s.cell_start[a.s.grid.count()]; i < a.s.size(); ++i) whole += a.s.rho[i];
    for (double r : a.frozen_rho) kept += r;
    EXPECT_GT(kept, 0.3 * whole);
  }
}

// The half list's fill walks each cell's stencil as runs kept once per cell
// (HalfList::stencil_runs); they must be exactly the candidates for_each_candidate scans for a
// particle of that cell, in its order and with its separations, or the lists (and every bit of
// the CPU's sums) would change.
void expect_cell_runs_are_the_candidate_scan(System& a, const char* what) {
  const auto v = a.view();
  std::vector<ms::HalfList<double>::Run> runs;
  int checked = 0;
  for (int i = 0; i < v.n; ++i) {
    if (v.frozen_part > 0 && i >= v.cell_start[v.frozen_part]) break;  // the mobile part's lists
    struct Seen {
      int j;
      double dx, dy, dz;
      bool operator==(const Seen& o) const {
        return j == o.j && dx == o.dx && dy == o.dy && dz == o.dz;
      }
    };
    std::vector<Seen> scan, walked;
    ms::for_each_candidate(v, i, [&](int j, double dx, double dy, double dz, double) {
      scan.push_back({j, dx, dy, dz});
    });
    const ms::CellGrid<double>& g = v.grid;
    const int c[3] = {g.coordinate(v.x[i], v.box.lo[0], 0), g.coordinate(v.y[i], v.box.lo[1], 1),
                      g.coordinate(v.z[i], v.box.lo[2], 2)};
    bool image[3];
    ms::HalfList<double>::stencil_runs(v, c, runs, image);
    for (const auto& run : runs)
      for (int j = run.first; j < run.end; ++j) {
        double d[3] = {(v.x[i] - v.x[j]) - run.shift[0], (v.y[i] - v.y[j]) - run.shift[1],
                       (v.z[i] - v.z[j]) - run.shift[2]};
        for (int ax = 0; ax < 3; ++ax)
          if (image[ax]) d[ax] = v.box.minimum_image(d[ax], ax);
        walked.push_back({j, d[0], d[1], d[2]});
      }
    ASSERT_TRUE(scan == walked) << what << ": particle " << i << ", " << scan.size()
                                << " candidates scanned, " << walked.size() << " walked";
    ++checked;
  }
  EXPECT_GT(checked, 100) << what;
}

TEST(HalfList, CellRunsAreTheCandidateScan) {
  Case reflective, short_axis, fine, skin;
  reflective.periodic[2] = false;
  short_axis.length[1] = 3.5;
  short_axis.length[2] = 2.5;
  fine.reach = 2;
  skin.skin = 0.3;
  for (const auto& [c, what] :
       {std::pair{Case{}, "periodic box"}, std::pair{reflective, "reflective z"},
        std::pair{short_axis, "short axes"}, std::pair{fine, "2 cells per rc"},
        std::pair{skin, "skin 0.3"}}) {
    System a(c);
    expect_cell_runs_are_the_candidate_scan(a, what);
  }
  SplitSystem split(Case{});
  expect_cell_runs_are_the_candidate_scan(split, "a frozen part");
}

TEST(HalfList, TheThreadCountChangesNoBit) {
  std::vector<System> runs;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    System s(Case{});
    ms::HalfList<double> list;
    list.build(s.s.view(), 1);
    s.newton(list);
    runs.push_back(s);
  }
  for (size_t k = 1; k < runs.size(); ++k) {
    EXPECT_EQ(runs[0].s.rho, runs[k].s.rho);
    EXPECT_EQ(runs[0].s.bvf, runs[k].s.bvf);
    EXPECT_EQ(runs[0].s.fx, runs[k].s.fx);
    EXPECT_EQ(runs[0].s.fz, runs[k].s.fz);
  }
  omp_set_num_threads(1);
}

}  // namespace
