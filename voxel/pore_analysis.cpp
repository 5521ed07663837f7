#include "voxel/pore_analysis.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>
#include <mutex>
#include <numeric>
#include <string>

#include "mesorock/errors.h"

namespace mesorock::voxel {
namespace {

const std::uint8_t* checked_codes(const Volume& labels) {
  if (labels.dtype() != DType::kUInt8) {
    throw ConfigError(std::string("pore analysis needs a uint8 phase-label volume, not ") +
                      dtype_name(labels.dtype()));
  }
  return labels.data<std::uint8_t>();
}

std::string bad_code_message(unsigned code) {
  return "label volume holds value " + std::to_string(code) +
         ", not a phase code (0 outside, 1 pore, 2 organic, 3 inorganic, 4 organic_pore)";
}

}  // namespace

const char* axis_name(int axis) {
  switch (axis) {
    case kAxisZ:
      return "z";
    case kAxisY:
      return "y";
    case kAxisX:
      return "x";
  }
  return "?";
}

int parse_axis(const std::string& name) {
  if (name == "z") return kAxisZ;
  if (name == "y") return kAxisY;
  if (name == "x") return kAxisX;
  throw ConfigError("unknown axis '" + name + "' (expected z, y or x)");
}

// ---------------------------------------------------------------------------------------------
// PoreStatistics

std::int64_t PoreStatistics::pore_voxels() const {
  return counts.voxels[static_cast<std::size_t>(Phase::kPore)] +
         counts.voxels[static_cast<std::size_t>(Phase::kOrganicPore)];
}

std::int64_t PoreStatistics::faces_normal_to(int axis) const {
  const auto& f = faces[static_cast<std::size_t>(axis)];
  return std::accumulate(f.begin(), f.end(), std::int64_t(0));
}

namespace {
// Area of one voxel face normal to `axis`.
double face_area(const Spacing& s, int axis) {
  switch (axis) {
    case kAxisZ:
      return s.dy * s.dx;
    case kAxisY:
      return s.dz * s.dx;
    default:
      return s.dz * s.dy;
  }
}
}  // namespace

double PoreStatistics::interface_area(const Spacing& spacing) const {
  double area = 0;
  for (int a = 0; a < 3; ++a) area += double(faces_normal_to(a)) * face_area(spacing, a);
  return area;
}

double PoreStatistics::interface_area(const Spacing& spacing, Phase solid) const {
  double area = 0;
  for (int a = 0; a < 3; ++a) {
    area += double(faces[static_cast<std::size_t>(a)][static_cast<std::size_t>(solid)]) *
            face_area(spacing, a);
  }
  return area;
}

double PoreStatistics::specific_surface_area(const Spacing& spacing) const {
  const double bulk = double(counts.counted()) * spacing.dz * spacing.dy * spacing.dx;
  return bulk > 0 ? interface_area(spacing) / bulk : 0.0;
}

std::vector<double> PoreStatistics::porosity_profile(int axis) const {
  const auto& pore = slice_pore[static_cast<std::size_t>(axis)];
  const auto& counted = slice_counted[static_cast<std::size_t>(axis)];
  std::vector<double> p(pore.size(), 0.0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (counted[i] > 0) p[i] = double(pore[i]) / double(counted[i]);
  }
  return p;
}

PoreStatistics measure_pores(const Volume& labels) {
  const std::uint8_t* v = checked_codes(labels);
  const Shape s = labels.shape();
  PoreStatistics stats;
  stats.shape = s;
  const std::int64_t extent[3] = {s.nz, s.ny, s.nx};
  for (int a = 0; a < 3; ++a) {
    stats.slice_pore[static_cast<std::size_t>(a)].assign(static_cast<std::size_t>(extent[a]), 0);
    stats.slice_counted[static_cast<std::size_t>(a)].assign(static_cast<std::size_t>(extent[a]), 0);
  }
  std::mutex merge;
  std::string error;
  // Each task takes a block of z slices and accumulates everything locally; integer sums, so the
  // merge order does not matter.
  tbb::parallel_for(
      tbb::blocked_range<std::int64_t>(0, s.nz, 4),
      [&](const tbb::blocked_range<std::int64_t>& range) {
        std::array<std::int64_t, 256> counts{};
        std::array<std::array<std::int64_t, kPhaseCount>, 3> faces{};
        std::vector<std::int64_t> y_pore(static_cast<std::size_t>(s.ny), 0),
            y_counted(static_cast<std::size_t>(s.ny), 0), x_pore(static_cast<std::size_t>(s.nx), 0),
            x_counted(static_cast<std::size_t>(s.nx), 0);
        std::vector<std::pair<std::int64_t, std::int64_t>> z_rows;
        for (std::int64_t z = range.begin(); z < range.end(); ++z) {
          std::int64_t z_pore = 0, z_counted = 0;
          for (std::int64_t y = 0; y < s.ny; ++y) {
            const std::uint8_t* row = v + (z * s.ny + y) * s.nx;
            const std::uint8_t* below_y = y + 1 < s.ny ? row + s.nx : nullptr;
            const std::uint8_t* below_z = z + 1 < s.nz ? row + s.ny * s.nx : nullptr;
            std::int64_t row_pore = 0, row_counted = 0;
            for (std::int64_t x = 0; x < s.nx; ++x) {
              const std::uint8_t c = row[x];
              ++counts[c];
              const bool pore = is_pore_code(c), solid = is_solid_code(c);
              const bool counted = c != 0;
              row_pore += pore;
              row_counted += counted;
              x_pore[static_cast<std::size_t>(x)] += pore;
              x_counted[static_cast<std::size_t>(x)] += counted;
              if (!pore && !solid) continue;
              // The faces towards +x, +y, +z.
              auto face = [&](int axis, std::uint8_t d) {
                if (pore && is_solid_code(d)) {
                  ++faces[static_cast<std::size_t>(axis)][d];
                } else if (solid && is_pore_code(d)) {
                  ++faces[static_cast<std::size_t>(axis)][c];
                }
              };
              if (x + 1 < s.nx) face(kAxisX, row[x + 1]);
              if (below_y) face(kAxisY, below_y[x]);
              if (below_z) face(kAxisZ, below_z[x]);
            }
            y_pore[static_cast<std::size_t>(y)] += row_pore;
            y_counted[static_cast<std::size_t>(y)] += row_counted;
            z_pore += row_pore;
            z_counted += row_counted;
          }
          z_rows.emplace_back(z_pore, z_counted);
        }
        std::lock_guard<std::mutex> lock(merge);
        for (unsigned c = kPhaseCount; c < 256; ++c) {
          if (counts[c] && error.empty()) error = bad_code_message(c);
        }
        for (int c = 0; c < kPhaseCount; ++c) {
          stats.counts.voxels[static_cast<std::size_t>(c)] += counts[static_cast<std::size_t>(c)];
        }
        for (int a = 0; a < 3; ++a) {
          for (int c = 0; c < kPhaseCount; ++c) {
            stats.faces[static_cast<std::size_t>(a)][static_cast<std::size_t>(c)] +=
                faces[static_cast<std::size_t>(a)][static_cast<std::size_t>(c)];
          }
        }
        for (std::int64_t z = range.begin(); z < range.end(); ++z) {
          const auto& zr = z_rows[static_cast<std::size_t>(z - range.begin())];
          stats.slice_pore[0][static_cast<std::size_t>(z)] = zr.first;
          stats.slice_counted[0][static_cast<std::size_t>(z)] = zr.second;
        }
        for (std::size_t y = 0; y < y_pore.size(); ++y) {
          stats.slice_pore[1][y] += y_pore[y];
          stats.slice_counted[1][y] += y_counted[y];
        }
        for (std::size_t x = 0; x < x_pore.size(); ++x) {
          stats.slice_pore[2][x] += x_pore[x];
          stats.slice_counted[2][x] += x_counted[x];
        }
      });
  if (!error.empty()) throw ConfigError(error);
  return stats;
}

// ---------------------------------------------------------------------------------------------
// Runs and clusters

std::size_t PoreRuns::bytes() const {
  return row_begin.capacity() * sizeof(std::int64_t) +
         (x_begin.capacity() + x_end.capacity()) * sizeof(std::int32_t);
}

PoreRuns find_pore_runs(const Volume& labels) {
  const std::uint8_t* v = checked_codes(labels);
  const Shape s = labels.shape();
  if (s.nx > std::numeric_limits<std::int32_t>::max() - 1) {
    throw LimitError("rows longer than 2^31 voxels are not supported");
  }
  PoreRuns runs;
  runs.shape = s;
  const std::int64_t rows = s.nz * s.ny;
  runs.row_begin.assign(static_cast<std::size_t>(rows + 1), 0);
  // Pass 1: runs per row; pass 2 (after the prefix sum): the runs themselves.
  tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, rows, 256),
                    [&](const tbb::blocked_range<std::int64_t>& range) {
                      for (std::int64_t r = range.begin(); r < range.end(); ++r) {
                        const std::uint8_t* row = v + r * s.nx;
                        std::int64_t n = 0;
                        bool inside = false;
                        for (std::int64_t x = 0; x < s.nx; ++x) {
                          const bool pore = is_pore_code(row[x]);
                          n += pore && !inside;
                          inside = pore;
                        }
                        runs.row_begin[static_cast<std::size_t>(r + 1)] = n;
                      }
                    });
  for (std::int64_t r = 0; r < rows; ++r) {
    runs.row_begin[static_cast<std::size_t>(r + 1)] += runs.row_begin[static_cast<std::size_t>(r)];
  }
  const std::int64_t total = runs.row_begin.back();
  if (total >= std::int64_t(std::numeric_limits<std::uint32_t>::max())) {
    throw LimitError(
        "more than 2^32 pore runs: the volume is too large or too fragmented for "
        "cluster labelling");
  }
  runs.x_begin.resize(static_cast<std::size_t>(total));
  runs.x_end.resize(static_cast<std::size_t>(total));
  tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, rows, 256),
                    [&](const tbb::blocked_range<std::int64_t>& range) {
                      for (std::int64_t r = range.begin(); r < range.end(); ++r) {
                        const std::uint8_t* row = v + r * s.nx;
                        std::size_t k =
                            static_cast<std::size_t>(runs.row_begin[static_cast<std::size_t>(r)]);
                        std::int64_t x = 0;
                        while (x < s.nx) {
                          while (x < s.nx && !is_pore_code(row[x])) ++x;
                          if (x == s.nx) break;
                          const std::int64_t start = x;
                          while (x < s.nx && is_pore_code(row[x])) ++x;
                          runs.x_begin[k] = static_cast<std::int32_t>(start);
                          runs.x_end[k] = static_cast<std::int32_t>(x);
                          ++k;
                        }
                      }
                    });
  return runs;
}

namespace {

// Union-find over run indices. The root of a tree is always its smallest index (a link goes
// from the larger root to the smaller), so parent[i] <= i: this makes the final relabelling a
// single forward pass, and the cluster order the order of first voxels.
class RunForest {
 public:
  explicit RunForest(std::size_t n) : parent_(n) {
    std::iota(parent_.begin(), parent_.end(), std::uint32_t(0));
  }
  std::uint32_t find(std::uint32_t a) {
    while (parent_[a] != a) {
      parent_[a] = parent_[parent_[a]];  // path halving
      a = parent_[a];
    }
    return a;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) {
      parent_[b] = a;
    } else {
      parent_[a] = b;
    }
  }
  std::vector<std::uint32_t>& parent() { return parent_; }

 private:
  std::vector<std::uint32_t> parent_;
};

// Joins the runs of row `a` with the touching runs of row `b`. `reach` is 0 for runs that must
// share an x (face neighbours) and 1 for runs that may also meet at an edge or a corner.
void join_rows(const PoreRuns& runs, std::int64_t a, std::int64_t b, int reach, RunForest& forest) {
  std::int64_t i = runs.row_begin[static_cast<std::size_t>(a)];
  const std::int64_t i_end = runs.row_begin[static_cast<std::size_t>(a + 1)];
  std::int64_t j = runs.row_begin[static_cast<std::size_t>(b)];
  const std::int64_t j_end = runs.row_begin[static_cast<std::size_t>(b + 1)];
  while (i < i_end && j < j_end) {
    const auto ui = static_cast<std::size_t>(i), uj = static_cast<std::size_t>(j);
    // [b0, b1) and [c0, c1) touch when b0 < c1 + reach and c0 < b1 + reach.
    if (runs.x_begin[ui] < runs.x_end[uj] + reach && runs.x_begin[uj] < runs.x_end[ui] + reach) {
      forest.unite(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
    }
    if (runs.x_end[ui] < runs.x_end[uj]) {
      ++i;
    } else {
      ++j;
    }
  }
}

// Joins every run of row (z, y) with its neighbours in the rows before it: (z, y-1) and
// (z-1, y) for 6-connectivity, and also (z-1, y-1), (z-1, y+1) for 26, with `reach` 1. Rows
// before z_min are left out (they belong to another task).
void join_row(const PoreRuns& runs, std::int64_t z, std::int64_t y, std::int64_t z_min,
              bool all_neighbours, RunForest& forest) {
  const Shape& s = runs.shape;
  const std::int64_t row = z * s.ny + y;
  const int reach = all_neighbours ? 1 : 0;
  if (y > 0) join_rows(runs, row, row - 1, reach, forest);
  if (z > z_min) {
    join_rows(runs, row, row - s.ny, reach, forest);
    if (all_neighbours) {
      if (y > 0) join_rows(runs, row, row - s.ny - 1, reach, forest);
      if (y + 1 < s.ny) join_rows(runs, row, row - s.ny + 1, reach, forest);
    }
  }
}

}  // namespace

std::vector<Cluster> find_pore_clusters(const PoreRuns& runs, const ClusterOptions& options) {
  std::vector<Cluster> clusters;
  label_pore_runs(runs, options, &clusters);
  return clusters;
}

std::vector<std::uint32_t> label_pore_runs(const PoreRuns& runs, const ClusterOptions& options,
                                           std::vector<Cluster>* clusters_out) {
  if (options.connectivity != 6 && options.connectivity != 26) {
    throw ConfigError("connectivity must be 6 or 26, not " + std::to_string(options.connectivity));
  }
  const bool all = options.connectivity == 26;
  const Shape& s = runs.shape;
  const std::size_t n = static_cast<std::size_t>(runs.count());
  RunForest forest(n);
  // Slabs of z are joined in parallel: a slab's unions only touch its own runs (indices are in
  // row order), so the trees of different slabs never share a node. The slab boundaries are
  // joined afterwards, serially.
  const std::int64_t slab = std::max<std::int64_t>(8, (s.nz + 15) / 16);
  const std::int64_t slabs = (s.nz + slab - 1) / slab;
  tbb::parallel_for(std::int64_t(0), slabs, [&](std::int64_t k) {
    const std::int64_t z0 = k * slab, z1 = std::min(s.nz, z0 + slab);
    for (std::int64_t z = z0; z < z1; ++z) {
      for (std::int64_t y = 0; y < s.ny; ++y) join_row(runs, z, y, z0, all, forest);
    }
  });
  for (std::int64_t k = 1; k < slabs; ++k) {
    const std::int64_t z = k * slab;
    for (std::int64_t y = 0; y < s.ny; ++y) {
      const std::int64_t row = z * s.ny + y;
      const int reach = all ? 1 : 0;
      join_rows(runs, row, row - s.ny, reach, forest);
      if (all) {
        if (y > 0) join_rows(runs, row, row - s.ny - 1, reach, forest);
        if (y + 1 < s.ny) join_rows(runs, row, row - s.ny + 1, reach, forest);
      }
    }
  }
  // Relabel in place: slot i becomes the cluster id of run i. A root gets the next id; any other
  // run copies the id already stored in its parent's slot (parent < i, already relabelled).
  std::vector<std::uint32_t>& id = forest.parent();
  std::uint32_t clusters = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t p = id[i];
    id[i] = p == i ? clusters++ : id[p];
  }
  std::vector<Cluster> out(clusters);
  std::vector<bool> seen(clusters, false);
  const std::int32_t last[3] = {static_cast<std::int32_t>(s.nz - 1),
                                static_cast<std::int32_t>(s.ny - 1),
                                static_cast<std::int32_t>(s.nx)};
  for (std::int64_t z = 0; z < s.nz; ++z) {
    for (std::int64_t y = 0; y < s.ny; ++y) {
      const std::int64_t row = z * s.ny + y;
      for (std::int64_t r = runs.row_begin[static_cast<std::size_t>(row)];
           r < runs.row_begin[static_cast<std::size_t>(row + 1)]; ++r) {
        const auto ur = static_cast<std::size_t>(r);
        Cluster& c = out[id[ur]];
        const std::int32_t x0 = runs.x_begin[ur], x1 = runs.x_end[ur];
        const std::array<std::int32_t, 3> lo = {static_cast<std::int32_t>(z),
                                                static_cast<std::int32_t>(y), x0};
        const std::array<std::int32_t, 3> hi = {static_cast<std::int32_t>(z),
                                                static_cast<std::int32_t>(y), x1 - 1};
        if (!seen[id[ur]]) {
          seen[id[ur]] = true;
          c.lo = lo;
          c.hi = hi;
        } else {
          for (int a = 0; a < 3; ++a) {
            c.lo[static_cast<std::size_t>(a)] =
                std::min(c.lo[static_cast<std::size_t>(a)], lo[static_cast<std::size_t>(a)]);
            c.hi[static_cast<std::size_t>(a)] =
                std::max(c.hi[static_cast<std::size_t>(a)], hi[static_cast<std::size_t>(a)]);
          }
        }
        c.voxels += x1 - x0;
        if (z == 0) c.faces |= 1u << 0;
        if (z == last[0]) c.faces |= 1u << 1;
        if (y == 0) c.faces |= 1u << 2;
        if (y == last[1]) c.faces |= 1u << 3;
        if (x0 == 0) c.faces |= 1u << 4;
        if (x1 == last[2]) c.faces |= 1u << 5;
      }
    }
  }
  if (clusters_out) *clusters_out = std::move(out);
  return std::move(id);
}

PercolationSummary summarize_clusters(const std::vector<Cluster>& clusters, std::size_t largest) {
  PercolationSummary sum;
  sum.clusters = static_cast<std::int64_t>(clusters.size());
  std::vector<std::size_t> isolated;
  for (std::size_t i = 0; i < clusters.size(); ++i) {
    const Cluster& c = clusters[i];
    for (int a = 0; a < 3; ++a) {
      if (c.spans(a)) {
        ++sum.spanning_clusters[static_cast<std::size_t>(a)];
        sum.spanning_voxels[static_cast<std::size_t>(a)] += c.voxels;
      }
    }
    if (c.percolates()) {
      sum.percolating_voxels += c.voxels;
    } else {
      ++sum.isolated_clusters;
      sum.isolated_voxels += c.voxels;
      isolated.push_back(i);
      if (!c.touches_boundary()) {
        ++sum.enclosed_clusters;
        sum.enclosed_voxels += c.voxels;
      }
    }
  }
  // Biggest first; ties in the order of first voxels (deterministic).
  const std::size_t keep = std::min(largest, isolated.size());
  std::partial_sort(isolated.begin(), isolated.begin() + static_cast<std::ptrdiff_t>(keep),
                    isolated.end(), [&](std::size_t a, std::size_t b) {
                      return clusters[a].voxels != clusters[b].voxels
                                 ? clusters[a].voxels > clusters[b].voxels
                                 : a < b;
                    });
  for (std::size_t k = 0; k < keep; ++k) sum.largest_isolated.push_back(clusters[isolated[k]]);
  return sum;
}

}  // namespace mesorock::voxel
