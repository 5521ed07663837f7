#include "pipeline/flow/phase_connectivity.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "mesorock/errors.h"

namespace mesorock::pipeline {

namespace {

// Union-find over the phase's particles with the offset along the axis from each particle to its
// parent (unwrapped coordinates: x_parent = x_i + offset_i).
struct OffsetForest {
  std::vector<std::size_t> parent;
  std::vector<double> offset;
  explicit OffsetForest(std::size_t n) : parent(n), offset(n, 0.0) {
    for (std::size_t i = 0; i < n; ++i) parent[i] = i;
  }
  // The root of i, and i's offset to it (path compression keeps the offsets to the root).
  std::size_t find(std::size_t i, double& to_root) {
    double sum = 0;
    std::size_t r = i;
    while (parent[r] != r) {
      sum += offset[r];
      r = parent[r];
    }
    // Compress: every node on the path points at the root with its full offset.
    double rest = sum;
    for (std::size_t k = i; parent[k] != k;) {
      const std::size_t next = parent[k];
      const double own = offset[k];
      parent[k] = r;
      offset[k] = rest;
      rest -= own;
      k = next;
    }
    to_root = sum;
    return r;
  }
};

}  // namespace

PhaseConnectivity phase_connectivity(const sim::ParticleSet& p, int type, const sim::BoxSpec& box,
                                     int axis, double cutoff) {
  if (axis < 0 || axis > 2) throw ConfigError("phase connectivity: the axis must be 0, 1 or 2");
  if (!(cutoff > 0)) throw ConfigError("phase connectivity: the cutoff must be positive");
  std::vector<std::array<double, 3>> r;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == type) r.push_back({p.x[i], p.y[i], p.z[i]});
  PhaseConnectivity c;
  c.particles = r.size();
  if (r.empty()) return c;
  // Cells of at least the cutoff; positions folded into the box.
  std::array<int, 3> n{};
  std::array<double, 3> L{}, cell{};
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<size_t>(a);
    L[k] = box.length(a);
    n[k] = std::max(1, static_cast<int>(std::floor(L[k] / cutoff)));
    cell[k] = L[k] / n[k];
  }
  auto cell_of = [&](const std::array<double, 3>& q, int a) {
    const auto k = static_cast<size_t>(a);
    double u = q[k] - box.lo[k];
    if (box.periodic[k]) u -= L[k] * std::floor(u / L[k]);
    return std::clamp(static_cast<int>(u / cell[k]), 0, n[k] - 1);
  };
  const std::size_t cells = static_cast<std::size_t>(n[0]) * n[1] * n[2];
  std::vector<std::vector<std::size_t>> members(cells);
  std::vector<std::array<int, 3>> at(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    at[i] = {cell_of(r[i], 0), cell_of(r[i], 1), cell_of(r[i], 2)};
    members[(static_cast<std::size_t>(at[i][2]) * n[1] + at[i][1]) * n[0] + at[i][0]].push_back(i);
  }
  OffsetForest forest(r.size());
  const double c2 = cutoff * cutoff;
  const auto A = static_cast<size_t>(axis);
  std::vector<bool> wraps(r.size(), false);  // by root
  std::vector<std::size_t> seen;
  for (std::size_t i = 0; i < r.size(); ++i) {
    seen.clear();
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int d[3] = {dx, dy, dz};
          std::array<int, 3> q{};
          bool inside = true;
          for (int a = 0; a < 3; ++a) {
            const auto k = static_cast<size_t>(a);
            q[k] = at[i][k] + d[a];
            if (q[k] < 0 || q[k] >= n[k]) {
              if (!box.periodic[k]) inside = false;
              q[k] = (q[k] + n[k]) % n[k];
            }
          }
          if (!inside) continue;
          const std::size_t ci = (static_cast<std::size_t>(q[2]) * n[1] + q[1]) * n[0] + q[0];
          if (std::find(seen.begin(), seen.end(), ci) != seen.end()) continue;  // few cells
          seen.push_back(ci);
          for (std::size_t j : members[ci]) {
            if (j <= i) continue;
            double dr[3], d2 = 0;
            for (int a = 0; a < 3; ++a) {
              const auto k = static_cast<size_t>(a);
              dr[a] = r[j][k] - r[i][k];
              if (box.periodic[k]) dr[a] -= L[k] * std::round(dr[a] / L[k]);
              d2 += dr[a] * dr[a];
            }
            if (d2 >= c2) continue;
            // x_j = x_i + dr along the axis (unwrapped).
            double oi = 0, oj = 0;
            const std::size_t ri = forest.find(i, oi), rj = forest.find(j, oj);
            if (ri == rj) {
              // Root position seen from i and from j: x_i + oi and x_j + oj = x_i + dr + oj.
              if (std::abs(oi - (dr[axis] + oj)) > 0.5 * L[A]) wraps[ri] = true;
            } else {
              // Hang rj under ri: x_ri = x_i + oi, x_rj = x_j + oj = x_i + dr + oj.
              forest.parent[rj] = ri;
              forest.offset[rj] = oi - (dr[axis] + oj);
              if (wraps[rj]) wraps[ri] = true;
            }
          }
        }
  }
  // Cluster sizes, wrapping, and (bounded axis) the faces each cluster touches.
  std::vector<std::size_t> size(r.size(), 0);
  std::vector<char> near_lo(r.size(), 0), near_hi(r.size(), 0);
  for (std::size_t i = 0; i < r.size(); ++i) {
    double o = 0;
    const std::size_t root = forest.find(i, o);
    ++size[root];
    if (!box.periodic[A]) {
      if (r[i][A] - box.lo[A] < cutoff) near_lo[root] = 1;
      if (box.hi[A] - r[i][A] < cutoff) near_hi[root] = 1;
    }
  }
  std::size_t spanning = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (size[i] == 0) continue;
    ++c.clusters;
    c.largest = std::max(c.largest, size[i]);
    const bool spans = box.periodic[A] ? static_cast<bool>(wraps[i]) : near_lo[i] && near_hi[i];
    if (spans) spanning += size[i];
  }
  c.spans = spanning > 0;
  c.spanning_fraction = static_cast<double>(spanning) / static_cast<double>(r.size());
  return c;
}

}  // namespace mesorock::pipeline
