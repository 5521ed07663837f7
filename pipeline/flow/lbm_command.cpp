// `rockflow lbm SOLID`: the Stokes permeability of a solid mask by lattice Boltzmann, the
// continuum reference for the particle sweep (docs/lbm.md).
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <vector>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "pipeline/flow/lbm_stokes.h"
#include "sim/solid_grid.h"

namespace mesorock::pipeline {

namespace {

// The progress line of `rockflow lbm` on stderr: the step, the relative change of the Darcy
// velocity against the tolerance, and a guess at the time left from the rate at which the change
// has been falling over the last few checks. On a terminal one line is redrawn; in a log, a line
// every 10 s.
class LbmProgressLine {
 public:
  LbmProgressLine(double tolerance, std::int64_t max_steps)
      : tolerance_(tolerance),
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
    line << "lbm: step " << step << ", change " << std::setprecision(2) << change << " (stop at "
         << tolerance_ << "), " << static_cast<int>(elapsed) << " s, ETA ~"
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
  double tolerance_;
  std::int64_t max_steps_;
  bool tty_, drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_;
  std::vector<Check> checks_;
};

}  // namespace

FlowCommand add_lbm_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    LbmOptions options;
    std::string mask, out = "out", axis = "x";
    int refine = 2;
  };
  auto a = std::make_shared<Args>();
  CLI::App* lbm = rockflow.add_subcommand(
      "lbm", "Stokes permeability of a solid mask by lattice Boltzmann (D3Q19 TRT; docs/lbm.md)");
  LbmOptions& lo = a->options;
  lbm->add_option("solid", a->mask, "the solid mask (solid.h5, sim/solid_grid.h)")->required();
  lbm->add_option("--out", a->out, "output folder (lbm.json)")->capture_default_str();
  lbm->add_option("--axis", a->axis, "flow axis x|y|z")
      ->check(CLI::IsMember({"x", "y", "z"}))
      ->capture_default_str();
  lbm->add_option("--tau", lo.tau, "relaxation time, > 1/2 (k does not depend on it)")
      ->capture_default_str();
  lbm->add_option("--force", lo.force, "body force per voxel, lattice units")
      ->capture_default_str();
  lbm->add_option("--tolerance", lo.tolerance,
                  "stop when the Darcy velocity changes less than this (relative) per check")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  lbm->add_option("--check-every", lo.check_every, "steps between checks")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  lbm->add_option("--max-steps", lo.max_steps, "most steps")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  add_solver_flags(*lbm, a->flags, false);
  lbm->add_option("--refine", a->refine,
                  "lattice nodes per voxel edge (1 to 8; k converges as it grows, docs/lbm.md)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  return {
      lbm, [a](std::shared_ptr<sim::Communicator>) {
        if (!std::filesystem::exists(a->mask)) throw IoError(a->mask + ": no such file");
        const sim::SolidMask image = sim::read_solid_file(a->mask);
        const sim::SolidMask mask = refine_mask(image, a->refine);
        LbmOptions options = a->options;
        options.axis = a->axis[0] - 'x';
        options.threads = a->flags.threads;
        LbmProgressLine line(options.tolerance, options.max_steps);
        options.progress = [&line](std::int64_t step, double change) { line.update(step, change); };
        LbmResult r;
        try {
          r = lbm_permeability(mask, options);
        } catch (...) {
          line.finish();
          throw;
        }
        line.finish();
        const std::filesystem::path out(a->out);
        std::error_code ec;
        std::filesystem::create_directories(out, ec);
        if (ec) throw IoError(a->out + ": cannot create output folder: " + ec.message());
        r.k_voxel2 /= a->refine * a->refine;  // in the image's voxels, not the lattice's
        nlohmann::json report = lbm_report_json(a->mask, image, options, r);
        report["options"]["refine"] = a->refine;
        write_text_atomically(out / "lbm.json", report.dump(2) + "\n");
        if (!r.percolates) {
          std::cout << "permeability (LBM): 0: the pore space does not percolate along " << a->axis
                    << " (porosity " << r.porosity << ")\n";
        } else {
          const auto& k = report["result"]["permeability"];
          std::cout << "permeability (LBM): " << r.k_voxel2 << " voxel^2 = " << r.k_rc2 << " rc^2";
          if (k.contains("mD"))
            std::cout << " = " << k["nm2"].get<double>() << " nm^2 = " << k["mD"].get<double>()
                      << " mD";
          std::cout << " (porosity " << r.porosity << ", " << r.steps << " steps, "
                    << (r.converged ? "converged" : "NOT converged") << ", " << r.seconds
                    << " s)\n";
          if (!r.converged)
            std::cerr << "rockflow: warning: lbm: the Darcy velocity still changed by "
                      << r.history.back().rel_change << " per check after " << r.steps
                      << " steps (tolerance " << options.tolerance << "): raise --max-steps\n";
        }
        std::cout << "outputs: " << (out / "lbm.json").string() << "\n";
        return static_cast<int>(kExitOk);
      }};
}

}  // namespace mesorock::pipeline
