// `rockflow lbm SOLID`: the Stokes permeability of a solid mask by lattice Boltzmann on a ladder
// of refined lattices, extrapolated to the converged value: the continuum reference for the
// particle sweep (lbm/ladder.h, docs/lbm.md).
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <vector>

#include "lbm/ladder.h"
#include "lbm/lattice.h"
#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/output_lock.h"
#include "pipeline/cli_checks.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "pipeline/flow/interrupt.h"
#include "sim/solid_grid.h"

namespace mesorock::pipeline {

namespace {

// The progress line of `rockflow lbm` on stderr: the step, the relative change of the Darcy
// velocity against the tolerance, and a guess at the time left from the rate at which the change
// has been falling over the last few checks. On a terminal one line is redrawn; in a log, a line
// every 10 s.
class LbmProgressLine {
 public:
  LbmProgressLine(std::string label, double tolerance, std::int64_t max_steps)
      : label_(std::move(label)),
        tolerance_(tolerance),
        max_steps_(max_steps),
        tty_(isatty(STDERR_FILENO)),
        start_(std::chrono::steady_clock::now()),
        last_(start_) {}

  void update(std::int64_t step, double change) {
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    checks_.push_back({step, std::log(std::max(change, 1e-300))});
    if (std::chrono::duration<double>(now - last_).count() < (tty_ ? 0.2 : 10)) return;
    last_ = now;
    // Steps left: the change falls about exponentially; extrapolate over the last 5 checks.
    std::int64_t left = max_steps_ - step;
    if (checks_.size() > 5) {
      const Check& old = checks_[checks_.size() - 6];
      const double rate =
          (old.log_change - checks_.back().log_change) / static_cast<double>(step - old.step);
      if (rate > 0)
        left = std::min<std::int64_t>(
            left, static_cast<std::int64_t>(
                      std::max(0.0, (checks_.back().log_change - std::log(tolerance_)) / rate)));
    }
    std::ostringstream line;
    line << "lbm: " << label_ << ": step " << step << ", change " << std::setprecision(2) << change
         << " (stop at " << tolerance_ << "), " << static_cast<int>(elapsed) << " s, ETA ~"
         << static_cast<int>(elapsed / static_cast<double>(step) * static_cast<double>(left))
         << " s";
    if (tty_) {
      std::cerr << "\r" << line.str() << "\033[K" << std::flush;
      drawn_ = true;
    } else {
      std::cerr << line.str() << "\n" << std::flush;
    }
  }
  void finish() {
    if (drawn_) std::cerr << "\r\033[K" << std::flush;
    drawn_ = false;
  }

 private:
  struct Check {
    std::int64_t step;
    double log_change;
  };
  std::string label_;
  double tolerance_;
  std::int64_t max_steps_;
  bool tty_, drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_;
  std::vector<Check> checks_;
};

// The options of `rockflow lbm` on the command line.
struct LbmArgs {
  SolverFlags flags;
  lbm::LadderOptions ladder;
  std::string mask, out = "out", axis = "x", refine = "auto", backend = "auto",
                    precision = "double", warm_start = "on";
};

// "auto" -> {} (lbm::auto_rungs), "2" -> {2}, "1,2,3" -> {1, 2, 3}.
std::vector<int> parse_refines(const std::string& text) {
  if (text == "auto") return {};
  std::vector<int> out;
  for (const double v : parse_number_list(text, "lbm: --refine")) {
    if (v != std::floor(v) || v < 1 || v > 8)
      throw ConfigError("lbm: --refine: each rung must be a whole number 1 to 8 (got " + text +
                        ")");
    out.push_back(static_cast<int>(v));
  }
  return out;
}

// Before any work: the mask is a regular file (a FIFO would block), the output folder is this
// process's alone and can be written (OutputLock), and an earlier complete record is gone (a
// script waiting for lbm.json must not read the last run's).
void check_mask_file(const LbmArgs& a) {
  std::error_code ec;
  if (!std::filesystem::exists(a.mask, ec)) throw IoError(a.mask + ": no such file");
  if (!std::filesystem::is_regular_file(a.mask, ec))
    throw IoError(a.mask + ": not a regular file (a folder, FIFO or device)");
}

lbm::Backend chosen_backend(const std::string& name) {
  if (name == "cpu") return lbm::Backend::CPU;
  const std::string why = lbm::cuda_unavailable_reason();
  if (name == "cuda") {
    if (!why.empty()) throw DeviceError("lbm: " + why);
    return lbm::Backend::CUDA;
  }
  return why.empty() ? lbm::Backend::CUDA : lbm::Backend::CPU;
}

std::string k_text(const nlohmann::json& k) {
  std::ostringstream s;
  s << std::setprecision(6) << k["voxel2"].get<double>() << " voxel^2 = " << k["rc2"].get<double>()
    << " rc^2";
  if (k.contains("mD")) s << " = " << k["mD"].get<double>() << " mD";
  return s.str();
}

// Prints the ladder's result: k_inf with its error and order, the finest rung, and warnings.
void print_result(const nlohmann::json& report, const lbm::LadderResult& r) {
  const auto& res = report["result"];
  if (!r.percolates) {
    std::cout << "permeability (LBM): 0: the pore space does not percolate along "
              << report["options"]["axis"].get<std::string>() << " (porosity " << r.porosity
              << ")\n";
    return;
  }
  const lbm::Extrapolation& e = r.extrapolation;
  std::cout << "permeability (LBM, " << (e.extrapolated ? "extrapolated" : "one lattice")
            << "): " << k_text(res["permeability"]);
  if (res["permeability_error"].is_object()) {
    const auto& err = res["permeability_error"];
    std::cout << " +- " << std::setprecision(2)
              << err[err.contains("mD") ? "mD" : "rc2"].get<double>()
              << (err.contains("mD") ? " mD" : " rc^2") << " (" << 100 * e.error_voxel2 / e.k_voxel2
              << "%)";
  }
  std::cout << std::setprecision(6) << "\n  porosity " << r.porosity << "; order "
            << (std::isfinite(e.order) ? std::to_string(e.order).substr(0, 4) : "not measured")
            << (e.asymptotic ? " (asymptotic)" : " (NOT asymptotic)") << "; finest rung (refine "
            << r.rungs.back().refine << "): " << k_text(res["finest_rung"]["permeability"]) << "; "
            << r.seconds << " s\n";
  for (const std::string& w : e.warnings) std::cerr << "rockflow: warning: lbm: " << w << "\n";
}

}  // namespace

FlowCommand add_lbm_command(CLI::App& rockflow) {
  auto a = std::make_shared<LbmArgs>();
  CLI::App* lbm = rockflow.add_subcommand(
      "lbm",
      "Stokes permeability of a solid mask by lattice Boltzmann (D3Q19 TRT), converged by a "
      "refinement ladder (docs/lbm.md)");
  lbm::LbmOptions& lo = a->ladder.base;
  lbm->add_option("solid", a->mask, "the solid mask (solid.h5, sim/solid_grid.h)")->required();
  lbm->add_option("--out", a->out, "output folder (lbm.json)")->capture_default_str();
  lbm->add_option("--axis", a->axis, "flow axis x|y|z")
      ->check(CLI::IsMember({"x", "y", "z"}))
      ->capture_default_str();
  lbm->add_option("--refine", a->refine,
                  "lattice nodes per voxel edge: auto (a ladder 1,2,3,4 or 1,2,3 by size), one "
                  "value (one lattice, not extrapolated) or an increasing list such as 2,3,4")
      ->capture_default_str();
  lbm->add_option("--tau", lo.tau,
                  "relaxation time at refine 1, > 1/2 (rung r: 1/2 + (tau - 1/2) r; k does not "
                  "depend on it)")
      ->check(number_check([](double v, const std::string& t) {
        return v > 0.5 ? std::string() : "must be above 1/2 (got " + t + ")";
      }))
      ->capture_default_str();
  lbm->add_option("--force", lo.force, "body force per node, lattice units (not zero)")
      ->check(number_check([](double v, const std::string& t) {
        return v != 0 && std::isfinite(v) ? std::string()
                                          : "must be finite, not zero (got " + t + ")";
      }))
      ->capture_default_str();
  lbm->add_option("--tolerance", lo.tolerance,
                  "stop a rung when the Darcy velocity changes less than this (relative) per check")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  lbm->add_option("--check-every", lo.check_every, "steps between checks")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  lbm->add_option("--max-steps", lo.max_steps, "most steps per rung")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  lbm->add_option("--backend", a->backend, "cpu, cuda or auto (cuda when a device is usable)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}))
      ->capture_default_str();
  lbm->add_option("--precision", a->precision,
                  "populations in single or double precision (sums always in double)")
      ->check(CLI::IsMember({"single", "double"}))
      ->capture_default_str();
  lbm->add_option("--warm-start", a->warm_start,
                  "start each rung from the previous rung's flow (on) or from rest (off)")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  add_solver_flags(*lbm, a->flags, false);
  return {
      lbm, [a](std::shared_ptr<sim::Communicator>) {
        lbm::LadderOptions o = a->ladder;
        o.refines = parse_refines(a->refine);
        o.warm_start = a->warm_start == "on";
        o.base.axis = a->axis[0] - 'x';
        o.base.threads = a->flags.threads;
        o.base.precision =
            a->precision == "single" ? lbm::Precision::Single : lbm::Precision::Double;
        o.base.backend = chosen_backend(a->backend);
        check_mask_file(*a);
        const OutputLock lock(a->out);  // one owner per folder, before any work
        lock.remove_earlier_record("lbm.json");
        install_interrupt_handlers();  // Ctrl-C: exit 130 within a check, no lbm.json
        const sim::SolidMask image = sim::read_solid_file(a->mask);
        std::unique_ptr<LbmProgressLine> line;
        o.base.poll = [] { throw_if_interrupted("during rockflow lbm (no lbm.json written)"); };
        o.base.progress = [&line](std::int64_t step, double change) {
          if (line) line->update(step, change);
        };
        o.rung_start = [&](int index, int refine, std::int64_t nodes) {
          line = std::make_unique<LbmProgressLine>("refine " + std::to_string(refine) + " (rung " +
                                                       std::to_string(index + 1) + ", about " +
                                                       std::to_string(nodes) + " pore nodes)",
                                                   o.base.tolerance, o.base.max_steps);
        };
        o.rung_done = [&](int, int refine, const lbm::LbmResult& r) {
          line->finish();
          std::cerr << "lbm: refine " << refine << ": k = " << std::setprecision(6)
                    << r.k_voxel2 / (refine * refine) << " voxel^2, " << r.fluid_nodes << " nodes, "
                    << r.steps << " steps" << (r.converged ? "" : " (NOT converged)") << ", "
                    << std::setprecision(3) << r.seconds << " s (" << lbm::to_string(r.backend)
                    << ", " << lbm::to_string(r.precision) << ")\n";
        };
        lbm::LadderResult r;
        try {
          r = lbm::lbm_ladder(image, o);
        } catch (const ConfigError& e) {
          if (line) line->finish();
          throw ConfigError(a->mask + ": " + e.what());  // the mask's problem: name it
        } catch (...) {
          if (line) line->finish();
          throw;
        }
        const nlohmann::json report = lbm::ladder_report_json(a->mask, image, o, r);
        write_text_atomically(std::filesystem::path(a->out) / "lbm.json", report.dump(2) + "\n");
        print_result(report, r);
        std::cout << "outputs: " << (std::filesystem::path(a->out) / "lbm.json").string() << "\n";
        return static_cast<int>(kExitOk);
      }};
}

}  // namespace mesorock::pipeline
