// rockprep walls: the surface-wall sweep (solid voxels within a wall thickness of the pore space,
// per phase) after the particle-count estimate; writes DIR/walls.vdb and DIR/walls.json.
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/cli_checks.h"
#include "pipeline/prep/common.h"
#include "voxel/phase_grids.h"
#include "voxel/pore_analysis.h"
#include "voxel/staged_output.h"
#include "voxel/walls.h"

namespace fs = std::filesystem;

namespace mesorock::pipeline::prep {
namespace {

struct WallsArgs {
  LabelInputArgs input;
  double nm_per_rc = 0;
  double rc_per_voxel = 0;
  double thickness_rc = 1.0;
  std::int64_t max_particles = 50'000'000;
  double density = 6.88;
  double wall_density = 0;  // 0: same as density
  std::string out;
  bool quiet = false;
};

nlohmann::json estimate_record(const voxel::ParticleEstimate& e) {
  return {{"pore_volume_rc3", e.pore_volume_rc3},
          {"wall_volume_rc3", e.wall_volume_rc3},
          {"wall_volume", e.wall_exact ? "counted wall voxels" : "estimated from faces"},
          {"fluid_particles", e.fluid_particles},
          {"wall_particles", e.wall_particles},
          {"total_particles", e.total()},
          {"gpu_bytes", e.bytes}};
}

int run_walls(const WallsArgs& a) {
  // Everything the user typed is checked before the load.
  if (a.nm_per_rc == 0 && a.rc_per_voxel == 0) {
    throw ConfigError(
        "walls: the length scale is explicit: give --nm-per-rc X (physical nanopores) or "
        "--rc-per-voxel Y (scale-free Stokes regime)");
  }
  if (a.nm_per_rc != 0 && a.rc_per_voxel != 0) {
    throw ConfigError("walls: give either --nm-per-rc or --rc-per-voxel, not both");
  }
  voxel::LengthScale scale;
  scale.nm_per_rc = a.nm_per_rc;
  scale.rc_per_voxel = a.rc_per_voxel;
  if (!(a.density > 0) || a.wall_density < 0) {
    throw ConfigError("walls: --density and --wall-density must be positive");
  }
  voxel::ParticleEstimateOptions limits;
  limits.fluid_density = a.density;
  limits.wall_density = a.wall_density > 0 ? a.wall_density : a.density;
  limits.max_particles = a.max_particles;
  if (a.max_particles < 1) throw ConfigError("walls: --max-particles must be positive");
  check_output_folder(a.out);

  Progress progress(a.quiet);
  nlohmann::json record = provenance("walls");
  nlohmann::json input;
  voxel::Volume labels = load_labels(a.input, progress, &input);
  record["input"] = input;
  const std::string& name = input["path"].get_ref<const std::string&>();
  const voxel::Spacing spacing = labels.spacing();
  const std::int64_t n = labels.voxels();
  const std::array<double, 3> voxel_rc =
      about_file(name, [&] { return voxel::voxel_size_rc(scale, spacing); });
  const std::array<int, 3> layers =
      about_file(name, [&] { return voxel::wall_layers(a.thickness_rc, voxel_rc); });
  {
    std::ostringstream s;
    s.precision(4);
    s << "scale " << scale.str() << ": voxel " << voxel_rc[0] << " x " << voxel_rc[1] << " x "
      << voxel_rc[2] << " rc (z, y, x); wall " << a.thickness_rc << " rc = " << layers[0] << ", "
      << layers[1] << ", " << layers[2] << " voxels";
    progress.note(s.str());
  }

  // 1. The estimate, from one pass over the labels.
  const voxel::PoreStatistics stats = progress.stage("pore voxels and interfaces", n, [&] {
    return about_file(name, [&] { return voxel::measure_pores(labels); });
  });
  const voxel::ParticleEstimate estimate =
      voxel::estimate_particles(stats, voxel_rc, layers, limits);
  progress.note("estimate: " + estimate.str());
  // The refusals name the input, like every other error.
  auto check_limit = [&](const voxel::ParticleEstimate& e) {
    try {
      voxel::check_particle_limit(e, limits);
    } catch (const LimitError& error) {
      throw LimitError(name + ": " + error.what());
    }
  };
  check_limit(estimate);

  // 2. The sweep on sparse masks; the dense labels are freed first.
  voxel::PhaseGridOptions grid_options;
  grid_options.label_grid = voxel::LabelGridType::kNone;
  const openvdb::GridPtrVec masks = progress.stage(
      "phase masks", n, [&] { return voxel::build_phase_grids(labels, grid_options); });
  labels = voxel::Volume();
  voxel::WallOptions wall_options;
  wall_options.layers = layers;
  const voxel::WallSweep sweep =
      progress.stage("wall sweep", n, [&] { return voxel::sweep_walls(masks, wall_options); });
  const voxel::ParticleEstimate counted =
      voxel::count_particles(stats.pore_voxels(), sweep.total(), voxel_rc, limits);
  progress.note(std::to_string(sweep.total()) + " wall voxels (" +
                std::to_string(sweep.surface_voxels) + " pore surface voxels); " + counted.str());
  check_limit(counted);

  record["parameters"] = {
      {"scale", scale.nm_per_rc > 0 ? nlohmann::json{{"nm_per_rc", scale.nm_per_rc}}
                                    : nlohmann::json{{"rc_per_voxel", scale.rc_per_voxel}}},
      {"thickness_rc", a.thickness_rc},
      {"max_particles", a.max_particles},
      {"fluid_density", limits.fluid_density},
      {"wall_density", limits.wall_density},
      {"bytes_per_particle", limits.bytes_per_particle}};
  record["definitions"] = {
      {"wall",
       "solid voxels (organic, inorganic) with a pore voxel (pore, organic_pore) within "
       "|dz| <= tz, |dy| <= ty, |dx| <= tx voxels, t = ceil(thickness / voxel edge in rc)"},
      {"particles",
       "N = rho_f V_pore + rho_w V_wall (volumes in rc^3); before the sweep V_wall "
       "~ voxel volume x sum over axes of (pore/solid faces x t); GPU memory = N x "
       "bytes_per_particle"}};
  record["shape_zyx"] = {stats.shape.nz, stats.shape.ny, stats.shape.nx};
  record["spacing_zyx"] = {spacing.dz, spacing.dy, spacing.dx};
  record["unit"] = spacing.unit;
  record["voxel_size_rc_zyx"] = voxel_rc;
  record["wall_layers_zyx"] = layers;
  record["pore_voxels"] = stats.pore_voxels();
  record["pore_surface_voxels"] = sweep.surface_voxels;
  nlohmann::json walls = nlohmann::json::object();
  const double voxel_volume = spacing.dz * spacing.dy * spacing.dx;
  const double voxel_rc3 = voxel_rc[0] * voxel_rc[1] * voxel_rc[2];
  for (voxel::Phase p : {voxel::Phase::kOrganic, voxel::Phase::kInorganic}) {
    const std::int64_t v = sweep.voxels[static_cast<std::size_t>(p)];
    if (stats.counts.voxels[static_cast<std::size_t>(p)] == 0) continue;
    walls[voxel::phase_name(p)] = {
        {"voxels", v}, {"volume", double(v) * voxel_volume}, {"volume_rc3", double(v) * voxel_rc3}};
  }
  record["walls"] = walls;
  record["wall_voxels"] = sweep.total();
  record["estimate_before_sweep"] = estimate_record(estimate);
  record["particles"] = estimate_record(counted);
  record["outputs"] = {"walls.vdb", "walls.json"};
  record["warnings"] = progress.warnings();

  const fs::path out(a.out);
  progress.stage("write " + a.out, 0, [&] {
    voxel::StagedOutputs staged = voxel::StagedOutputs::in_directory(out);
    const std::map<std::string, std::string> meta = {
        {"mesorock_version", kVersion}, {"git_commit", kGitCommit}, {"provenance", record.dump()}};
    voxel::write_vdb(staged.stage("walls.vdb"), sweep.walls, meta, (out / "walls.vdb").string());
    write_json(staged.stage("walls.json"), record, (out / "walls.json").string());
    staged.commit();
  });
  return 0;
}

}  // namespace

Command add_walls_command(CLI::App& rockprep) {
  auto args = std::make_shared<WallsArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "walls",
      "Surface-wall sweep: the solid voxels within a wall thickness of the pore space, per "
      "phase, as OpenVDB masks (DIR/walls.vdb) with counts and the particle estimate "
      "(DIR/walls.json); refuses when the estimate exceeds --max-particles");
  args->input.add_to(app);
  app->add_option("--nm-per-rc", args->nm_per_rc,
                  "Length scale: rc in nanometres (physical nanopores; needs a physical spacing)")
      ->check(positive_value());
  app->add_option("--rc-per-voxel", args->rc_per_voxel,
                  "Length scale: rc per voxel edge along x (scale-free Stokes regime)")
      ->check(positive_value());
  app->add_option("--thickness-rc", args->thickness_rc,
                  "Wall thickness in rc, at least the mDPD cutoff 1 (default 1)");
  app->add_option("--max-particles", args->max_particles,
                  "Refuse when the particle estimate exceeds this (default 50000000)");
  app->add_option("--density", args->density,
                  "Particles per rc^3 in the pore space (default 6.88, the mDPD water model)");
  app->add_option("--wall-density", args->wall_density,
                  "Particles per rc^3 in the wall shell (default: --density)");
  app->add_option("--out", args->out, "Output folder")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_walls(*args); }};
}

}  // namespace mesorock::pipeline::prep
