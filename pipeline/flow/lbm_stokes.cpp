#include "pipeline/flow/lbm_stokes.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <string>

#include "mesorock/errors.h"
#include "mesorock/version.h"

namespace mesorock::pipeline {

namespace {

// D3Q19: c_0 = 0, then nine velocities and, at q + 9, their opposites.
constexpr int kQ = 19;
constexpr int kHalf = 9;
constexpr int kC[kQ][3] = {{0, 0, 0},   {1, 0, 0},  {0, 1, 0},   {0, 0, 1},   {1, 1, 0},
                           {1, -1, 0},  {1, 0, 1},  {1, 0, -1},  {0, 1, 1},   {0, 1, -1},
                           {-1, 0, 0},  {0, -1, 0}, {0, 0, -1},  {-1, -1, 0}, {-1, 1, 0},
                           {-1, 0, -1}, {-1, 0, 1}, {0, -1, -1}, {0, -1, 1}};
// Weights: 1/3 at rest, 1/18 along the axes, 1/36 along the face diagonals.
constexpr double kW[kQ] = {1.0 / 3,  1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 36, 1.0 / 36, 1.0 / 36,
                           1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 36,
                           1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36};
// The collision writes the moments out for this order of kC: c_1..c_9 as listed, c_{q+9} = -c_q.
constexpr bool velocities_are_as_written() {
  constexpr int expected[kHalf + 1][3] = {{0, 0, 0},  {1, 0, 0}, {0, 1, 0},  {0, 0, 1}, {1, 1, 0},
                                          {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}};
  for (int q = 0; q <= kHalf; ++q)
    for (int a = 0; a < 3; ++a) {
      if (kC[q][a] != expected[q][a]) return false;
      if (q > 0 && kC[q + kHalf][a] != -expected[q][a]) return false;
    }
  return true;
}
static_assert(velocities_are_as_written(), "lbm_stokes.cpp: the collision assumes this kC");

constexpr int opposite(int q) {
  return q == 0 ? 0 : (q <= kHalf ? q + kHalf : q - kHalf);
}

constexpr double kMagicLambda = 3.0 / 16;
// A link whose upstream voxel is solid: the population bounces back at the halfway wall.
constexpr std::uint32_t kWall = std::numeric_limits<std::uint32_t>::max();
// Nodes per block of the velocity sums: fixed, so the sums do not depend on the thread count.
constexpr std::int64_t kBlock = 4096;

std::size_t physical_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page_size <= 0) return std::numeric_limits<std::size_t>::max();
  return static_cast<std::size_t>(pages) * static_cast<std::size_t>(page_size);
}

// count * bytes_each, refused (LimitError naming `what`) when it overflows or exceeds the
// machine's memory.
std::size_t checked_bytes(std::int64_t count, std::size_t bytes_each, const std::string& what) {
  const std::size_t limit = physical_memory_bytes();
  if (count < 0 || (count > 0 && static_cast<std::size_t>(count) > limit / bytes_each)) {
    std::ostringstream s;
    s << "lbm: " << what << ": " << count << " x " << bytes_each << " bytes, more than the "
      << limit << " bytes of memory here";
    throw LimitError(s.str());
  }
  return static_cast<std::size_t>(count) * bytes_each;
}

void check_inputs(const sim::SolidMask& mask, const LbmOptions& o) {
  if (o.axis < 0 || o.axis > 2)
    throw ConfigError("lbm: the flow axis must be 0, 1 or 2 (x, y, z), got " +
                      std::to_string(o.axis));
  if (!(o.tau > 0.5) || !std::isfinite(o.tau))
    throw ConfigError("lbm: tau must be finite and > 1/2 (viscosity (tau - 1/2) / 3), got " +
                      std::to_string(o.tau));
  if (!std::isfinite(o.force) || o.force == 0)
    throw ConfigError("lbm: the body force must be finite and not zero");
  if (!(o.tolerance >= 0) || !std::isfinite(o.tolerance))
    throw ConfigError("lbm: the tolerance must be finite and >= 0");
  if (o.check_every < 1) throw ConfigError("lbm: check_every must be at least 1");
  if (o.max_steps < 1) throw ConfigError("lbm: max_steps must be at least 1");
  if (o.threads < 0) throw ConfigError("lbm: threads must be >= 0 (0: OpenMP's default)");
  for (int d = 0; d < 3; ++d) {
    if (mask.dims[d] <= 0)
      throw ConfigError("lbm: the solid mask has a non-positive dimension along " +
                        std::string(1, "xyz"[d]));
    if (!(mask.voxel[d] > 0) || !std::isfinite(mask.voxel[d]))
      throw ConfigError("lbm: the solid mask's voxel edges must be positive and finite");
  }
  // The product of the dimensions must not overflow before it is compared with the bytes.
  constexpr std::int64_t kHuge = std::int64_t(1) << 62;
  if (mask.dims[0] > kHuge / mask.dims[1] || mask.dims[0] * mask.dims[1] > kHuge / mask.dims[2])
    throw LimitError("lbm: the solid mask's dimensions are absurdly large");
  if (mask.solid.size() != static_cast<std::size_t>(mask.voxels()))
    throw ConfigError("lbm: the solid mask holds " + std::to_string(mask.solid.size()) +
                      " bytes for " + std::to_string(mask.voxels()) + " voxels");
  const double edge = mask.voxel[0];
  for (int d = 1; d < 3; ++d) {
    if (std::abs(mask.voxel[d] - edge) > 1e-9 * edge) {
      std::ostringstream s;
      s.precision(17);
      s << "lbm: LBM needs cubic voxels (one lattice spacing), but the voxel edges are "
        << mask.voxel[0] << " x " << mask.voxel[1] << " x " << mask.voxel[2] << " rc";
      throw ConfigError(s.str());
    }
  }
}

// The pore nodes and their links, before and after dropping non-percolating components.
struct Lattice {
  std::int64_t nodes = 0;
  std::vector<std::uint32_t> source;  // [(q - 1) * nodes + n]: node at x - c_q, or kWall
};

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
  checked_bytes(voxels, sizeof(std::uint32_t), "the voxel-to-node map");
  // The most held per node at once: the two population arrays and two copies of the link table
  // while the run's copy is made (the component search needs less: the table and 21 bytes).
  checked_bytes(pores, 2 * kQ * sizeof(double) + 2 * 18 * sizeof(std::uint32_t),
                "the lattice of " + std::to_string(pores) + " pore nodes");
  std::vector<std::uint32_t> node_of(static_cast<std::size_t>(voxels), kWall);
  axis_coord.assign(static_cast<std::size_t>(pores), 0);
  std::uint32_t next = 0;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const std::size_t v = mask.index(i, j, k);
        if (mask.solid[v] != 0) continue;
        const std::int64_t c[3] = {i, j, k};
        axis_coord[next] = static_cast<std::uint32_t>(c[axis]);
        node_of[v] = next++;
      }
  Lattice lat;
  lat.nodes = pores;
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
  const std::int64_t n_nodes = lat.nodes;
  const std::size_t N = static_cast<std::size_t>(n_nodes);
  constexpr std::int64_t kUnseen = std::numeric_limits<std::int64_t>::min();
  std::vector<std::int64_t> winding(N, kUnseen);
  std::vector<std::uint32_t> queue;
  std::vector<std::uint32_t> members;
  keep.assign(N, 0);
  std::int64_t kept = 0;
  for (std::size_t start = 0; start < N; ++start) {
    if (winding[start] != kUnseen) continue;
    bool percolates = false;
    members.clear();
    queue.assign(1, static_cast<std::uint32_t>(start));
    winding[start] = 0;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const std::uint32_t n = queue[head];
      members.push_back(n);
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
    if (percolates) {
      for (const std::uint32_t n : members) keep[n] = 1;
      kept += static_cast<std::int64_t>(members.size());
    }
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
  for (std::size_t n = 0; n < N; ++n) {
    if (!keep[n]) continue;
    for (std::size_t l = 0; l < 18; ++l) {
      const std::uint32_t m = lat.source[l * N + n];
      out.source[l * K + renumber[n]] = m == kWall ? kWall : renumber[m];
    }
  }
  return out;
}

// Per-block sums of one measured step.
struct BlockSums {
  double u_axis = 0, rho = 0, u_max2 = 0;
};

// One step: for every node pull the populations (halfway bounce-back on wall links), take the
// moments, relax with TRT and write. `from` and `to` hold [q * N + n]. With Measure, the
// moments of the pulled populations (time t) are summed per block.
template <bool Measure>
void step(std::int64_t N, const std::uint32_t* src, const double* from, double* to, int axis,
          double force, double omega_plus, double omega_minus, int threads,
          std::vector<BlockSums>& sums) {
  const std::size_t SN = static_cast<std::size_t>(N);
  const std::int64_t blocks = (N + kBlock - 1) / kBlock;
  BlockSums* block_sums = Measure ? sums.data() : nullptr;
  // Guo's source (1 - omega-/2) 3 w_q c_q . F for q = 1..9, antisymmetric (q + 9 gets minus).
  double source[kHalf + 1] = {0};
  for (int q = 1; q <= kHalf; ++q)
    source[q] = (1 - 0.5 * omega_minus) * 3 * kW[q] * kC[q][axis] * force;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::int64_t b = 0; b < blocks; ++b) {
    const std::int64_t end = std::min(N, (b + 1) * kBlock);
    BlockSums s;
    for (std::int64_t n = b * kBlock; n < end; ++n) {
      const std::size_t sn = static_cast<std::size_t>(n);
      double f[kQ];
      f[0] = from[sn];
      for (int q = 1; q < kQ; ++q) {
        const std::uint32_t m = src[static_cast<std::size_t>(q - 1) * SN + sn];
        f[q] = m != kWall ? from[static_cast<std::size_t>(q) * SN + m]
                          : from[static_cast<std::size_t>(opposite(q)) * SN + sn];
      }
      // Moments through the pair differences d_q = f_q - f_{q+9} (c_{q+9} = -c_q), written out
      // for the velocities of kC (checked by velocities_are_as_written): the loops over kC are
      // not folded by the compiler and ran at half the speed.
      double d[kHalf + 1], rho = f[0];
      for (int q = 1; q <= kHalf; ++q) {
        d[q] = f[q] - f[q + kHalf];
        rho += f[q] + f[q + kHalf];
      }
      double j[3] = {d[1] + d[4] + d[5] + d[6] + d[7], d[2] + d[4] - d[5] + d[8] + d[9],
                     d[3] + d[6] - d[7] + d[8] - d[9]};
      j[axis] += 0.5 * force;
      if constexpr (Measure) {
        s.u_axis += j[axis];
        s.rho += rho;
        s.u_max2 = std::max(s.u_max2, j[0] * j[0] + j[1] * j[1] + j[2] * j[2]);
      }
      to[sn] = f[0] - omega_plus * (f[0] - kW[0] * rho);
      const double cj[kHalf + 1] = {0,           j[0],        j[1],        j[2],
                                    j[0] + j[1], j[0] - j[1], j[0] + j[2], j[0] - j[2],
                                    j[1] + j[2], j[1] - j[2]};  // c_q . j
      for (int q = 1; q <= kHalf; ++q) {
        const int p = q + kHalf;
        const double plus = 0.5 * (f[q] + f[p]), minus = 0.5 * d[q];
        const double new_plus = plus - omega_plus * (plus - kW[q] * rho);
        const double new_minus = minus - omega_minus * (minus - 3 * kW[q] * cj[q]) + source[q];
        to[static_cast<std::size_t>(q) * SN + sn] = new_plus + new_minus;
        to[static_cast<std::size_t>(p) * SN + sn] = new_plus - new_minus;
      }
    }
    if constexpr (Measure) block_sums[b] = s;
  }
}

}  // namespace

LbmResult lbm_permeability(const sim::SolidMask& mask, const LbmOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  check_inputs(mask, o);
  LbmResult r;
  const std::int64_t voxels = mask.voxels();
  for (const std::uint8_t s : mask.solid) r.pore_voxels += s == 0;
  if (r.pore_voxels == 0) throw ConfigError("lbm: the solid mask has no pore voxel");
  r.porosity = static_cast<double>(r.pore_voxels) / static_cast<double>(voxels);
  const double nu = (o.tau - 0.5) / 3;
  r.tau_minus = 0.5 + kMagicLambda / (o.tau - 0.5);
  const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
  const auto finish = [&]() {
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
  };

  Lattice lat;
  {
    std::vector<std::uint32_t> axis_coord;
    Lattice all = build_lattice(mask, o.axis, threads, axis_coord);
    std::vector<std::uint8_t> keep;
    const std::int64_t kept = find_percolating(all, axis_coord, o.axis, mask.dims[o.axis], keep);
    if (kept == 0) {
      r.percolates = false;
      r.converged = true;  // k = 0 is the exact Stokes answer: nothing to run
      r.mean_density = 1;
      return finish();
    }
    lat = kept == all.nodes ? std::move(all) : compact(all, keep, kept);
  }
  r.percolates = true;
  r.fluid_nodes = lat.nodes;

  const std::size_t N = static_cast<std::size_t>(lat.nodes);
  const std::int64_t blocks = (lat.nodes + kBlock - 1) / kBlock;
  checked_bytes(lat.nodes, 2 * kQ * sizeof(double),
                "the populations of " + std::to_string(lat.nodes) + " nodes");
  // The run's arrays, first touched (rest state, rho = 1) by the thread that updates each block
  // (step's static schedule), so that on a NUMA machine their pages sit beside that thread.
  std::unique_ptr<double[]> fa(new double[kQ * N]), fb(new double[kQ * N]);
  std::unique_ptr<std::uint32_t[]> source(new std::uint32_t[18 * N]);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::int64_t b = 0; b < blocks; ++b) {
    const std::size_t begin = static_cast<std::size_t>(b * kBlock);
    const std::size_t end = std::min(N, begin + static_cast<std::size_t>(kBlock));
    for (std::size_t q = 0; q < kQ; ++q)
      for (std::size_t n = begin; n < end; ++n) {
        fa[q * N + n] = kW[q];
        fb[q * N + n] = 0;
        if (q < 18) source[q * N + n] = lat.source[q * N + n];
      }
  }
  lat.source = std::vector<std::uint32_t>();
  const double omega_plus = 1 / o.tau, omega_minus = 1 / r.tau_minus;
  std::vector<BlockSums> sums(static_cast<std::size_t>(blocks));
  double* from = fa.get();
  double* to = fb.get();
  double q_prev = 0;
  for (std::int64_t s = 1; s <= o.max_steps; ++s) {
    const bool check = s % o.check_every == 0 || s == o.max_steps;
    if (check) {
      step<true>(lat.nodes, source.get(), from, to, o.axis, o.force, omega_plus, omega_minus,
                 threads, sums);
    } else {
      step<false>(lat.nodes, source.get(), from, to, o.axis, o.force, omega_plus, omega_minus,
                  threads, sums);
    }
    std::swap(from, to);
    r.steps = s;
    if (!check) continue;
    // Serial sum over the blocks in their order: the same doubles for any thread count.
    double u = 0, rho = 0, u_max2 = 0;
    for (const BlockSums& b : sums) {
      u += b.u_axis;
      rho += b.rho;
      u_max2 = std::max(u_max2, b.u_max2);
    }
    const double q = u / static_cast<double>(voxels);
    if (!std::isfinite(q) || !std::isfinite(rho))
      throw NumericalError("lbm: the mean velocity is not finite at step " + std::to_string(s));
    const double change = q != 0 ? std::abs(q - q_prev) / std::abs(q) : (q_prev == 0 ? 0.0 : 1.0);
    r.history.push_back({s, q, change});
    r.darcy_velocity = q;
    r.max_velocity = std::sqrt(u_max2);
    r.mean_density = rho / static_cast<double>(lat.nodes);
    q_prev = q;
    if (o.progress) o.progress(s, change);
    if (change < o.tolerance && r.history.size() > 1) {
      r.converged = true;
      break;
    }
  }
  r.k_voxel2 = nu * r.darcy_velocity / o.force;
  r.k_rc2 = r.k_voxel2 * mask.voxel[0] * mask.voxel[0];
  r.mean_pore_velocity = r.darcy_velocity / r.porosity;
  r.reynolds_estimate = std::abs(r.darcy_velocity) * std::sqrt(std::max(0.0, r.k_voxel2)) / nu;
  return finish();
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
  r.origin = mask.origin;
  r.nm_per_rc = mask.nm_per_rc;
  r.solid.resize(static_cast<std::size_t>(r.voxels()));
  for (std::int64_t k = 0; k < r.dims[2]; ++k)
    for (std::int64_t j = 0; j < r.dims[1]; ++j)
      for (std::int64_t i = 0; i < r.dims[0]; ++i)
        r.solid[r.index(i, j, k)] = mask.solid[mask.index(i / n, j / n, k / n)];
  return r;
}

nlohmann::json lbm_report_json(const std::string& input_file, const sim::SolidMask& mask,
                               const LbmOptions& o, const LbmResult& r) {
  nlohmann::json k = {{"voxel2", r.k_voxel2}, {"rc2", r.k_rc2}};
  if (mask.nm_per_rc > 0) {
    const double nm2 = r.k_rc2 * mask.nm_per_rc * mask.nm_per_rc;
    k["nm2"] = nm2;
    k["mD"] = nm2 / 986.9233;  // 1 mD = 9.869233e-16 m^2
  }
  nlohmann::json history = nlohmann::json::array();
  for (const LbmCheck& c : r.history)
    history.push_back(
        {{"step", c.step}, {"darcy_velocity", c.darcy_velocity}, {"rel_change", c.rel_change}});
  return {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"command", "rockflow lbm"},
      {"input_file", input_file},
      {"method",
       "D3Q19 TRT lattice Boltzmann, Lambda = 3/16, Stokes (linear) equilibrium, halfway "
       "bounce-back, periodic, uniform body force with Guo forcing; docs/lbm.md"},
      {"definitions",
       "lattice units (voxel = 1, dt = 1, rho0 = 1); nu = (tau - 1/2) / 3; q = sum of u_axis over "
       "the pore nodes / all voxels (Darcy velocity); k = nu q / force; k_rc2 = k voxel_rc^2; "
       "Re = q sqrt(k) / nu"},
      {"options",
       {{"axis", std::string(1, "xyz"[o.axis])},
        {"tau", o.tau},
        {"tau_minus", r.tau_minus},
        {"magic_lambda", kMagicLambda},
        {"viscosity", (o.tau - 0.5) / 3},
        {"force", o.force},
        {"tolerance", o.tolerance},
        {"check_every", o.check_every},
        {"max_steps", o.max_steps},
        {"threads", o.threads}}},
      {"mask",
       {{"dims", mask.dims},
        {"voxel_rc", mask.voxel},
        {"nm_per_rc", mask.nm_per_rc},
        {"pore_voxels", r.pore_voxels}}},
      {"result",
       {{"permeability", k},
        {"porosity", r.porosity},
        {"percolates", r.percolates},
        {"fluid_nodes", r.fluid_nodes},
        {"converged", r.converged},
        {"steps", r.steps},
        {"darcy_velocity", r.darcy_velocity},
        {"mean_pore_velocity", r.mean_pore_velocity},
        {"max_velocity", r.max_velocity},
        {"reynolds_estimate", r.reynolds_estimate},
        {"mean_density", r.mean_density},
        {"seconds", r.seconds}}},
      {"history", history}};
}

}  // namespace mesorock::pipeline
