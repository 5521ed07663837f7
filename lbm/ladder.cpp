#include "lbm/ladder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "lbm/d3q19.h"
#include "lbm/lattice.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/memory_budget.h"

namespace mesorock::lbm {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// k_inf of k = k_inf + C1 / r + C2 / r^2 through three rungs: the quadratic in x = 1 / r
// through the three points, evaluated at x = 0 (Lagrange).
double three_term(const double* r, const double* k) {
  double sum = 0;
  for (int i = 0; i < 3; ++i) {
    double w = 1;
    for (int j = 0; j < 3; ++j)
      if (j != i) w *= (0 - 1 / r[j]) / (1 / r[i] - 1 / r[j]);
    sum += w * k[i];
  }
  return sum;
}

// The order p of k = k_inf + C r^-p through three rungs (NaN when the changes differ in sign or
// imply p outside 0.05..8): (ka - kb) / (kb - kc) = (ra^-p - rb^-p) / (rb^-p - rc^-p), which
// grows with p; bisection.
double power_order(const double* r, const double* k) {
  const double d1 = k[0] - k[1], d2 = k[1] - k[2];
  if (!(d1 * d2 > 0)) return kNaN;
  const double want = d1 / d2;
  const auto ratio = [&](double p) {
    const double a = std::pow(r[0], -p), b = std::pow(r[1], -p), c = std::pow(r[2], -p);
    return (a - b) / (b - c);
  };
  double lo = 0.05, hi = 8;
  if (want < ratio(lo) || want > ratio(hi)) return kNaN;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (ratio(mid) < want ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double power_limit(double rb, double rc, double kb, double kc, double p) {
  const double b = std::pow(rb, -p), c = std::pow(rc, -p);
  return kc - (kb - kc) * c / (b - c);
}

std::string number(double v, int digits = 4) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

}  // namespace

Extrapolation extrapolate(const std::vector<int>& refines, const std::vector<double>& k) {
  if (refines.empty() || refines.size() != k.size())
    throw ConfigError("lbm: extrapolate needs one k per refinement");
  Extrapolation e;
  const std::size_t n = k.size();
  std::vector<double> r(refines.begin(), refines.end());
  e.k_voxel2 = k.back();
  e.order = kNaN;
  e.order_previous = kNaN;
  if (n == 1) {
    e.error_voxel2 = kNaN;
    e.method = "one lattice: not extrapolated";
    e.warnings.push_back(
        "one lattice only: its k is not the converged value (k falls at first order as the "
        "lattice refines rock voxels; docs/lbm.md): run the ladder (the default --refine auto)");
    return e;
  }
  e.extrapolated = true;
  const double scale = std::max(std::abs(k.back()), std::numeric_limits<double>::min());
  const bool flat = std::abs(k[n - 1] - k[n - 2]) <= 1e-9 * scale &&
                    (n < 3 || std::abs(k[n - 2] - k[n - 3]) <= 1e-9 * scale);
  if (flat) {
    e.error_voxel2 = std::abs(k[n - 1] - k[n - 2]);
    e.asymptotic = true;
    e.method = "the rungs agree (to 1e-9): no refinement dependence to extrapolate";
    return e;
  }
  if (n == 2) {
    e.k_voxel2 = power_limit(r[0], r[1], k[0], k[1], 1);
    e.error_voxel2 = std::abs(k[1] - e.k_voxel2);
    e.method = "first order assumed from two rungs (k_inf + C / r); error: the whole correction";
    e.warnings.push_back("two rungs: the order of convergence is assumed, not measured");
    return e;
  }
  const double* r3 = &r[n - 3];
  const double* k3 = &k[n - 3];
  e.k_voxel2 = three_term(r3, k3);
  e.order = power_order(r3, k3);
  const bool shrinking = std::abs(k3[2] - k3[1]) < std::abs(k3[1] - k3[0]);
  e.asymptotic = std::isfinite(e.order) && e.order >= 0.5 && e.order <= 3 && shrinking;
  if (n >= 4) {
    const double previous = three_term(&r[n - 4], &k[n - 4]);
    e.order_previous = power_order(&r[n - 4], &k[n - 4]);
    e.error_voxel2 = std::abs(e.k_voxel2 - previous);
    e.asymptotic = e.asymptotic && std::isfinite(e.order_previous) &&
                   std::abs(e.order - e.order_previous) <= 0.5;
    e.method =
        "k_inf + C1/r + C2/r^2 through the last three rungs; error: its change from the three "
        "before";
  } else {
    // The two-term model of the nearest whole order through the last two rungs, and the power
    // law: how far the three-term limit sits from the other models these rungs allow.
    const double whole = std::isfinite(e.order) && e.order >= 1.5 ? 2 : 1;
    double spread = std::abs(e.k_voxel2 - power_limit(r[1], r[2], k[1], k[2], whole));
    if (std::isfinite(e.order))
      spread =
          std::max(spread, std::abs(e.k_voxel2 - power_limit(r[1], r[2], k[1], k[2], e.order)));
    e.error_voxel2 = spread;
    e.method =
        "k_inf + C1/r + C2/r^2 through three rungs; error: the spread of the extrapolations three "
        "rungs allow (a fourth rung measures it)";
    e.warnings.push_back(
        "three rungs: the error is the spread of extrapolations, not a measured change; a fourth "
        "rung checks it");
  }
  if (!e.asymptotic)
    e.warnings.push_back("the ladder is not yet in its asymptotic range (order " +
                         number(e.order, 3) +
                         (n >= 4 ? ", previous " + number(e.order_previous, 3) : std::string()) +
                         "; changes " + number(k3[1] - k3[0], 3) + ", " + number(k3[2] - k3[1], 3) +
                         " voxel^2): add a finer rung before trusting k_inf");
  if (std::abs(e.error_voxel2) > 0.01 * std::abs(e.k_voxel2))
    e.warnings.push_back("k_inf's error is " + number(100 * e.error_voxel2 / e.k_voxel2, 2) +
                         "%, above 1%: add a finer rung");
  return e;
}

std::vector<int> auto_rungs(const sim::SolidMask& mask, Backend backend, Precision precision) {
  double pores = 0;
  for (const std::uint8_t s : mask.solid) pores += s == 0;
  double top_nodes = 2e6;  // the CPU: minutes on two cores for a 50^3 crop
  if (backend == Backend::CUDA) {
    const sim::MemoryAvailable m = sim::device_memory_available(0);
    top_nodes = m.bytes ? 0.8 * *m.bytes / bytes_per_node(precision) : 4e8;
    top_nodes = std::min(top_nodes, 4e8);
  }
  if (pores * 64 <= top_nodes) return {1, 2, 3, 4};
  return {1, 2, 3};
}

LadderResult lbm_ladder(const sim::SolidMask& image, const LadderOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  image.check("lbm");
  const std::vector<int> refines =
      o.refines.empty() ? auto_rungs(image, o.base.backend, o.base.precision) : o.refines;
  for (std::size_t i = 0; i < refines.size(); ++i) {
    if (refines[i] < 1 || refines[i] > 8)
      throw ConfigError("lbm: --refine: each rung must be 1 to 8 (got " +
                        std::to_string(refines[i]) + ")");
    if (i > 0 && refines[i] <= refines[i - 1])
      throw ConfigError("lbm: --refine: the rungs must increase");
  }
  double pores = 0;
  for (const std::uint8_t s : image.solid) pores += s == 0;
  LadderResult out;
  FlowField previous;
  for (std::size_t i = 0; i < refines.size(); ++i) {
    const int r = refines[i];
    LbmOptions opt = o.base;
    if (o.scale_tau) opt.tau = 0.5 + (o.base.tau - 0.5) * r;
    opt.keep_field = o.warm_start && i + 1 < refines.size();
    if (o.warm_start && i > 0) opt.initial = {&previous, static_cast<double>(r) / refines[i - 1]};
    if (o.rung_start)
      o.rung_start(static_cast<int>(i), r, static_cast<std::int64_t>(pores * r * r * r));
    Rung rung;
    rung.refine = r;
    rung.tau = opt.tau;
    {
      const sim::SolidMask lattice = refine_mask(image, r);
      rung.result = lbm_permeability(lattice, opt);
    }
    rung.k_voxel2 = rung.result.k_voxel2 / (r * r);
    previous = std::move(rung.result.field);
    rung.result.field = FlowField{};
    if (o.rung_done) o.rung_done(static_cast<int>(i), r, rung.result);
    out.porosity = rung.result.porosity;
    out.percolates = rung.result.percolates;
    out.rungs.push_back(std::move(rung));
    if (!out.percolates) break;  // k = 0 on every lattice: the same components (lattice.h)
  }
  std::vector<int> done;
  std::vector<double> ks;
  for (const Rung& g : out.rungs) {
    done.push_back(g.refine);
    ks.push_back(g.k_voxel2);
  }
  if (!out.percolates) {
    out.extrapolation.k_voxel2 = 0;
    out.extrapolation.method = "the pore space does not percolate: k = 0";
    out.extrapolation.asymptotic = true;
  } else {
    out.extrapolation = extrapolate(done, ks);
  }
  for (const Rung& g : out.rungs)
    if (!g.result.converged)
      out.extrapolation.warnings.push_back(
          "refine " + std::to_string(g.refine) + " did not converge in " +
          std::to_string(g.result.steps) + " steps: raise --max-steps");
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

namespace {

nlohmann::json k_json(double k_voxel2, const sim::SolidMask& image) {
  const double rc2 = k_voxel2 * image.voxel[0] * image.voxel[0];
  nlohmann::json k = {{"voxel2", k_voxel2}, {"rc2", rc2}};
  if (image.nm_per_rc > 0) {
    const double nm2 = rc2 * image.nm_per_rc * image.nm_per_rc;
    k["nm2"] = nm2;
    k["mD"] = nm2 / 986.9233;  // 1 mD = 9.869233e-16 m^2
  }
  return k;
}

nlohmann::json finite_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

nlohmann::json rung_json(const Rung& g, const sim::SolidMask& image) {
  const LbmResult& r = g.result;
  nlohmann::json history = nlohmann::json::array();
  for (const LbmCheck& c : r.history)
    history.push_back(
        {{"step", c.step}, {"darcy_velocity", c.darcy_velocity}, {"rel_change", c.rel_change}});
  const double updates = static_cast<double>(r.fluid_nodes) * static_cast<double>(r.steps);
  return {{"refine", g.refine},
          {"tau", g.tau},
          {"tau_minus", r.tau_minus},
          {"viscosity", (g.tau - 0.5) / 3},
          {"permeability", k_json(g.k_voxel2, image)},
          {"fluid_nodes", r.fluid_nodes},
          {"steps", r.steps},
          {"converged", r.converged},
          {"darcy_velocity", r.darcy_velocity},
          {"max_velocity", r.max_velocity},
          {"reynolds_estimate", r.reynolds_estimate},
          {"mean_density", r.mean_density},
          {"seconds", r.seconds},
          {"step_seconds", r.step_seconds},
          {"node_updates_per_second", r.step_seconds > 0 ? updates / r.step_seconds : 0.0},
          {"history", history}};
}

}  // namespace

nlohmann::json ladder_report_json(const std::string& input_file, const sim::SolidMask& image,
                                  const LadderOptions& o, const LadderResult& r) {
  const Extrapolation& e = r.extrapolation;
  nlohmann::json rungs = nlohmann::json::array();
  std::vector<int> refines;
  bool converged = true;
  std::int64_t pore_voxels = 0;
  for (const std::uint8_t s : image.solid) pore_voxels += s == 0;
  for (const Rung& g : r.rungs) {
    rungs.push_back(rung_json(g, image));
    refines.push_back(g.refine);
    converged = converged && g.result.converged;
  }
  const LbmOptions& b = o.base;
  nlohmann::json result = {
      {"permeability", k_json(e.k_voxel2, image)},
      {"permeability_error",
       std::isfinite(e.error_voxel2) ? k_json(e.error_voxel2, image) : nlohmann::json()},
      {"extrapolated", e.extrapolated},
      {"order", finite_or_null(e.order)},
      {"order_previous", finite_or_null(e.order_previous)},
      {"asymptotic", e.asymptotic},
      {"extrapolation", e.method},
      {"warnings", e.warnings},
      {"finest_rung", r.rungs.empty() ? nlohmann::json()
                                      : nlohmann::json({{"refine", r.rungs.back().refine},
                                                        {"permeability",
                                                         k_json(r.rungs.back().k_voxel2, image)}})},
      {"porosity", r.porosity},
      {"percolates", r.percolates},
      {"converged", converged},
      {"seconds", r.seconds}};
  return {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"command", "rockflow lbm"},
      {"input_file", input_file},
      {"method",
       "D3Q19 TRT lattice Boltzmann, Lambda = 3/16, Stokes (linear) equilibrium, halfway "
       "bounce-back, periodic, uniform body force with Guo forcing, on a ladder of refined "
       "lattices (each voxel r^3 nodes) extrapolated to r -> infinity; docs/lbm.md"},
      {"definitions",
       "lattice units (lattice voxel = 1, dt = 1, rho0 = 1); nu = (tau - 1/2) / 3; q = sum of "
       "u_axis over the pore nodes / all lattice voxels (Darcy velocity); k = nu q / force, "
       "reported in the image's voxels (k_lattice / r^2); k_rc2 = k voxel_rc^2; Re = q sqrt(k) / "
       "nu"},
      {"options",
       {{"axis", std::string(1, "xyz"[b.axis])},
        {"refines", refines},
        {"tau_at_refine_1", b.tau},
        {"tau_scaling", o.scale_tau ? "tau_r = 1/2 + (tau - 1/2) r" : "none"},
        {"warm_start", o.warm_start},
        {"magic_lambda", kMagicLambda},
        {"force", b.force},
        {"tolerance", b.tolerance},
        {"check_every", b.check_every},
        {"max_steps", b.max_steps},
        {"threads", b.threads},
        {"backend", to_string(b.backend)},
        {"precision", to_string(b.precision)}}},
      {"mask",
       {{"dims", image.dims},
        {"voxel_rc", image.voxel},
        {"nm_per_rc", image.nm_per_rc},
        {"pore_voxels", pore_voxels}}},
      {"result", result},
      {"rungs", rungs}};
}

}  // namespace mesorock::lbm
