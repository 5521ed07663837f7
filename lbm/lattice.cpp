#include "lbm/lattice.h"

#include <cmath>
#include <limits>
#include <sstream>

#include "lbm/d3q19.h"
#include "mesorock/errors.h"
#include "sim/memory_budget.h"

namespace mesorock::lbm {

void check_host_bytes(double count, double bytes_each, const std::string& what) {
  if (!(count >= 0) || !std::isfinite(count))
    throw LimitError("lbm: " + what + ": an impossible count");
  const double need = count * bytes_each;
  const sim::MemoryAvailable available = sim::host_memory_available();
  const std::string shortfall = sim::memory_shortfall(need, available, "host");
  if (!shortfall.empty()) throw LimitError("lbm: " + what + " " + shortfall);
  if (need > static_cast<double>(std::numeric_limits<std::size_t>::max() / 2))
    throw LimitError("lbm: " + what + ": " + sim::bytes_text(need) + " cannot be addressed");
}

namespace {

// Numbers the pore voxels in image order and fills the pull table. axis_coord receives each
// node's coordinate along `axis`.
Lattice build_lattice(const sim::SolidMask& mask, int axis, int threads,
                      std::vector<std::uint32_t>& axis_coord) {
  const std::int64_t nx = mask.dims[0], ny = mask.dims[1], nz = mask.dims[2];
  const std::int64_t voxels = mask.voxels();
  std::int64_t pores = 0;
  for (const std::uint8_t s : mask.solid) pores += s == 0;
  if (pores >= static_cast<std::int64_t>(kWall))
    throw LimitError("lbm: " + std::to_string(pores) +
                     " pore voxels; at most 2^32 - 2 are supported");
  // At the peak: the voxel-to-node map, and per node the link table twice (the percolating
  // part's copy), its voxel index twice, its axis coordinate and the component search's winding
  // and queue (8 + 4 + 4 bytes).
  check_host_bytes(static_cast<double>(voxels), sizeof(std::uint32_t), "the voxel-to-node map");
  check_host_bytes(static_cast<double>(pores), 2 * 18 * 4 + 2 * 8 + 4 + 16,
                   "the lattice of " + std::to_string(pores) + " pore nodes");
  std::vector<std::uint32_t> node_of(static_cast<std::size_t>(voxels), kWall);
  axis_coord.assign(static_cast<std::size_t>(pores), 0);
  Lattice lat;
  lat.nodes = pores;
  lat.voxel.resize(static_cast<std::size_t>(pores));
  std::uint32_t next = 0;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const std::size_t v = mask.index(i, j, k);
        if (mask.solid[v] != 0) continue;
        const std::int64_t c[3] = {i, j, k};
        axis_coord[next] = static_cast<std::uint32_t>(c[axis]);
        lat.voxel[next] = static_cast<std::int64_t>(v);
        node_of[v] = next++;
      }
  lat.source.assign(static_cast<std::size_t>(18 * pores), kWall);
  const auto wrap = [](std::int64_t a, std::int64_t n) { return ((a % n) + n) % n; };
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const std::uint32_t n = node_of[mask.index(i, j, k)];
        if (n == kWall) continue;
        for (int q = 1; q < kQ; ++q) {
          const std::size_t up =
              mask.index(wrap(i - kC[q][0], nx), wrap(j - kC[q][1], ny), wrap(k - kC[q][2], nz));
          lat.source[static_cast<std::size_t>(q - 1) * static_cast<std::size_t>(pores) + n] =
              node_of[up];
        }
      }
  return lat;
}

// Marks the nodes of components that percolate along the axis (see the header); returns how
// many there are.
std::int64_t find_percolating(const Lattice& lat, const std::vector<std::uint32_t>& axis_coord,
                              int axis, std::int64_t axis_length, std::vector<std::uint8_t>& keep) {
  const std::size_t N = static_cast<std::size_t>(lat.nodes);
  constexpr std::int64_t kUnseen = std::numeric_limits<std::int64_t>::min();
  std::vector<std::int64_t> winding(N, kUnseen);
  std::vector<std::uint32_t> queue;
  keep.assign(N, 0);
  std::int64_t kept = 0;
  for (std::size_t start = 0; start < N; ++start) {
    if (winding[start] != kUnseen) continue;
    bool percolates = false;
    queue.assign(1, static_cast<std::uint32_t>(start));
    winding[start] = 0;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const std::uint32_t n = queue[head];
      for (int q = 1; q < kQ; ++q) {
        const std::uint32_t m = lat.source[static_cast<std::size_t>(q - 1) * N + n];
        if (m == kWall) continue;
        // m sits at x - c_q; the step wraps when the axis coordinate leaves 0..axis_length-1.
        const std::int64_t a = static_cast<std::int64_t>(axis_coord[n]) - kC[q][axis];
        const std::int64_t w = winding[n] + (a < 0 ? -1 : (a >= axis_length ? 1 : 0));
        if (winding[m] == kUnseen) {
          winding[m] = w;
          queue.push_back(m);
        } else if (winding[m] != w) {
          percolates = true;
        }
      }
    }
    if (!percolates) continue;
    for (const std::uint32_t n : queue) keep[n] = 1;
    kept += static_cast<std::int64_t>(queue.size());
  }
  return kept;
}

// Renumbers the kept nodes (in their order) and rewrites the table. A link never joins a kept
// node to a dropped one: both would be in one component.
Lattice compact(const Lattice& lat, const std::vector<std::uint8_t>& keep, std::int64_t kept) {
  const std::size_t N = static_cast<std::size_t>(lat.nodes);
  std::vector<std::uint32_t> renumber(N, kWall);
  std::uint32_t next = 0;
  for (std::size_t n = 0; n < N; ++n)
    if (keep[n]) renumber[n] = next++;
  Lattice out;
  out.nodes = kept;
  const std::size_t K = static_cast<std::size_t>(kept);
  out.source.assign(18 * K, kWall);
  out.voxel.resize(K);
  for (std::size_t n = 0; n < N; ++n) {
    if (!keep[n]) continue;
    out.voxel[renumber[n]] = lat.voxel[n];
    for (std::size_t l = 0; l < 18; ++l) {
      const std::uint32_t m = lat.source[l * N + n];
      out.source[l * K + renumber[n]] = m == kWall ? kWall : renumber[m];
    }
  }
  return out;
}

}  // namespace

Lattice percolating_lattice(const sim::SolidMask& mask, int axis, int threads) {
  std::vector<std::uint32_t> axis_coord;
  Lattice all = build_lattice(mask, axis, threads, axis_coord);
  std::vector<std::uint8_t> keep;
  const std::int64_t kept = find_percolating(all, axis_coord, axis, mask.dims[axis], keep);
  if (kept == all.nodes) return all;
  return compact(all, keep, kept);
}

sim::SolidMask refine_mask(const sim::SolidMask& mask, int n) {
  mask.check("lbm: --refine");
  if (n < 1 || n > 8)
    throw ConfigError("lbm: --refine must be 1 to 8 (got " + std::to_string(n) + ")");
  sim::SolidMask r;
  double voxels = 1;
  for (int a = 0; a < 3; ++a) {
    r.dims[a] = mask.dims[a] * n;
    r.voxel[a] = mask.voxel[a] / n;
    voxels *= static_cast<double>(r.dims[a]);
  }
  if (voxels > std::ldexp(1.0, 33))
    throw LimitError("lbm: refining " + std::to_string(mask.voxels()) + " voxels by " +
                     std::to_string(n) + " per axis gives more than 2^33 voxels");
  check_host_bytes(voxels, 1, "the mask refined " + std::to_string(n) + " times per axis");
  r.origin = mask.origin;
  r.nm_per_rc = mask.nm_per_rc;
  r.solid.resize(static_cast<std::size_t>(r.voxels()));
  for (std::int64_t k = 0; k < r.dims[2]; ++k)
    for (std::int64_t j = 0; j < r.dims[1]; ++j)
      for (std::int64_t i = 0; i < r.dims[0]; ++i)
        r.solid[r.index(i, j, k)] = mask.solid[mask.index(i / n, j / n, k / n)];
  return r;
}

}  // namespace mesorock::lbm
