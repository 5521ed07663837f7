#include "pipeline/flow/run_scene.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/particle_io.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

void run_scene(const Scene& scene, const RunOptions& o) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  sim::ParticleSet initial = build_initial_particles(scene);
  if (scene.stages.empty()) throw ConfigError(scene.path.string() + ": run: no stages");
  auto sim = sim::make_simulation(scene.model, scene.box, initial, scene.stages.front().dt, o.sim);

  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) throw IoError(o.out_dir.string() + ": cannot create output folder: " + ec.message());

  if (o.progress)
    std::cerr << "rockflow: " << scene.path.string() << ": " << sim->size() << " particles, "
              << sim->pass_name() << ", backend " << sim->backend_name() << ", "
              << sim::to_string(scene.model.precision) << " precision\n";

  // thermo.csv grows during the run under its temporary name and is renamed at the end.
  const fs::path thermo_path = o.out_dir / "thermo.csv";
  const fs::path thermo_tmp = temporary_path_for(thermo_path);
  std::ofstream thermo;
  if (scene.output.thermo_every > 0) {
    thermo.open(thermo_tmp);
    if (!thermo) throw IoError(thermo_path.string() + ": cannot open for writing");
    thermo << "# mesorock " << kVersion << " (" << kGitCommit << "), scene " << scene.path.string()
           << ", reduced units (rc = m = kBT = 1)\n";
    thermo << "step,time,stage,temperature,pressure,px,py,pz\n";
    thermo << std::setprecision(10);
  }
  double time = 0;
  std::uint64_t total_steps = 0;
  const auto t_run = Clock::now();
  try {
    for (const auto& stage : scene.stages) {
      sim->set_dt(stage.dt);
      std::uint64_t done = 0;
      const std::uint64_t chunk = scene.output.thermo_every > 0
                                      ? scene.output.thermo_every
                                      : std::max<std::uint64_t>(stage.steps, 1);
      const auto t_stage = Clock::now();
      while (done < stage.steps) {
        const std::uint64_t n = std::min(chunk, stage.steps - done);
        sim->run(n);
        done += n;
        time += static_cast<double>(n) * stage.dt;
        if (scene.output.thermo_every > 0) {
          const double T = sim->kinetic_temperature();
          const auto st = sim->stress();
          const auto p = sim->momentum();
          if (!std::isfinite(T) || !std::isfinite(st.pressure()))
            throw NumericalError("step " + std::to_string(sim->step()) +
                                 ": temperature or pressure is not finite (dt = " +
                                 std::to_string(stage.dt) + " may be too large)");
          thermo << sim->step() << "," << time << "," << stage.name << "," << T << ","
                 << st.pressure() << "," << p[0] << "," << p[1] << "," << p[2] << "\n";
        }
        if (o.progress) {
          const double el = std::chrono::duration<double>(Clock::now() - t_stage).count();
          const double rate = el > 0 ? sim->size() * static_cast<double>(done) / el / 1e6 : 0;
          const double eta = done > 0 ? el * static_cast<double>(stage.steps - done) / done : 0;
          // On a terminal one line is redrawn; in a log, a line per tenth of the stage.
          const bool tty = isatty(STDERR_FILENO);
          const std::uint64_t tenth = std::max<std::uint64_t>(1, stage.steps / 10);
          if (tty || done == stage.steps || (done / tenth) != ((done - n) / tenth))
            std::cerr << (tty ? "\r" : "") << "  stage " << stage.name << ": " << done << "/"
                      << stage.steps << " steps, " << std::setprecision(3) << rate << " MPS/s, ETA "
                      << std::setprecision(3) << eta << " s" << (tty ? "   " : "\n") << std::flush;
        }
      }
      total_steps += stage.steps;
      if (o.progress && isatty(STDERR_FILENO)) std::cerr << "\n";
    }
  } catch (...) {
    thermo.close();
    fs::remove(thermo_tmp, ec);
    throw;
  }
  const double run_seconds = std::chrono::duration<double>(Clock::now() - t_run).count();
  if (thermo.is_open()) {
    thermo.close();
    fs::rename(thermo_tmp, thermo_path, ec);
    if (ec) throw IoError(thermo_path.string() + ": cannot rename: " + ec.message());
  }

  nlohmann::json provenance = {{"scene", scene.path.string()},
                               {"seed", scene.model.seed},
                               {"backend", sim->backend_name()},
                               {"pass", sim->pass_name()}};
  if (scene.output.final_snapshot) {
    sim::ParticleFileMeta meta;
    for (const auto& t : scene.model.types) meta.type_names.push_back(t.name);
    meta.box = scene.box;
    meta.step = sim->step();
    meta.time = time;
    meta.created_by = "rockflow run";
    meta.provenance_json = provenance.dump();
    meta.length_unit = "rc";
    sim::write_particle_file(o.out_dir / "final.h5", sim->particles(), meta);
    sim::write_particle_xdmf(o.out_dir / "final.xmf", o.out_dir / "final.h5", sim->size());
  }

  const double T = sim->kinetic_temperature();
  nlohmann::json summary = {
      {"mesorock_version", kVersion},
      {"git_commit", kGitCommit},
      {"scene_file", scene.path.string()},
      {"scene_name", scene.name},
      {"backend", sim->backend_name()},
      {"precision", sim::to_string(scene.model.precision)},
      {"pass", sim->pass_name()},
      {"density_kernel", scene.model.conservative == sim::ConservativeKind::MDPD
                             ? sim::to_string(scene.model.density_kernel)
                             : "none"},
      {"particles", sim->size()},
      {"steps", total_steps},
      {"simulated_time", time},
      {"wall_seconds", std::chrono::duration<double>(Clock::now() - t_start).count()},
      {"run_seconds", run_seconds},
      {"mps",
       run_seconds > 0 ? sim->size() * static_cast<double>(total_steps) / run_seconds / 1e6 : 0.0},
      {"final_temperature", T},
      {"units", "reduced: rc = m = kBT = 1"},
      {"scene", scene.source_text}};
  write_text_atomically(o.out_dir / "summary.json", summary.dump(2) + "\n");
  if (o.progress)
    std::cerr << "rockflow: done: " << total_steps << " steps in " << std::setprecision(3)
              << run_seconds << " s; outputs in " << o.out_dir.string()
              << " (summary.json, thermo.csv, final.xmf opens in ParaView)\n";
}

}  // namespace mesorock::pipeline
