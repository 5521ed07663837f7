// rockflow: run a scene, validate the physics, benchmark the solver.
#include <CLI/CLI.hpp>

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
#include "mesorock/version.h"
#include "pipeline/cli_checks.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/bench.h"
#include "pipeline/flow/interrupt.h"
#include "pipeline/flow/lbm_stokes.h"
#include "pipeline/flow/progress.h"
#include "pipeline/flow/run_scene.h"
#include "pipeline/flow/study.h"
#include "pipeline/flow/sweep.h"
#include "pipeline/flow/validation.h"
#include "pipeline/scene.h"
#include "sim/domain/communicator.h"
#include "sim/particle_io.h"
#include "sim/solid_grid.h"

namespace mp = mesorock::pipeline;
namespace ms = mesorock::sim;

namespace {

ms::BackendKind parse_backend(const std::string& s) {
  if (s == "cpu") return ms::BackendKind::CPU;
  if (s == "cuda") return ms::BackendKind::CUDA;
  throw mesorock::ConfigError("--backend must be cpu or cuda (got " + s + ")");
}

// Fails early, with one line, when CUDA is asked for but absent (never a silent fall-back).
void require_backend(ms::BackendKind b) {
  if (b != ms::BackendKind::CUDA) return;
  const std::string why = ms::cuda_unavailable_reason();
  if (!why.empty()) throw mesorock::DeviceError(why);
}

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

int main(int argc, char** argv) {
  // Under mpirun every rank runs this program; MPI starts only then (a plain run never calls
  // MPI_Init). A rank that fails alone aborts the others, which would wait in a collective.
  ms::MpiSession mpi(&argc, &argv);
  ms::skip_hdf5_exit_cleanup();
  const int code = mp::run_main("rockflow", [&]() -> int {
    CLI::App app{"rockflow: the mesorock mDPD flow solver"};
    app.set_version_flag("--version", std::string("rockflow ") + mesorock::kVersion + " (" +
                                          mesorock::kGitCommit + ")");
    app.require_subcommand(1);

    std::string backend = "cpu";
    int threads = 0;
    std::string watchdog = "on";  // sim/watchdog.h
    double runaway = ms::WatchdogOptions{}.runaway_displacement;
    const auto on_off = CLI::IsMember({"on", "off"});
    const char* const watchdog_help = "stop a blow-up (NaN, runaway velocity) with a diagnostic";

    auto* run = app.add_subcommand("run", "run a scene file");
    std::string scene_path, out_dir = "out";
    run->add_option("scene", scene_path, "scene file (TOML, see docs/scene.md)")->required();
    run->add_option("--out", out_dir, "output folder")->capture_default_str();
    run->add_option("--backend", backend, "cpu or cuda")->capture_default_str();
    run->add_option("--threads", threads, "CPU threads (0: all cores)")
        ->check(CLI::NonNegativeNumber);
    run->add_option("--watchdog", watchdog, watchdog_help)->check(on_off)->capture_default_str();
    run->add_option("--runaway-displacement", runaway,
                    "watchdog: a particle moving more rc than this in one step is a runaway")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    bool resume = false;
    std::int64_t checkpoint_every = -1;
    run->add_flag("--resume", resume, "continue from OUT/checkpoint.h5 (same scene)");
    run->add_option("--checkpoint-every", checkpoint_every,
                    "write OUT/checkpoint.h5 every N steps (default: the scene's "
                    "[output] checkpoint_every; 0 = none)")
        ->check(CLI::NonNegativeNumber);

    auto* val = app.add_subcommand("validate", "run a built-in physics validation case");
    std::string case_name, size = "small", kernel = "warren";
    bool list = false, json = false;
    val->add_option("case", case_name, "case name (see --list)");
    val->add_flag("--list", list, "print the case names, one per line");
    val->add_option("--size", size, "small (CI) or full")->check(CLI::IsMember({"small", "full"}));
    val->add_option("--density-kernel", kernel, "warren or lucy")
        ->check(CLI::IsMember({"warren", "lucy"}));
    val->add_option("--backend", backend, "cpu or cuda");
    val->add_option("--threads", threads, "CPU threads (0: all cores)")
        ->check(CLI::NonNegativeNumber);
    val->add_flag("--json", json, "print one JSON object");
    val->add_option("--watchdog", watchdog, watchdog_help)->check(on_off)->capture_default_str();

    auto* sweep = app.add_subcommand(
        "sweep", "permeability sweep: flow rate vs driving force, Darcy and Forchheimer fits");
    mp::SweepCommand sc;
    std::string sweep_scene, sweep_out = "out", forces_text;
    double fluid_density = 0, viscosity = 0, viscosity_error = 0;
    std::string viscosity_cache, types_text;
    sweep->add_option("scene", sweep_scene, "the prepared sample (scene file)")->required();
    sweep->add_option("--out", sweep_out, "output folder")->capture_default_str();
    sweep
        ->add_option("--forces", forces_text,
                     "body forces per fluid particle, comma-separated (reduced units)")
        ->required();
    sweep->add_option("--axis", sc.axis, "flow axis x|y|z (default: the scene's body force)");
    sweep->add_option("--types", types_text,
                      "driven types, comma-separated (default: the scene's body-force types)");
    sweep->add_option("--fluid-density", fluid_density,
                      "the fluid's number density n_f (default: the scene's [[init]] density)");
    sweep->add_option("--viscosity", viscosity, "the fluid's viscosity (skips the calibration)");
    sweep->add_option("--viscosity-error", viscosity_error, "its standard error");
    sweep->add_option("--calibration", sc.calibration, "calibration size tiny|small|full")
        ->check(CLI::IsMember({"tiny", "small", "full"}))
        ->capture_default_str();
    sweep->add_option("--viscosity-cache", viscosity_cache,
                      "folder of cached calibrations (default: ~/.cache/mesorock/viscosity)");
    sweep->add_option("--warmup", sc.run.warmup_steps, "steps before blocks start, per point")
        ->capture_default_str();
    sweep->add_option("--block-steps", sc.run.block_steps, "steps per averaging block")
        ->capture_default_str();
    sweep->add_option("--window", sc.run.window, "blocks per half of the steady-state test")
        ->capture_default_str();
    sweep->add_option("--tolerance", sc.run.tolerance, "steady-state tolerance (relative)")
        ->capture_default_str();
    sweep->add_option("--measure-blocks", sc.run.measure_blocks, "blocks measured once steady")
        ->capture_default_str();
    sweep->add_option("--max-steps", sc.run.max_steps, "most steps per point")
        ->capture_default_str();
    sweep->add_option("--backend", backend, "cpu or cuda");
    sweep->add_option("--threads", threads, "CPU threads (0: all cores)")
        ->check(CLI::NonNegativeNumber);

    auto* bench = app.add_subcommand("bench", "measure million particle-steps per second");
    mp::BenchOptions bo;
    std::string precision = "single";
    bool bench_json = false, compare_cpu = false;
    bench->add_option("--case", bo.case_name, "bulk or porous")
        ->check(CLI::IsMember({"bulk", "porous"}))
        ->capture_default_str();
    bench->add_option("--particles", bo.particles, "particle count")->capture_default_str();
    bench->add_option("--steps", bo.steps, "timed steps")->capture_default_str();
    bench->add_option("--backend", backend, "cpu or cuda");
    bench->add_option("--threads", threads, "CPU threads (0: all cores)")
        ->check(CLI::NonNegativeNumber);
    bench->add_option("--precision", precision, "single or double")
        ->check(CLI::IsMember({"single", "double"}));
    bench->add_flag("--compare-cpu", compare_cpu, "also run the CPU backend on the same case");
    bench->add_flag("--json", bench_json, "print JSON");
    bench
        ->add_option("--watchdog", watchdog,
                     "on, off, or compare: time both in alternating rounds and print its cost")
        ->check(CLI::IsMember({"on", "off", "compare"}))
        ->capture_default_str();
    bool profile = false, decompose = false;
    int reorder_every = 1;
    double skin = 0;
    bench
        ->add_option("--reorder-every", reorder_every,
                     "steps between cell sorts (needs --skin; default 1: every step)")
        ->check(CLI::Range(1, 1000));
    bench->add_option("--skin", skin, "cell-list skin in rc for --reorder-every")
        ->check(CLI::Range(0.0, 1.0));
    bench->add_flag("--decompose", decompose,
                    "run the decomposed (MPI) solver even on one rank, to measure its cost");
    bench->add_flag("--profile", profile, "CUDA: also time each pass (kick, sort, density, force)");
    int cells_per_rc = ms::SimulationOptions{}.cells_per_cutoff;
    bench->add_option("--cells-per-rc", cells_per_rc, "cell-list cells per cutoff (1-4)")
        ->check(CLI::Range(1, 4))
        ->capture_default_str();

    auto* lbm = app.add_subcommand(
        "lbm", "Stokes permeability of a solid mask by lattice Boltzmann (D3Q19 TRT; docs/lbm.md)");
    mp::LbmOptions lbm_options;
    std::string lbm_mask, lbm_out = "out", lbm_axis = "x";
    lbm->add_option("solid", lbm_mask, "the solid mask (solid.h5, sim/solid_grid.h)")->required();
    lbm->add_option("--out", lbm_out, "output folder (lbm.json)")->capture_default_str();
    lbm->add_option("--axis", lbm_axis, "flow axis x|y|z")
        ->check(CLI::IsMember({"x", "y", "z"}))
        ->capture_default_str();
    lbm->add_option("--tau", lbm_options.tau, "relaxation time, > 1/2 (k does not depend on it)")
        ->capture_default_str();
    lbm->add_option("--force", lbm_options.force, "body force per voxel, lattice units")
        ->capture_default_str();
    lbm->add_option("--tolerance", lbm_options.tolerance,
                    "stop when the Darcy velocity changes less than this (relative) per check")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    lbm->add_option("--check-every", lbm_options.check_every, "steps between checks")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    lbm->add_option("--max-steps", lbm_options.max_steps, "most steps")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    lbm->add_option("--threads", threads, "CPU threads (0: all cores)")
        ->check(CLI::NonNegativeNumber);
    int lbm_refine = 2;
    lbm->add_option("--refine", lbm_refine,
                    "lattice nodes per voxel edge (1 to 8; k converges as it grows, docs/lbm.md)")
        ->check(CLI::Range(1, 8))
        ->capture_default_str();

    const mp::StudyCommand study = mp::add_study_command(app, backend, threads);
    mp::bound_count_options(app);

    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      const int code = app.exit(e);
      return code == 0 ? 0 : mp::kExitBadInput;
    }

    ms::SimulationOptions so;
    so.backend = parse_backend(backend);
    so.threads = threads;
    so.comm = mpi.world();
    // Under mpirun, rank 0 alone prints results.
    const bool root = !so.comm || so.comm->rank() == 0;
    so.watchdog.enabled = watchdog != "off";
    so.watchdog.runaway_displacement = runaway;

    if (*run) {
      require_backend(so.backend);
      const mp::Scene scene = mp::load_scene(scene_path);
      mp::check_memory_for(scene, so);  // before any particle: host and (CUDA) device memory
      mp::RunOptions ro;
      ro.out_dir = out_dir;
      ro.sim = so;
      ro.sim.decomposition = scene.decomposition;
      ro.resume = resume;
      if (checkpoint_every >= 0) ro.checkpoint_every = static_cast<std::uint64_t>(checkpoint_every);
      mp::install_interrupt_handlers();  // Ctrl-C: checkpoint, then exit 130
      // Ctrl-C during the solver's set-up stops it between passes (nothing written yet).
      ro.sim.interrupt_check = [] {
        mp::throw_if_interrupted("during set-up, before any step: nothing was written");
      };
      mp::run_scene(scene, ro);
      return mp::kExitOk;
    }

    if (*sweep) {
      require_backend(so.backend);
      const mp::Scene scene = mp::load_scene(sweep_scene);
      mp::check_memory_for(scene, so);
      sc.out_dir = sweep_out;
      sc.run.sim = so;
      // Every item, empty ones too: "0.01,,0.02" is a typo, not two forces.
      auto split = [](const std::string& text) {
        std::vector<std::string> out;
        for (std::size_t start = 0;;) {
          const std::size_t comma = text.find(',', start);
          out.push_back(text.substr(start, comma - start));
          if (comma == std::string::npos) return out;
          start = comma + 1;
        }
      };
      for (const auto& f : split(forces_text)) {
        if (f.find_first_not_of(" \t") == std::string::npos)
          throw mesorock::ConfigError("sweep: --forces '" + forces_text +
                                      "': an empty item (forces are comma-separated numbers)");
        try {
          size_t used = 0;
          sc.forces.push_back(std::stod(f, &used));
          if (used != f.size()) throw std::invalid_argument(f);
        } catch (const std::exception&) {
          throw mesorock::ConfigError("sweep: --forces: '" + f + "' is not a number");
        }
      }
      if (!types_text.empty()) sc.types = split(types_text);
      if (fluid_density != 0) sc.fluid_density = fluid_density;
      if (viscosity != 0) sc.viscosity = viscosity;
      if (viscosity_error != 0) sc.viscosity_error = viscosity_error;
      if (!viscosity_cache.empty()) sc.viscosity_cache = viscosity_cache;
      const auto summary = mp::run_sweep_command(scene, sc);
      const auto& darcy = summary["fits"]["darcy"]["permeability"];
      std::cout << "permeability (Darcy fit): " << darcy["rc2"].get<double>() << " +- "
                << darcy["rc2_error"].get<double>() << " rc^2";
      if (darcy.contains("mD"))
        std::cout << " = " << darcy["nm2"].get<double>() << " nm^2 = " << darcy["mD"].get<double>()
                  << " mD";
      std::cout << "\n";
      if (summary["fits"].contains("quadratic")) {
        const auto& q = summary["fits"]["quadratic"];
        std::cout << "deviation from Darcy at the largest gradient: "
                  << 100 * q["deviation_at_largest_gradient"].get<double>() << " +- "
                  << 100 * q["deviation_error"].get<double>() << " %"
                  << (q["deviation_significant"].get<bool>() ? " (significant)" : "") << "\n";
      }
      std::cout << "outputs: " << sweep_out << "/sweep.csv, sweep.json, sweep.png\n";
      return mp::kExitOk;
    }

    if (*val) {
      if (list) {
        for (const auto& c : mp::validation_cases()) std::cout << c.name << "\n";
        return mp::kExitOk;
      }
      if (case_name.empty()) throw mesorock::ConfigError("validate: name a case (see --list)");
      const mp::ValidationCase* c = mp::find_validation_case(case_name);
      if (!c)
        throw mesorock::ConfigError("validate: unknown case '" + case_name + "' (see --list)");
      require_backend(so.backend);
      mp::ValidateOptions vo;
      vo.size = size == "full" ? mp::CaseSize::Full : mp::CaseSize::Small;
      vo.density_kernel =
          kernel == "lucy" ? ms::DensityKernelKind::Lucy : ms::DensityKernelKind::Warren;
      vo.sim = so;
      vo.verbose = root;
      mp::ProgressMeter meter("validate " + case_name, std::cerr, root);
      meter.set_total(1e6 * (vo.size == mp::CaseSize::Full ? c->work_full : c->work_small));
      vo.sim.on_run = [&meter](std::uint64_t steps, std::size_t n) { meter.advance(steps, n); };
      const auto t0 = std::chrono::steady_clock::now();
      mp::CaseResult r = c->run(vo);
      meter.finish(r.pass() ? "pass" : "FAIL");
      r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (root) std::cout << (json ? mp::format_case_json(r) + "\n" : mp::format_case_text(r));
      return r.pass() ? mp::kExitOk : mp::kExitFailed;
    }

    if (*lbm) {
      if (!std::filesystem::exists(lbm_mask)) throw mesorock::IoError(lbm_mask + ": no such file");
      const ms::SolidMask image = ms::read_solid_file(lbm_mask);
      const ms::SolidMask mask = mp::refine_mask(image, lbm_refine);
      lbm_options.axis = lbm_axis[0] - 'x';
      lbm_options.threads = threads;
      LbmProgressLine line(lbm_options.tolerance, lbm_options.max_steps);
      lbm_options.progress = [&line](std::int64_t step, double change) {
        line.update(step, change);
      };
      mp::LbmResult r;
      try {
        r = mp::lbm_permeability(mask, lbm_options);
      } catch (...) {
        line.finish();
        throw;
      }
      line.finish();
      const std::filesystem::path out(lbm_out);
      std::error_code ec;
      std::filesystem::create_directories(out, ec);
      if (ec) throw mesorock::IoError(lbm_out + ": cannot create output folder: " + ec.message());
      r.k_voxel2 /= lbm_refine * lbm_refine;  // in the image's voxels, not the lattice's
      nlohmann::json report = mp::lbm_report_json(lbm_mask, image, lbm_options, r);
      report["options"]["refine"] = lbm_refine;
      mesorock::write_text_atomically(out / "lbm.json", report.dump(2) + "\n");
      if (!r.percolates) {
        std::cout << "permeability (LBM): 0: the pore space does not percolate along " << lbm_axis
                  << " (porosity " << r.porosity << ")\n";
      } else {
        const auto& k = report["result"]["permeability"];
        std::cout << "permeability (LBM): " << r.k_voxel2 << " voxel^2 = " << r.k_rc2 << " rc^2";
        if (k.contains("mD"))
          std::cout << " = " << k["nm2"].get<double>() << " nm^2 = " << k["mD"].get<double>()
                    << " mD";
        std::cout << " (porosity " << r.porosity << ", " << r.steps << " steps, "
                  << (r.converged ? "converged" : "NOT converged") << ", " << r.seconds << " s)\n";
        if (!r.converged)
          std::cerr << "rockflow: warning: lbm: the Darcy velocity still changed by "
                    << r.history.back().rel_change << " per check after " << r.steps
                    << " steps (tolerance " << lbm_options.tolerance << "): raise --max-steps\n";
      }
      std::cout << "outputs: " << (out / "lbm.json").string() << "\n";
      return mp::kExitOk;
    }

    if (*study.app) {
      require_backend(so.backend);
      return study.run(so);
    }

    if (*bench) {
      require_backend(so.backend);
      bo.precision = precision == "double" ? ms::Precision::Double : ms::Precision::Single;
      bo.sim = so;
      bo.sim.profile = profile;
      bo.sim.cells_per_cutoff = cells_per_rc;
      bo.sim.reorder_every = reorder_every;
      bo.sim.skin = skin;
      if (decompose) {
        bo.sim.decomposition.force = true;
        if (!bo.sim.comm) bo.sim.comm = ms::make_self_communicator();
      }
      bo.compare_watchdog = watchdog == "compare";
      const mp::BenchResult r = mp::run_bench(bo);
      mp::BenchResult cpu;
      if (compare_cpu) {
        mp::BenchOptions co = bo;
        co.sim.backend = ms::BackendKind::CPU;
        co.sim.profile = false;
        co.steps = std::max<std::uint64_t>(5, bo.steps / 20);
        cpu = mp::run_bench(co);
      }
      if (!root) return mp::kExitOk;
      if (bench_json) {
        std::string out = mp::format_bench_json(r);
        if (compare_cpu) {
          out.pop_back();
          out += ",\"cpu\":" + mp::format_bench_json(cpu) +
                 ",\"speedup_vs_cpu\":" + std::to_string(r.mps / cpu.mps) + "}";
        }
        std::cout << out << "\n";
      } else {
        std::cout << mp::format_bench_text(r);
        if (compare_cpu)
          std::cout << mp::format_bench_text(cpu) << "speed-up vs CPU: " << r.mps / cpu.mps
                    << "x\n";
      }
      return mp::kExitOk;
    }
    return mp::kExitOk;
  });
  if (code != mp::kExitOk && mpi.world() && mpi.world()->size() > 1) ms::MpiSession::abort(code);
  return code;
}
