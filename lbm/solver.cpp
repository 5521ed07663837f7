#include "lbm/solver.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <string>

#include "lbm/lattice.h"
#include "lbm/steps.h"
#include "mesorock/errors.h"
#include "sim/memory_budget.h"
#include "sim/simulation.h"

namespace mesorock::lbm {

const char* to_string(Backend b) {
  return b == Backend::CUDA ? "cuda" : "cpu";
}
const char* to_string(Precision p) {
  return p == Precision::Single ? "single" : "double";
}

double bytes_per_node(Precision p) {
  const double real = p == Precision::Single ? 4 : 8;
  return 2 * kQ * real + 18 * 4;
}

// The solver's own answer (sim/simulation.h): one device query for both solvers.
std::string cuda_unavailable_reason() {
  return sim::cuda_unavailable_reason();
}

namespace {

// Nodes per block of the CPU's velocity sums: fixed, so the sums do not depend on the thread
// count.
constexpr std::int64_t kBlock = 4096;

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
  if (o.initial.field != nullptr && !(o.initial.ratio >= 1))
    throw ConfigError("lbm: a lattice starts only from a coarser one");
}

// The CPU backend: OpenMP over fixed blocks of nodes, each block's sums in double, added in
// block order.
template <class Real>
class CpuRunner final : public StepRunner<Real> {
 public:
  CpuRunner(std::vector<std::uint32_t>&& source, std::vector<Real>&& initial,
            const StepParams<Real>& p, int threads)
      : p_(p),
        threads_(threads),
        blocks_((static_cast<std::int64_t>(p.nodes) + kBlock - 1) / kBlock),
        src_(std::move(source)),
        from_(std::move(initial)),
        to_(from_.size()),
        sums_(static_cast<std::size_t>(blocks_)) {}

  void run(std::int64_t count, bool measure, int axis, StepSums& sums) override {
    for (std::int64_t s = 0; s < count; ++s) {
      if (measure && s == count - 1)
        step<true>(axis);
      else
        step<false>(axis);
      from_.swap(to_);
    }
    if (!measure) return;
    sums = StepSums{};
    for (const StepSums& b : sums_) {
      sums.u_axis += b.u_axis;
      sums.drho += b.drho;
      sums.u2_max = std::max(sums.u2_max, b.u2_max);
    }
  }

  void moments(std::vector<float>& drho, std::vector<float>& jx, std::vector<float>& jy,
               std::vector<float>& jz) override {
    const std::size_t N = p_.nodes;
    drho.resize(N);
    jx.resize(N);
    jy.resize(N);
    jz.resize(N);
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (std::int64_t n = 0; n < static_cast<std::int64_t>(N); ++n) {
      const NodeMoments<Real> m = node_moments(static_cast<std::uint64_t>(n), from_.data(), p_);
      drho[n] = static_cast<float>(m.drho);
      jx[n] = static_cast<float>(m.j[0]);
      jy[n] = static_cast<float>(m.j[1]);
      jz[n] = static_cast<float>(m.j[2]);
    }
  }

 private:
  template <bool Measure>
  void step(int axis) {
    const std::int64_t N = static_cast<std::int64_t>(p_.nodes);
    const std::uint32_t* src = src_.data();
    const Real* from = from_.data();
    Real* to = to_.data();
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (std::int64_t b = 0; b < blocks_; ++b) {
      const std::int64_t end = std::min(N, (b + 1) * kBlock);
      StepSums s;
      for (std::int64_t n = b * kBlock; n < end; ++n) {
        const NodeMoments<Real> m = update_node(static_cast<std::uint64_t>(n), src, from, to, p_);
        if constexpr (Measure) {
          s.u_axis += static_cast<double>(m.j[axis]);
          s.drho += static_cast<double>(m.drho);
          s.u2_max = std::max(s.u2_max, static_cast<double>(m.j[0]) * m.j[0] +
                                            static_cast<double>(m.j[1]) * m.j[1] +
                                            static_cast<double>(m.j[2]) * m.j[2]);
        }
      }
      if constexpr (Measure) sums_[static_cast<std::size_t>(b)] = s;
    }
  }

  StepParams<Real> p_;
  int threads_;
  std::int64_t blocks_;
  std::vector<std::uint32_t> src_;
  std::vector<Real> from_, to_;
  std::vector<StepSums> sums_;
};

// The populations a lattice starts with: rest (zero deviations), or the equilibrium of the
// coarser flow's moments (InitialFlow in solver.h).
template <class Real>
std::vector<Real> initial_populations(const Lattice& lat, const sim::SolidMask& mask,
                                      const LbmOptions& o, double nu) {
  const std::size_t N = static_cast<std::size_t>(lat.nodes);
  std::vector<Real> g(kQ * N, Real(0));
  const FlowField* field = o.initial.field;
  if (field == nullptr) return g;
  const double ratio = o.initial.ratio;
  const double u_scale = ratio * ratio * (field->nu / nu) * (o.force / field->force);
  const double rho_scale = ratio * (o.force / field->force);
  const std::int64_t nx = mask.dims[0], ny = mask.dims[1];
  const auto coarse = [&](std::int64_t i, int a) {
    return std::min(field->dims[a] - 1,
                    static_cast<std::int64_t>((static_cast<double>(i) + 0.5) / ratio));
  };
#pragma omp parallel for schedule(static) num_threads(o.threads)
  for (std::int64_t n = 0; n < static_cast<std::int64_t>(N); ++n) {
    const std::int64_t v = lat.voxel[static_cast<std::size_t>(n)];
    const std::int64_t i = v % nx, j = (v / nx) % ny, k = v / (nx * ny);
    const std::int64_t ci = coarse(i, 0), cj = coarse(j, 1), ck = coarse(k, 2);
    const std::uint32_t m =
        field->node_of[static_cast<std::size_t>((ck * field->dims[1] + cj) * field->dims[0] + ci)];
    if (m == kWall) continue;
    const double drho = rho_scale * field->drho[m];
    const double j3[3] = {u_scale * field->jx[m], u_scale * field->jy[m], u_scale * field->jz[m]};
    for (int q = 0; q < kQ; ++q) {
      const double cj3 = kC[q][0] * j3[0] + kC[q][1] * j3[1] + kC[q][2] * j3[2];
      g[static_cast<std::size_t>(q) * N + static_cast<std::size_t>(n)] =
          static_cast<Real>(weight(q) * (drho + 3 * cj3));
    }
  }
  return g;
}

template <class Real>
StepParams<Real> step_params(std::int64_t nodes, const LbmOptions& o, double tau_minus) {
  StepParams<Real> p;
  p.nodes = static_cast<std::uint64_t>(nodes);
  p.omega_plus = static_cast<Real>(1 / o.tau);
  const double omega_minus = 1 / tau_minus;
  p.omega_minus = static_cast<Real>(omega_minus);
  p.half_force[o.axis] = static_cast<Real>(0.5 * o.force);
  for (int q = 1; q <= kHalf; ++q)
    p.source[q] =
        static_cast<Real>((1 - 0.5 * omega_minus) * 3 * weight(q) * kC[q][o.axis] * o.force);
  return p;
}

template <class Real>
void run_lattice(Lattice&& lat, const sim::SolidMask& mask, const LbmOptions& o, LbmResult& r) {
  const double nu = (o.tau - 0.5) / 3;
  const std::int64_t voxels = mask.voxels();
  const std::int64_t nodes = lat.nodes;
  const StepParams<Real> params = step_params<Real>(nodes, o, r.tau_minus);
  check_host_bytes(static_cast<double>(nodes),
                   (o.backend == Backend::CPU ? 2 * kQ : kQ) * sizeof(Real),
                   "the populations of " + std::to_string(nodes) + " nodes");
  std::unique_ptr<StepRunner<Real>> runner;
  {
    std::vector<Real> initial = initial_populations<Real>(lat, mask, o, nu);
    if (o.backend == Backend::CUDA) {
#ifdef MESOROCK_HAVE_CUDA
      const double need = static_cast<double>(nodes) * bytes_per_node(r.precision);
      const std::string shortfall =
          sim::memory_shortfall(need, sim::device_memory_available(0), "device");
      if (!shortfall.empty())
        throw LimitError("lbm: the lattice of " + std::to_string(nodes) + " nodes " + shortfall);
      runner = make_cuda_runner<Real>(lat.source, initial, params);
#endif
    } else {
      runner = std::make_unique<CpuRunner<Real>>(std::move(lat.source), std::move(initial), params,
                                                 o.threads);
    }
    lat.source = std::vector<std::uint32_t>();
  }
  const auto t0 = std::chrono::steady_clock::now();
  double q_prev = 0;
  StepSums sums;
  for (std::int64_t s = 0; s < o.max_steps;) {
    const std::int64_t count = std::min<std::int64_t>(o.check_every, o.max_steps - s);
    runner->run(count, true, o.axis, sums);
    s += count;
    r.steps = s;
    const double q = sums.u_axis / static_cast<double>(voxels);
    if (!std::isfinite(q) || !std::isfinite(sums.drho))
      throw NumericalError("lbm: the mean velocity is not finite at step " + std::to_string(s));
    const double change = q != 0 ? std::abs(q - q_prev) / std::abs(q) : (q_prev == 0 ? 0.0 : 1.0);
    r.history.push_back({s, q, change});
    r.darcy_velocity = q;
    r.max_velocity = std::sqrt(sums.u2_max);
    r.mean_density = 1 + sums.drho / static_cast<double>(nodes);
    q_prev = q;
    if (o.progress) o.progress(s, change);
    if (o.poll) o.poll();
    if (change < o.tolerance && r.history.size() > 1) {
      r.converged = true;
      break;
    }
  }
  r.step_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (o.keep_field) {
    FlowField& f = r.field;
    f.dims = mask.dims;
    f.nu = nu;
    f.force = o.force;
    f.node_of.assign(static_cast<std::size_t>(voxels), kWall);
    for (std::int64_t n = 0; n < nodes; ++n)
      f.node_of[static_cast<std::size_t>(lat.voxel[static_cast<std::size_t>(n)])] =
          static_cast<std::uint32_t>(n);
    runner->moments(f.drho, f.jx, f.jy, f.jz);
  }
  r.k_voxel2 = nu * r.darcy_velocity / o.force;
}

}  // namespace

LbmResult lbm_permeability(const sim::SolidMask& mask, const LbmOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  check_inputs(mask, o);
  if (o.backend == Backend::CUDA) {
    const std::string why = cuda_unavailable_reason();
    if (!why.empty()) throw DeviceError("lbm: " + why);
  }
  LbmResult r;
  r.backend = o.backend;
  r.precision = o.precision;
  const std::int64_t voxels = mask.voxels();
  for (const std::uint8_t s : mask.solid) r.pore_voxels += s == 0;
  if (r.pore_voxels == 0) throw ConfigError("lbm: the solid mask has no pore voxel");
  if (r.pore_voxels == voxels)
    throw ConfigError(
        "lbm: the solid mask has no solid voxel: a body force accelerates the fluid without "
        "bound, so it has no permeability");
  r.porosity = static_cast<double>(r.pore_voxels) / static_cast<double>(voxels);
  r.tau_minus = 0.5 + kMagicLambda / (o.tau - 0.5);
  LbmOptions options = o;
  options.threads = o.threads > 0 ? o.threads : omp_get_max_threads();
  Lattice lat = percolating_lattice(mask, o.axis, options.threads);
  if (lat.nodes == 0) {
    r.percolates = false;
    r.converged = true;  // k = 0 is the exact Stokes answer: nothing to run
    r.mean_density = 1;
  } else {
    r.percolates = true;
    r.fluid_nodes = lat.nodes;
    if (o.precision == Precision::Single)
      run_lattice<float>(std::move(lat), mask, options, r);
    else
      run_lattice<double>(std::move(lat), mask, options, r);
  }
  const double nu = (o.tau - 0.5) / 3;
  r.k_rc2 = r.k_voxel2 * mask.voxel[0] * mask.voxel[0];
  r.mean_pore_velocity = r.darcy_velocity / r.porosity;
  r.reynolds_estimate = std::abs(r.darcy_velocity) * std::sqrt(std::max(0.0, r.k_voxel2)) / nu;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace mesorock::lbm
