// Pore statistics and connected clusters against brute-force references (reference.h) on random
// volumes: several shapes (including single slices and tall volumes that split into many
// parallel slabs), porosities near and above the percolation threshold, seeds, and both
// connectivities.
#include <gtest/gtest.h>

#include "mesorock/errors.h"
#include "reference.h"
#include "test_util.h"
#include "voxel/pore_analysis.h"

namespace mesorock::voxel::test {
namespace {

void expect_clusters_match(const Volume& labels, int connectivity) {
  const std::vector<RefCluster> ref = ref_clusters(labels, connectivity);
  ClusterOptions o;
  o.connectivity = connectivity;
  const std::vector<Cluster> got = find_pore_clusters(find_pore_runs(labels), o);
  ASSERT_EQ(got.size(), ref.size()) << "connectivity " << connectivity;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    ASSERT_EQ(got[i].voxels, ref[i].voxels) << "cluster " << i;
    ASSERT_EQ(unsigned(got[i].faces), ref[i].faces) << "cluster " << i;
    for (std::size_t a = 0; a < 3; ++a) {
      ASSERT_EQ(got[i].lo[a], ref[i].lo[a]) << "cluster " << i << " axis " << a;
      ASSERT_EQ(got[i].hi[a], ref[i].hi[a]) << "cluster " << i << " axis " << a;
    }
  }
  // Percolation summary against sums over the reference clusters.
  const PercolationSummary sum = summarize_clusters(got, 5);
  std::array<std::int64_t, 3> spanning{};
  std::int64_t isolated = 0, isolated_clusters = 0;
  std::vector<std::int64_t> isolated_sizes;
  for (const RefCluster& c : ref) {
    bool any = false;
    for (int a = 0; a < 3; ++a) {
      const bool spans = (c.faces >> (2 * a) & 3u) == 3u;
      if (spans) spanning[std::size_t(a)] += c.voxels;
      any = any || spans;
    }
    if (!any) {
      isolated += c.voxels;
      ++isolated_clusters;
      isolated_sizes.push_back(c.voxels);
    }
  }
  EXPECT_EQ(sum.spanning_voxels, spanning);
  EXPECT_EQ(sum.isolated_voxels, isolated);
  EXPECT_EQ(sum.isolated_clusters, isolated_clusters);
  std::sort(isolated_sizes.rbegin(), isolated_sizes.rend());
  ASSERT_EQ(sum.largest_isolated.size(), std::min<std::size_t>(5, isolated_sizes.size()));
  for (std::size_t i = 0; i < sum.largest_isolated.size(); ++i) {
    EXPECT_EQ(sum.largest_isolated[i].voxels, isolated_sizes[i]);
  }
}

TEST(PoreClusters, MatchFloodFillOnRandomVolumes) {
  const Shape shapes[] = {{17, 19, 23}, {1, 30, 31},  {29, 1, 27},
                          {24, 26, 1},  {100, 9, 11}, {6, 7, 5}};
  int checked = 0;
  for (const Shape& shape : shapes) {
    for (double pore : {0.25, 0.33, 0.55}) {
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const Volume labels = random_labels(shape, pore, 0.05, seed * 7919 + checked);
        SCOPED_TRACE(shape.str() + " pore " + std::to_string(pore) + " seed " +
                     std::to_string(seed));
        expect_clusters_match(labels, 6);
        expect_clusters_match(labels, 26);
        ++checked;
      }
    }
  }
}

TEST(PoreClusters, DiagonalContactsJoinOnlyWith26) {
  // Two voxels touching at a corner, two touching at an edge, one isolated.
  Volume v(Shape{3, 3, 6}, DType::kUInt8);
  std::fill_n(v.data<std::uint8_t>(), v.voxels(), std::uint8_t(3));
  auto at = [&](int z, int y, int x) -> std::uint8_t& {
    return v.data<std::uint8_t>()[(z * 3 + y) * 6 + x];
  };
  at(0, 0, 0) = 1;
  at(1, 1, 1) = 4;  // corner contact with (0,0,0)
  at(0, 0, 4) = 1;
  at(0, 1, 5) = 1;  // edge contact with (0,0,4)
  at(2, 2, 2) = 1;  // corner contact with (1,1,1)
  const PoreRuns runs = find_pore_runs(v);
  EXPECT_EQ(runs.count(), 5);
  ClusterOptions six, all;
  all.connectivity = 26;
  EXPECT_EQ(find_pore_clusters(runs, six).size(), 5u);
  const auto c26 = find_pore_clusters(runs, all);
  ASSERT_EQ(c26.size(), 2u);
  EXPECT_EQ(c26[0].voxels, 3);
  EXPECT_TRUE(c26[0].spans(0));  // z 0 to 2
  EXPECT_TRUE(c26[0].spans(1));
  EXPECT_FALSE(c26[0].spans(2));
  EXPECT_EQ(c26[1].voxels, 2);
  ClusterOptions bad;
  bad.connectivity = 18;
  EXPECT_THROW(find_pore_clusters(runs, bad), ConfigError);
}

TEST(PoreStatistics, MatchBruteForceCounts) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Spacing spacing{2.0, 0.5, 1.25, "nm"};
    const Volume v = random_labels(Shape{13, 17, 19}, 0.4, 0.1, seed, spacing);
    const PoreStatistics stats = measure_pores(v);
    const Shape s = v.shape();
    const std::uint8_t* p = v.data<std::uint8_t>();
    std::array<std::int64_t, 5> counts{};
    std::array<std::array<std::int64_t, 5>, 3> faces{};
    std::array<std::vector<std::int64_t>, 3> pore, counted;
    const std::int64_t n[3] = {s.nz, s.ny, s.nx};
    for (int a = 0; a < 3; ++a) {
      pore[a].assign(std::size_t(n[a]), 0);
      counted[a].assign(std::size_t(n[a]), 0);
    }
    for (std::int64_t z = 0; z < s.nz; ++z)
      for (std::int64_t y = 0; y < s.ny; ++y)
        for (std::int64_t x = 0; x < s.nx; ++x) {
          const std::uint8_t c = p[(z * s.ny + y) * s.nx + x];
          ++counts[c];
          const std::int64_t idx[3] = {z, y, x};
          for (int a = 0; a < 3; ++a) {
            pore[a][std::size_t(idx[a])] += ref_pore(c);
            counted[a][std::size_t(idx[a])] += c != 0;
            std::int64_t w[3] = {z, y, x};
            if (++w[a] >= n[a]) continue;
            const std::uint8_t d = p[(w[0] * s.ny + w[1]) * s.nx + w[2]];
            if (ref_pore(c) && ref_solid(d)) ++faces[a][d];
            if (ref_solid(c) && ref_pore(d)) ++faces[a][c];
          }
        }
    for (int c = 0; c < 5; ++c) EXPECT_EQ(stats.counts.voxels[std::size_t(c)], counts[c]);
    EXPECT_EQ(stats.faces, faces);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(stats.slice_pore[a], pore[a]);
      EXPECT_EQ(stats.slice_counted[a], counted[a]);
    }
    // Areas: faces normal to z are dy*dx, to y dz*dx, to x dz*dy.
    const double area = double(faces[0][2] + faces[0][3]) * 0.5 * 1.25 +
                        double(faces[1][2] + faces[1][3]) * 2.0 * 1.25 +
                        double(faces[2][2] + faces[2][3]) * 2.0 * 0.5;
    EXPECT_DOUBLE_EQ(stats.interface_area(spacing), area);
    const double bulk = double(stats.counts.counted()) * 2.0 * 0.5 * 1.25;
    EXPECT_DOUBLE_EQ(stats.specific_surface_area(spacing), area / bulk);
    EXPECT_DOUBLE_EQ(stats.interface_area(spacing, Phase::kOrganic) +
                         stats.interface_area(spacing, Phase::kInorganic),
                     area);
  }
}

TEST(PoreStatistics, ACubicPoreHasSixFacesOfArea) {
  // A 2x3x4 pore box inside solid: 2*(2*3 + 2*4 + 3*4) = 52 faces.
  Volume v(Shape{6, 7, 8}, DType::kUInt8, Spacing{1, 1, 1, "um"});
  std::uint8_t* p = v.data<std::uint8_t>();
  std::fill_n(p, v.voxels(), std::uint8_t(3));
  for (int z = 2; z < 4; ++z)
    for (int y = 2; y < 5; ++y)
      for (int x = 2; x < 6; ++x) p[(z * 7 + y) * 8 + x] = 1;
  const PoreStatistics stats = measure_pores(v);
  EXPECT_EQ(stats.faces_normal_to(kAxisZ), 2 * 3 * 4);
  EXPECT_EQ(stats.faces_normal_to(kAxisY), 2 * 2 * 4);
  EXPECT_EQ(stats.faces_normal_to(kAxisX), 2 * 2 * 3);
  EXPECT_DOUBLE_EQ(stats.interface_area(v.spacing()), 52.0);
  EXPECT_DOUBLE_EQ(stats.porosity_profile(kAxisZ)[2], 12.0 / 56.0);
  EXPECT_DOUBLE_EQ(stats.porosity_profile(kAxisZ)[0], 0.0);
  const auto clusters = find_pore_clusters(find_pore_runs(v));
  ASSERT_EQ(clusters.size(), 1u);
  EXPECT_FALSE(clusters[0].touches_boundary());
  const PercolationSummary sum = summarize_clusters(clusters);
  EXPECT_EQ(sum.enclosed_clusters, 1);
  EXPECT_EQ(sum.enclosed_voxels, 24);
}

TEST(PoreStatistics, RefusesCodesThatAreNotPhases) {
  Volume v(Shape{2, 2, 2}, DType::kUInt8);
  std::fill_n(v.data<std::uint8_t>(), 8, std::uint8_t(1));
  v.data<std::uint8_t>()[5] = 9;
  EXPECT_THROW(measure_pores(v), ConfigError);
  Volume wide(Shape{2, 2, 2}, DType::kUInt16);
  EXPECT_THROW(measure_pores(wide), ConfigError);
  EXPECT_THROW(find_pore_runs(wide), ConfigError);
  EXPECT_EQ(parse_axis("y"), kAxisY);
  EXPECT_THROW(parse_axis("w"), ConfigError);
}

}  // namespace
}  // namespace mesorock::voxel::test
