// rockprep run: the whole chain from an image stack (or phase labels) to a ready-to-run set-up:
// segment (when given a grey stack), crop, wall sweep, tiles, packing, scene. Two layouts: the
// 2020 paper's flooding set-up (packing/flooding.h, the default) and a periodic block for
// permeability sweeps (packing/permeability.h, --layout permeability).
//
//   DIR/particles.h5 + particles.xmf   the particle set (docs/scene.md layout), open in ParaView
//   DIR/solid.h5                        the solid's voxels (the solver keeps fluid out of them)
//   DIR/scene.toml                      `rockflow run DIR/scene.toml --out OUT` runs it as is
//   DIR/tiles.h5                        the tile sets used (a tile database)
//   DIR/run.json                        provenance, parameters, counts, timings, memory
//   DIR/particles.data                  with --lammps: the same particles as a LAMMPS data file
#include <omp.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <sstream>

#include "mesorock/atomic_file.h"
#include "mesorock/cache.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "packing/flooding.h"
#include "packing/pack.h"
#include "packing/permeability.h"
#include "packing/sink.h"
#include "pipeline/cli_checks.h"
#include "pipeline/prep/common.h"
#include "pipeline/prep/flooding_scene.h"
#include "pipeline/prep/packing_common.h"
#include "pipeline/prep/stokes_regime.h"
#include "sim/particle_io.h"
#include "sim/solid_grid.h"
#include "voxel/local_thickness.h"
#include "voxel/roi.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"
#include "voxel/walls.h"

namespace fs = std::filesystem;

namespace mesorock::pipeline::prep {
namespace {

// The block's pore sizes in voxels (along x): local thickness by pore volume, and the critical
// diameter along the flow axis (the largest sphere that passes through; voxel/local_thickness.h).
struct PoreSizes {
  bool available = false;
  double d10_voxels = 0, median_voxels = 0, mean_voxels = 0, max_voxels = 0;
  double critical_voxels = 0;
};

PoreSizes pore_sizes_of(const voxel::Volume& labels, int flow_axis, Progress& progress,
                        const std::string& name) {
  PoreSizes p;
  try {
    p.critical_voxels =
        progress.stage("critical pore diameter along the flow axis", labels.voxels(),
                       [&] { return voxel::critical_pore_diameter(labels, 2 - flow_axis); }) /
        labels.spacing().dx;
    const voxel::Volume thickness = progress.stage("pore sizes (local thickness)", labels.voxels(),
                                                   [&] { return voxel::local_thickness(labels); });
    const voxel::SizeDistribution d = voxel::size_distribution(thickness, labels);
    if (d.pore_voxels == 0) return p;
    const double unit = labels.spacing().dx;  // thickness unit per voxel along x
    // The 10% point of the pore volume, interpolated in its bin like the median.
    double below = 0, d10 = d.edges.back();
    for (std::size_t b = 0; b < d.volume_fraction.size(); ++b) {
      if (below + d.volume_fraction[b] >= 0.1) {
        const double f = d.volume_fraction[b] > 0 ? (0.1 - below) / d.volume_fraction[b] : 0;
        d10 = d.edges[b] + f * (d.edges[b + 1] - d.edges[b]);
        break;
      }
      below += d.volume_fraction[b];
    }
    p.available = true;
    p.d10_voxels = d10 / unit;
    p.median_voxels = d.median / unit;
    p.mean_voxels = d.mean / unit;
    p.max_voxels = d.max / unit;
  } catch (const ConfigError& e) {
    progress.warn(name + ": pore sizes: " + e.what());
  }
  return p;
}

struct RunArgs {
  LabelInputArgs input;
  FilterArgs filters;
  std::string thresholds;
  int otsu = 0;
  std::string phases;
  std::string crop;
  double nm_per_rc = 0;
  double rc_per_voxel = 0;
  std::string flow_axis = "x";
  double wall_thickness_rc = 1.0;
  bool all_pores = false;
  int connectivity = 6;
  double inlet_rc = 4, outlet_rc = 4, slab_rc = 1.0, room_rc = -1;
  std::string wall_fill = "tiles", fluid_fill = "tiles", slab_fill = "tiles";
  double wall_density = 8.0, fluid_density = 6.5;
  std::string tiles_db;
  std::string tile_cache = default_cache_dir("tiles").string();  // "none": no cache
  TileGenerationArgs generation;
  // Pair sets (the wall tiles are equilibrated with the wall-wall one, the fluid tiles with the
  // fluid-fluid one).
  // NaN: the layout's default (flooding: -30 organic, -40 inorganic, the wetting of the contact
  // angle case; permeability: kNoSlipWallA for both, the no-slip plane on the voxel faces).
  double a_fluid = -40, a_organic = std::nan(""), a_inorganic = std::nan(""), a_wall = -40;
  double B = 25, gamma = 4.5, rd = 0.75, kBT = 1.0;
  std::string density_kernel = "warren";
  double back_pressure = -1, pressure_drop = 50;
  std::uint64_t relax_steps = 100, settle_steps = 200, flood_steps = 2000;
  double dt = 0.01;
  std::uint64_t thermo_every = 50, region_every = 50, snapshot_every = 0;
  std::uint64_t seed = 1;
  std::int64_t max_particles = 50'000'000;
  bool lammps = false;
  std::string out;
  bool quiet = false;
  // --layout permeability: the block (mirrored along the flow axis unless --no-mirror) in a
  // periodic box, one fluid type driven by a body force.
  std::string layout = "flooding";
  bool no_mirror = false;
  double body_force = 0.02;
  std::uint64_t flow_steps = 2000;
  // Options of one layout only, when given: an error with the other layout.
  std::vector<const CLI::Option*> flooding_only, permeability_only;
};

// The first option of `options` given on the command line, or "".
std::string first_given(const std::vector<const CLI::Option*>& options) {
  for (const CLI::Option* o : options)
    if (o->count() > 0) return o->get_name();
  return "";
}

std::string gib(double bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return b;
}

// Grey stack -> labels by --otsu/--thresholds, or phase labels as they are.
voxel::Volume labels_of(const RunArgs& a, Progress& progress, nlohmann::json* record) {
  if (a.otsu == 0 && a.thresholds.empty()) {
    if (a.filters.any())
      throw ConfigError("run: filters need a grey stack (--otsu or --thresholds)");
    return load_labels(a.input, progress, record);
  }
  if (a.otsu > 0 && !a.thresholds.empty())
    throw ConfigError("run: give --otsu or --thresholds, not both");
  if (!a.input.labels.empty())
    throw ConfigError(
        "run: --labels is for labelled volumes; --otsu/--thresholds segment grey ones");
  std::vector<double> thresholds =
      a.thresholds.empty() ? std::vector<double>{} : parse_numbers(a.thresholds, "--thresholds");
  const int classes = a.otsu > 0 ? a.otsu : static_cast<int>(thresholds.size()) + 1;
  std::vector<voxel::Phase> phases;
  if (a.phases.empty()) {
    phases = voxel::default_class_phases(classes);
  } else {
    for (const std::string& n : voxel::split(a.phases, ','))
      phases.push_back(voxel::parse_phase(n));
    if (static_cast<int>(phases.size()) != classes)
      throw ConfigError("--phases names " + std::to_string(phases.size()) + " phases for " +
                        std::to_string(classes) + " classes");
  }
  voxel::ReadReport report;
  voxel::Volume grey = load_input(a.input.input, progress, &report);
  *record = input_record(a.input.input, grey, report);
  const voxel::Spacing spacing = grey.spacing();
  const std::int64_t n = grey.voxels();
  std::optional<voxel::FieldOfView> fov;
  (*record)["filters"] = about_file(a.input.input.path,
                                    [&] { return apply_filters(a.filters, grey, progress, &fov); });
  voxel::Exclusion exclusion;
  exclusion.field_of_view = fov;
  if (a.otsu > 0) {
    const voxel::Histogram h = progress.stage("histogram", n, [&] {
      return about_file(a.input.input.path, [&] { return voxel::histogram_of(grey, exclusion); });
    });
    thresholds =
        about_file(a.input.input.path, [&] { return voxel::multi_otsu_thresholds(h, a.otsu); });
  }
  std::ostringstream s;
  s << "thresholds";
  for (double t : thresholds) s << " " << t;
  progress.note(s.str());
  (*record)["segmentation"] = {{"method", a.otsu > 0 ? "multi-otsu" : "thresholds"},
                               {"thresholds", thresholds}};
  voxel::ThresholdSegmentation seg{thresholds, phases, exclusion};
  voxel::Volume labels = progress.stage("label by thresholds", n, [&] {
    return about_file(a.input.input.path,
                      [&] { return voxel::segment_by_thresholds(std::move(grey), seg); });
  });
  labels.set_spacing(spacing);
  return labels;
}

int run_run(const RunArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  // Everything the user typed is checked before the load.
  if (a.nm_per_rc > 0 && a.rc_per_voxel > 0)
    throw ConfigError(
        "run: the length scale is explicit: give one of --nm-per-rc X (physical nanopores) or "
        "--rc-per-voxel Y, or neither (the rc per voxel is then chosen from the pore sizes)");
  if (a.nm_per_rc < 0 || a.rc_per_voxel < 0)
    throw ConfigError("run: --nm-per-rc and --rc-per-voxel must be positive");
  voxel::LengthScale scale;
  scale.nm_per_rc = a.nm_per_rc;
  scale.rc_per_voxel = a.rc_per_voxel;
  const int flow_axis = a.flow_axis == "x" ? 0 : a.flow_axis == "y" ? 1 : 2;
  const packing::Fill wall_fill = packing::parse_fill(a.wall_fill);
  const packing::Fill fluid_fill = packing::parse_fill(a.fluid_fill);
  const packing::Fill slab_fill = packing::parse_fill(a.slab_fill);
  if (wall_fill == packing::Fill::Random || slab_fill == packing::Fill::Random)
    throw ConfigError("run: walls and slabs are packed from tiles or a lattice, not at random");
  if (fluid_fill == packing::Fill::Lattice)
    throw ConfigError("run: fluid is packed from tiles or at random, not on a lattice");
  if (!(a.wall_density > 0) || !(a.fluid_density > 0))
    throw ConfigError("run: --wall-density and --fluid-density must be positive");
  if (a.max_particles < 1) throw ConfigError("run: --max-particles must be positive");
  if (!(a.dt > 0) || a.dt > 0.1) throw ConfigError("run: --dt must be in (0, 0.1]");
  if (a.pressure_drop < 0) throw ConfigError("run: --pressure-drop must be >= 0");
  const bool permeability = a.layout == "permeability";
  const double a_organic =
      std::isnan(a.a_organic) ? (permeability ? kNoSlipWallA : -30.0) : a.a_organic;
  const double a_inorganic =
      std::isnan(a.a_inorganic) ? (permeability ? kNoSlipWallA : -40.0) : a.a_inorganic;
  if (!std::isfinite(a_organic) || !std::isfinite(a_inorganic))
    throw ConfigError("run: --a-organic and --a-inorganic must be finite");
  if (permeability) {
    const std::string o = first_given(a.flooding_only);
    if (!o.empty()) throw ConfigError("run: " + o + " belongs to --layout flooding");
    if (!std::isfinite(a.body_force) || !(a.body_force > 0))
      throw ConfigError("run: --body-force must be a positive number");
  } else {
    const std::string o = first_given(a.permeability_only);
    if (!o.empty()) throw ConfigError("run: " + o + " belongs to --layout permeability");
  }
  check_output_folder(a.out);
  std::optional<voxel::VoxelBox> crop;
  if (!a.crop.empty()) crop = voxel::parse_voxel_box(a.crop, "--crop");
  tiledb::TileDatabase db;
  if (!a.tiles_db.empty() && fs::exists(a.tiles_db)) db = tiledb::read_tile_database(a.tiles_db);

  if (a.generation.threads > 0) omp_set_num_threads(a.generation.threads);
  Progress progress(a.quiet);
  auto say = [&](const std::string& line) { progress.note(line); };
  nlohmann::json record = provenance("run");
  nlohmann::json input;
  voxel::Volume labels = labels_of(a, progress, &input);
  record["input"] = input;
  const std::string& name = a.input.input.path;
  if (crop) {
    about_file(name, [&] { voxel::check_box(*crop, labels.shape()); });
    labels = progress.stage("crop " + crop->str(), crop->shape().voxels(),
                            [&] { return voxel::crop(labels, *crop); });
  }
  const voxel::Shape shape = labels.shape();
  // A sample without solid has no permeability (its driven fluid would accelerate without bound):
  // refused before any work.
  if (permeability) {
    const voxel::PhaseCounts counts = voxel::count_phases(labels);
    if (counts.voxels[2] + counts.voxels[3] == 0)
      throw ConfigError(name +
                        ": permeability layout: the block has no solid voxel, and a sample "
                        "without solid has no permeability");
  }
  // Pore sizes and, without a length scale, the rc per voxel that resolves the throats
  // (pipeline/prep/stokes_regime.h).
  const PoreSizes sizes = pore_sizes_of(labels, flow_axis, progress, name);
  if (a.nm_per_rc == 0 && a.rc_per_voxel == 0) {
    scale.rc_per_voxel = auto_rc_per_voxel(sizes.critical_voxels);
    std::ostringstream s;
    s.precision(3);
    s << "no length scale given: " << scale.rc_per_voxel
      << " rc per voxel, so the critical pore diameter along " << a.flow_axis << " ("
      << sizes.critical_voxels << " voxels) is " << sizes.critical_voxels * scale.rc_per_voxel
      << " rc (at least " << kResolvedThroatRc << " rc: docs/accuracy.md, resolution on real rock)";
    progress.note(s.str());
  }
  const double rc_per_voxel = scale.rc_per_voxel;
  const std::array<double, 3> voxel_zyx =
      about_file(name, [&] { return voxel::voxel_size_rc(scale, labels.spacing()); });
  const std::array<double, 3> voxel_rc{voxel_zyx[2], voxel_zyx[1], voxel_zyx[0]};
  double nm_per_rc = a.nm_per_rc;
  if (nm_per_rc == 0 && labels.spacing().known())
    nm_per_rc = voxel::nanometres_per(labels.spacing().unit) * labels.spacing().dx / rc_per_voxel;
  {
    std::ostringstream s;
    s.precision(4);
    s << "block " << shape.str() << " voxels of " << voxel_rc[2] << " x " << voxel_rc[1] << " x "
      << voxel_rc[0] << " rc (z, y, x), scale " << scale.str() << "; flow along " << a.flow_axis;
    if (permeability)
      s << "; permeability layout, periodic"
        << (a.no_mirror ? "" : ", mirrored along the flow axis");
    progress.note(s.str());
  }
  // Layout: connected pores, wall sweep, and the reservoirs and slabs (flooding) or the mirror
  // image and periodic box (permeability).
  packing::FloodingOptions fo;
  fo.flow_axis = flow_axis;
  fo.voxel_rc = voxel_rc;
  fo.wall_thickness_rc = a.wall_thickness_rc;
  fo.connected_only = !a.all_pores;
  fo.connectivity = a.connectivity;
  fo.inlet_rc = a.inlet_rc;
  fo.outlet_rc = a.outlet_rc;
  fo.slab_rc = a.slab_rc;
  fo.room_rc = a.room_rc;
  const std::int64_t nblock = shape.voxels();
  packing::FloodingLayout flooding;
  packing::PermeabilityLayout periodic;
  packing::VoxelLayout& layout =
      permeability ? static_cast<packing::VoxelLayout&>(periodic) : flooding;
  if (permeability) {
    packing::PermeabilityOptions po;
    po.flow_axis = flow_axis;
    po.voxel_rc = voxel_rc;
    po.wall_thickness_rc = a.wall_thickness_rc;
    po.connected_only = !a.all_pores;
    po.connectivity = a.connectivity;
    po.mirror = !a.no_mirror;
    periodic = progress.stage("pore clusters, wall sweep, periodic layout", nblock, [&] {
      return about_file(name,
                        [&] { return packing::build_permeability_layout(std::move(labels), po); });
    });
  } else {
    flooding = progress.stage("pore clusters, wall sweep, layout", nblock, [&] {
      return about_file(name,
                        [&] { return packing::build_flooding_layout(std::move(labels), fo); });
    });
  }
  if (fo.connected_only) {
    progress.note(std::to_string(layout.spanning_clusters) + " of " +
                  std::to_string(layout.clusters) +
                  (permeability ? " pore clusters join the block's faces along " + a.flow_axis
                                : std::string(" pore clusters join the inlet and outlet")) +
                  "; " + std::to_string(layout.pore_voxels_dropped) +
                  " pore voxels of the others become solid");
  }
  const auto& rv = layout.role_voxels;
  progress.note(std::to_string(layout.pore_voxels) + " pore voxels, " +
                std::to_string(rv[packing::kRoleOrganicWall] + rv[packing::kRoleInorganicWall]) +
                " wall voxels (organic " + std::to_string(rv[packing::kRoleOrganicWall]) +
                ", inorganic " + std::to_string(rv[packing::kRoleInorganicWall]) + ") of " +
                std::to_string(layout.solid_voxels) + " solid" +
                (permeability ? " (pore and solid in the block, walls in the box; " +
                                    std::to_string(rv[packing::kRoleBlockFluid]) +
                                    " fluid voxels in the box)"
                              : std::string()));

  if (sizes.available) {
    const double rc = voxel_rc[0];  // rc per voxel edge (local thickness is in voxels along x)
    std::ostringstream s;
    s.precision(3);
    s << "pore sizes (local thickness by pore volume): d10 " << sizes.d10_voxels * rc << ", median "
      << sizes.median_voxels * rc << ", mean " << sizes.mean_voxels * rc << ", max "
      << sizes.max_voxels * rc << " rc; critical diameter along " << a.flow_axis << " "
      << sizes.critical_voxels * rc << " rc (the largest sphere that passes through)";
    progress.note(s.str());
    // Only a permeability measurement has a resolution to meet (docs/accuracy.md).
    if (permeability && sizes.critical_voxels * rc < kResolvedThroatRc) {
      std::ostringstream w;
      w.precision(3);
      w << "the throats that control the flow are " << sizes.critical_voxels * rc
        << " rc across (critical pore diameter along " << a.flow_axis << "), below the "
        << kResolvedThroatRc
        << " rc at which the resolution study found the permeability within 10% of a "
           "continuum solution (docs/accuracy.md): use --rc-per-voxel "
        << auto_rc_per_voxel(sizes.critical_voxels) << " or more";
      progress.warn(w.str());
    }
    record["pore_sizes"] = {{"method",
                             "local thickness by pore volume of the block; critical diameter: the "
                             "largest sphere whose centres connect the faces along the flow axis"},
                            {"d10_rc", sizes.d10_voxels * rc},
                            {"median_rc", sizes.median_voxels * rc},
                            {"mean_rc", sizes.mean_voxels * rc},
                            {"max_rc", sizes.max_voxels * rc},
                            {"critical_rc", sizes.critical_voxels * rc},
                            {"resolved_critical_rc", kResolvedThroatRc}};
  }

  // Tiles.
  tiledb::TileKey wall_key;
  wall_key.role = tiledb::TileRole::Wall;
  wall_key.density = a.wall_density;
  wall_key.edge = voxel_rc;
  wall_key.A = a.a_wall;
  wall_key.B = a.B;
  wall_key.rd = a.rd;
  wall_key.gamma = a.gamma;
  wall_key.kBT = a.kBT;
  wall_key.density_kernel =
      a.density_kernel == "lucy" ? sim::DensityKernelKind::Lucy : sim::DensityKernelKind::Warren;
  tiledb::TileKey fluid_key;
  fluid_key.role = tiledb::TileRole::Fluid;
  fluid_key.density = a.fluid_density;
  fluid_key.edge = voxel_rc;
  fluid_key.A = a.a_fluid;
  fluid_key.B = a.B;
  fluid_key.rd = a.rd;
  fluid_key.gamma = a.gamma;
  fluid_key.kBT = a.kBT;
  fluid_key.density_kernel = wall_key.density_kernel;
  const tiledb::TileSet* wall_tiles = nullptr;
  const tiledb::TileSet* fluid_tiles = nullptr;
  bool built_any = false;
  const std::size_t sets_before = db.sets.size();
  // Sets missing from --tiles come from the shared cache when there is one (a second run with
  // the same fluid builds nothing); the cache is not used when --tiles names the database.
  const fs::path cache_dir =
      a.tiles_db.empty() && a.tile_cache != "none" ? fs::path(a.tile_cache) : fs::path();
  nlohmann::json tile_sources = nlohmann::json::object();
  auto tiles_for = [&](const char* what, const tiledb::TileKey& key) {
    TileSource source = TileSource::Built;
    progress.stage(std::string(what) + " tiles", 0, [&] {
      find_or_build_tiles(db, key, a.generation, record.dump(), say, &source, cache_dir);
    });
    built_any = built_any || source == TileSource::Built;
    tile_sources[what] = to_string(source);
  };
  if (wall_fill == packing::Fill::Tiles || (!permeability && slab_fill == packing::Fill::Tiles))
    tiles_for("wall", wall_key);
  if (fluid_fill == packing::Fill::Tiles) tiles_for("fluid", fluid_key);
  // Pointers only now: building a set may have grown the vector.
  wall_tiles = db.find(wall_key);
  fluid_tiles = db.find(fluid_key);

  // Types and roles.
  // The permeability layout has one fluid type; its pores are the flooding layout's block-fluid
  // role, and the reservoir and slab roles have no voxels.
  std::vector<std::string> types = permeability ? std::vector<std::string>{"fluid"}
                                                : std::vector<std::string>{"source", "working"};
  auto type_of = [&](const std::string& t) {
    for (std::size_t i = 0; i < types.size(); ++i)
      if (types[i] == t) return static_cast<std::int32_t>(i);
    types.push_back(t);
    return static_cast<std::int32_t>(types.size() - 1);
  };
  std::vector<packing::RoleSpec> roles(packing::kFloodingRoles);
  auto fluid_role = [&](int code, const std::string& type) {
    packing::RoleSpec& r = roles[static_cast<std::size_t>(code - 1)];
    r.name = packing::flooding_role_name(code);
    r.type = type_of(type);
    r.fill = fluid_fill;
    r.density = a.fluid_density;
    r.tiles = fluid_tiles;
    r.thermal = true;
    r.kBT = a.kBT;
  };
  auto solid_role = [&](int code, const std::string& type, packing::Fill fill) {
    packing::RoleSpec& r = roles[static_cast<std::size_t>(code - 1)];
    r.name = packing::flooding_role_name(code);
    r.type = layout.has_role(code) ? type_of(type) : 0;
    // A role the layout lacks (the permeability layout's slabs) packs nothing and needs no tiles:
    // with tiles it stopped `--wall-fill lattice --fluid-fill random` ("no tiles").
    r.fill = layout.has_role(code) ? fill : packing::Fill::Lattice;
    r.density = a.wall_density;
    r.tiles = wall_tiles;
    r.thermal = false;
  };
  fluid_role(packing::kRoleBlockFluid, permeability ? "fluid" : "source");
  fluid_role(packing::kRoleInletFluid, permeability ? "fluid" : "working");
  fluid_role(packing::kRoleOutletFluid, permeability ? "fluid" : "source");
  if (permeability)
    roles[static_cast<std::size_t>(packing::kRoleBlockFluid) - 1].name = "fluid in the pores";
  solid_role(packing::kRoleOrganicWall, "organic_wall", wall_fill);
  solid_role(packing::kRoleInorganicWall, "inorganic_wall", wall_fill);
  solid_role(packing::kRolePushSlab, "push_slab", slab_fill);
  solid_role(packing::kRoleBackSlab, "back_slab", slab_fill);

  // The estimate before anything is written.
  const double voxel_volume = voxel_rc[0] * voxel_rc[1] * voxel_rc[2];
  double expected = 0;
  for (int c = 1; c <= packing::kFloodingRoles; ++c) {
    const packing::RoleSpec& r = roles[static_cast<std::size_t>(c - 1)];
    const double rho =
        r.fill == packing::Fill::Tiles && r.tiles ? r.tiles->stats.density : r.density;
    expected += static_cast<double>(rv[static_cast<std::size_t>(c)]) * voxel_volume * rho;
  }
  progress.note("estimate: " + std::to_string(static_cast<std::int64_t>(expected)) +
                " particles, " + gib(expected * packing::kParticleBytes) + " of particle arrays");
  if (expected > static_cast<double>(a.max_particles))
    throw LimitError(name + ": the set-up would hold about " +
                     std::to_string(static_cast<std::int64_t>(expected)) +
                     " particles, more than --max-particles " + std::to_string(a.max_particles));

  // Pack, streaming into the particle file (and the LAMMPS file).
  const fs::path out(a.out);
  voxel::StagedOutputs staged = voxel::StagedOutputs::in_directory(out);
  sim::ParticleFileMeta meta;
  meta.type_names = types;
  meta.box = layout.box;
  meta.created_by = "rockprep run";
  meta.length_unit = "rc";
  if (permeability) {
    // What rockflow sweep needs and the scene cannot say for a file block: the driven fluid's
    // density (its default n_f).
    meta.provenance_json = nlohmann::json{
        {"layout", "permeability"},
        {"fluid_types", {"fluid"}},
        {"fluid_density", a.fluid_density},
        {"flow_axis", a.flow_axis},
        {"mirrored",
         !a.no_mirror}}.dump();
  }
  packing::ParticleFileSink file_sink(staged.stage("particles.h5"), meta);
  std::unique_ptr<packing::LammpsDataSink> lammps;
  std::vector<packing::ParticleSink*> sinks{&file_sink};
  if (a.lammps) {
    lammps = std::make_unique<packing::LammpsDataSink>(staged.stage("particles.data"), types,
                                                       layout.box, "mesorock rockprep run");
    sinks.push_back(lammps.get());
  }
  packing::TeeSink tee(sinks);
  packing::PackOptions po;
  po.voxel_rc = voxel_rc;
  po.origin = layout.origin;
  po.seed = a.seed;
  po.progress = [&](double f) {
    char line[64];
    std::snprintf(line, sizeof line, "  packed %.0f%% of the layers", 100 * f);
    progress.note(line);
  };
  const packing::PackStats stats = progress.stage(
      "pack " + std::to_string(layout.codes.voxels()) + " voxels", layout.codes.voxels(),
      [&] { return packing::pack_voxels(layout.codes, roles, po, tee); });
  const std::int64_t ext_voxels = layout.codes.voxels();
  // The solid's voxels for the solver (grains stay dry whatever the wall particles do) and for
  // a continuum reference on the identical geometry (rockflow lbm).
  sim::SolidMask solid = permeability
                             ? packing::solid_mask_of(layout, -1e300, 1e300)
                             : packing::solid_mask_of(layout, flooding.block_lo, flooding.block_hi);
  solid.nm_per_rc = nm_per_rc;
  layout.codes = voxel::Volume();

  std::vector<std::int64_t> per_type(types.size(), 0);
  nlohmann::json role_table = nlohmann::json::array();
  for (int c = 1; c <= packing::kFloodingRoles; ++c) {
    const packing::RoleCount& k = stats.roles[static_cast<std::size_t>(c - 1)];
    const packing::RoleSpec& r = roles[static_cast<std::size_t>(c - 1)];
    if (k.voxels == 0) continue;
    per_type[static_cast<std::size_t>(r.type)] += k.particles;
    role_table.push_back({{"role", r.name},
                          {"type", types[static_cast<std::size_t>(r.type)]},
                          {"fill", packing::to_string(r.fill)},
                          {"voxels", k.voxels},
                          {"particles", k.particles},
                          {"expected", k.expected},
                          {"standard_deviation", std::sqrt(k.variance)}});
  }

  // Scene.
  PermeabilitySceneParams sp;
  sp.name =
      fs::path(a.out).filename().string().empty() ? a.layout : fs::path(a.out).filename().string();
  sp.seed = a.seed;
  sp.type_names = types;
  sp.a_fluid = a.a_fluid;
  sp.a_organic = a_organic;
  sp.a_inorganic = a_inorganic;
  sp.a_wall = a.a_wall;
  sp.B = a.B;
  sp.gamma = a.gamma;
  sp.rd = a.rd;
  sp.kBT = a.kBT;
  sp.density_kernel = a.density_kernel;
  sp.wall_density = wall_fill == packing::Fill::Tiles ? wall_tiles->stats.density : a.wall_density;
  sp.back_pressure = a.back_pressure >= 0 ? a.back_pressure
                                          : warren_pressure(a.fluid_density, a.a_fluid, a.B, a.rd);
  sp.push_pressure = sp.back_pressure + a.pressure_drop;
  sp.relax_steps = a.relax_steps;
  sp.settle_steps = a.settle_steps;
  sp.flood_steps = a.flood_steps;
  sp.dt = a.dt;
  sp.thermo_every = a.thermo_every;
  sp.region_every = a.region_every;
  sp.snapshot_every = a.snapshot_every;
  sp.nm_per_rc = nm_per_rc;
  sp.body_force = a.body_force;
  sp.flow_steps = a.flow_steps;
  if (permeability) {
    std::ostringstream c;
    c << "Permeability set-up written by rockprep run (mesorock " << kVersion << ", " << kGitCommit
      << "): the block" << (a.no_mirror ? "" : " and its mirror image along " + a.flow_axis)
      << " in a periodic box, the fluid driven by a body force along " << a.flow_axis
      << ".\nSweep it: rockflow sweep scene.toml --out OUT --forces 0.01,0.02,0.03,0.04 "
         "(docs/permeability.md); or rockflow run scene.toml --out OUT.\nSeed "
      << a.seed << "; provenance in run.json.";
    sp.comment = c.str();
  } else {
    std::ostringstream c;
    c << "Flooding set-up written by rockprep run (mesorock " << kVersion << ", " << kGitCommit
      << ").\nRun it: rockflow run scene.toml --out OUT (regions.csv, saturation.csv: the "
         "recovery curve).\nSeed "
      << a.seed << "; provenance in run.json.";
    sp.comment = c.str();
  }

  record["parameters"] = {
      {"scale", scale.nm_per_rc > 0 ? nlohmann::json{{"nm_per_rc", scale.nm_per_rc}}
                                    : nlohmann::json{{"rc_per_voxel", scale.rc_per_voxel}}},
      {"crop", a.crop},
      {"voxel_rc_zyx", {voxel_rc[2], voxel_rc[1], voxel_rc[0]}},
      {"layout", a.layout},
      {"flow_axis", a.flow_axis},
      {"wall_thickness_rc", a.wall_thickness_rc},
      {"connected_only", fo.connected_only},
      {"connectivity", a.connectivity},
      {"wall_fill", a.wall_fill},
      {"fluid_fill", a.fluid_fill},
      {"wall_density", a.wall_density},
      {"fluid_density", a.fluid_density},
      {"seed", a.seed},
      {"density_kernel", a.density_kernel},
      {"pairs",
       {{"a_fluid", a.a_fluid},
        {"a_organic", a_organic},
        {"a_inorganic", a_inorganic},
        {"a_wall", a.a_wall},
        {"B", a.B},
        {"gamma", a.gamma},
        {"rd", a.rd},
        {"kBT", a.kBT}}}};
  nlohmann::json& parameters = record["parameters"];
  if (permeability) {
    parameters["mirror"] = !a.no_mirror;
    parameters["body_force"] = a.body_force;
    parameters["stages"] = {{"relax", a.relax_steps}, {"flow", a.flow_steps}};
  } else {
    parameters["inlet_rc"] = a.inlet_rc;
    parameters["outlet_rc"] = a.outlet_rc;
    parameters["slab_rc"] = a.slab_rc;
    parameters["room_rc"] = a.room_rc;
    parameters["slab_fill"] = a.slab_fill;
    parameters["back_pressure"] = sp.back_pressure;
    parameters["push_pressure"] = sp.push_pressure;
    parameters["stages"] = {
        {"relax", a.relax_steps}, {"settle", a.settle_steps}, {"flood", a.flood_steps}};
  }
  nlohmann::json tiles_used = nlohmann::json::array();
  for (const tiledb::TileSet* s : {wall_tiles, fluid_tiles})
    if (s)
      tiles_used.push_back({{"key", s->key.str()},
                            {"tiles", s->tiles()},
                            {"measured_density", s->stats.density},
                            {"temperature", s->stats.temperature},
                            {"seed", s->build.seed}});
  record["tiles"] = {{"database", a.tiles_db.empty() ? "(built here)" : a.tiles_db},
                     {"cache", cache_dir.empty() ? "none" : cache_dir.string()},
                     {"copy", "tiles.h5"},
                     {"sets", tiles_used},
                     {"source", tile_sources},
                     {"built_here", built_any}};
  const std::array<double, 3> box_lo = layout.box.lo, box_hi = layout.box.hi;
  if (permeability) {
    const std::array<double, 3> block_hi = periodic.block_extent;
    record["layout"] = {{"kind", "permeability"},
                        {"box_lo", box_lo},
                        {"box_hi", box_hi},
                        {"periodic", {true, true, true}},
                        {"block_lo", std::array<double, 3>{0, 0, 0}},
                        {"block_hi", block_hi},
                        {"mirrored", periodic.mirrored},
                        {"wall_layers_zyx", layout.wall_layers_zyx}};
  } else {
    record["layout"] = {{"kind", "flooding"},
                        {"box_lo", box_lo},
                        {"box_hi", box_hi},
                        {"block", {flooding.block_lo, flooding.block_hi}},
                        {"push_slab", {flooding.push_lo, flooding.push_hi}},
                        {"inlet_reservoir", {flooding.inlet_lo, flooding.block_lo}},
                        {"outlet_reservoir", {flooding.block_hi, flooding.outlet_hi}},
                        {"back_slab", {flooding.back_lo, flooding.back_hi}},
                        {"wall_layers_zyx", layout.wall_layers_zyx}};
  }
  record["voxels"] = {{"block", layout.block_voxels},
                      {permeability ? "box" : "extended", ext_voxels},
                      {"pore", layout.pore_voxels},
                      {"pore_dropped", layout.pore_voxels_dropped},
                      {"solid", layout.solid_voxels},
                      {"wall_organic", rv[packing::kRoleOrganicWall]},
                      {"wall_inorganic", rv[packing::kRoleInorganicWall]},
                      {"clusters", layout.clusters},
                      {"spanning_clusters", layout.spanning_clusters}};
  if (permeability) record["voxels"]["fluid_in_box"] = rv[packing::kRoleBlockFluid];
  nlohmann::json by_type = nlohmann::json::object();
  for (std::size_t t = 0; t < types.size(); ++t) by_type[types[t]] = per_type[t];
  record["particles"] = {{"total", stats.particles}, {"by_type", by_type}, {"by_role", role_table}};

  progress.stage("write " + a.out, 0, [&] {
    file_sink.commit();
    if (lammps) lammps->commit();
    sim::write_particle_xdmf(staged.stage("particles.xmf"),
                             staged.final_path("particles.xmf").parent_path() / "particles.h5",
                             static_cast<std::size_t>(stats.particles));
    sim::write_solid_file(staged.stage("solid.h5"), solid, "rockprep run",
                          nlohmann::json{{"layout", a.layout},
                                         {"input", record["input"]},
                                         {"crop", a.crop},
                                         {"flow_axis", a.flow_axis},
                                         {"mirrored", permeability && !a.no_mirror},
                                         {"solid", "wall voxels and the empty voxels of the block"}}
                              .dump());
    mesorock::write_text_atomically(
        staged.stage("scene.toml"),
        permeability ? permeability_scene_toml(periodic, sp) : flooding_scene_toml(flooding, sp));
    // The sets used, with the output (a few MB at most): the packing can be repeated from it.
    tiledb::TileDatabase used;
    for (const tiledb::TileSet* s : {wall_tiles, fluid_tiles})
      if (s) used.put(*s);
    tiledb::write_tile_database(staged.stage("tiles.h5"), used);
    if (!a.tiles_db.empty() && db.sets.size() > sets_before)
      tiledb::write_tile_database(a.tiles_db, db);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    record["memory"] = {{"peak_rss_bytes", peak_rss_bytes()},
                        {"particle_bytes", stats.particles * packing::kParticleBytes},
                        {"peak_pack_buffer_bytes", stats.peak_buffer_bytes}};
    record["seconds"] = {{"pack", stats.seconds}, {"total", seconds}};
    record["outputs"] =
        a.lammps ? nlohmann::json{"particles.h5", "particles.xmf", "particles.data", "solid.h5",
                                  "scene.toml",   "tiles.h5",      "run.json"}
                 : nlohmann::json{"particles.h5", "particles.xmf", "solid.h5",
                                  "scene.toml",   "tiles.h5",      "run.json"};
    record["warnings"] = progress.warnings();
    write_json(staged.stage("run.json"), record, (out / "run.json").string());
    staged.commit();
  });

  // Summary.
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ostringstream s;
  s << "summary: " << layout.block_voxels << " block voxels (" << ext_voxels
    << (permeability ? a.no_mirror ? " in the periodic box" : " in the periodic box, mirrored"
                     : " with reservoirs and slabs")
    << "), " << layout.pore_voxels << " pore, "
    << rv[packing::kRoleOrganicWall] + rv[packing::kRoleInorganicWall]
    << (permeability ? " wall in the box; " : " wall; ") << stats.particles << " particles:";
  for (std::size_t t = 0; t < types.size(); ++t) s << " " << types[t] << " " << per_type[t];
  s << "; particle arrays " << gib(static_cast<double>(stats.particles * packing::kParticleBytes))
    << ", peak memory " << gib(static_cast<double>(peak_rss_bytes())) << "; " << seconds << " s";
  if (!a.quiet) std::cout << "rockprep: " << s.str() << "\n";
  if (!a.quiet && permeability)
    std::cout << "rockprep: next: rockflow sweep " << (out / "scene.toml").string()
              << " --out OUT --forces 0.01,0.02,0.03,0.04\n";
  else if (!a.quiet)
    std::cout << "rockprep: next: rockflow run " << (out / "scene.toml").string() << " --out OUT\n";
  return 0;
}

}  // namespace

Command add_run_command(CLI::App& rockprep) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "run",
      "The whole chain from a stack to a flooding set-up (or, with --layout permeability, a "
      "periodic sample for rockflow sweep): segment (a grey stack with --otsu or --thresholds) "
      "or read phase labels, crop, sweep the surface walls, pack walls from the tile database "
      "and pores with fluid, add reservoirs and slabs; writes DIR/particles.h5 (+ .xmf), "
      "DIR/scene.toml for rockflow run, DIR/tiles.h5 and DIR/run.json");
  a->input.add_to(app);
  a->filters.add_to(app, false);
  app->add_option("--otsu", a->otsu, "Segment a grey stack into K classes by multi-Otsu");
  app->add_option("--thresholds", a->thresholds, "Segment a grey stack by thresholds T1,T2,...");
  app->add_option("--phases", a->phases,
                  "Phases of the classes, darkest first (default pore,organic,inorganic for 3)");
  app->add_option("--crop", a->crop, "Voxel box Z0:Z1,Y0:Y1,X0:X1 of the block");
  app->add_option("--nm-per-rc", a->nm_per_rc, "Length scale: rc in nm (needs a physical spacing)")
      ->check(positive_value());
  app->add_option("--rc-per-voxel", a->rc_per_voxel,
                  "Length scale: rc per voxel edge along x (without it or --nm-per-rc: chosen so "
                  "the critical pore diameter, the throats, is resolved, docs/accuracy.md)")
      ->check(positive_value());
  app->add_option("--flow-axis", a->flow_axis, "x (default), y or z")
      ->check(CLI::IsMember({"x", "y", "z"}));
  app->add_option("--layout", a->layout,
                  "flooding (default: the 2020 paper's set-up) or permeability (the block, "
                  "mirrored along the flow axis, in a periodic box; one fluid driven by a body "
                  "force, for rockflow sweep)")
      ->check(CLI::IsMember({"flooding", "permeability"}));
  a->permeability_only = {
      app->add_flag("--no-mirror", a->no_mirror,
                    "permeability: do not mirror the block along the flow axis (for a block "
                    "that is periodic already)"),
      app->add_option("--body-force", a->body_force,
                      "permeability: the fluid's body force along the flow axis (default 0.02)"),
      app->add_option("--flow-steps", a->flow_steps,
                      "permeability: scene's flow stage after the relax stage (default 2000)")};
  app->add_option("--wall-thickness-rc", a->wall_thickness_rc,
                  "Surface-wall thickness in rc, >= 1 (default 1)");
  app->add_flag("--all-pores", a->all_pores,
                "Fill every pore (default: only the clusters joining the inlet and outlet faces)");
  app->add_option("--connectivity", a->connectivity, "Pore clusters: 6 (default) or 26")
      ->check(CLI::IsMember({6, 26}));
  a->flooding_only.push_back(
      app->add_option("--inlet-rc", a->inlet_rc, "Working-fluid reservoir length, rc (default 4)"));
  a->flooding_only.push_back(app->add_option("--outlet-rc", a->outlet_rc,
                                             "Source-fluid reservoir length, rc (default 4)"));
  a->flooding_only.push_back(
      app->add_option("--slab-rc", a->slab_rc, "Slab thickness, rc (default 1)"));
  a->flooding_only.push_back(
      app->add_option("--room-rc", a->room_rc,
                      "Empty room behind the back slab, rc (default: the block's pore volume over "
                      "its cross-section, + 1)"));
  app->add_option("--wall-fill", a->wall_fill, "tiles (default) or lattice")
      ->check(CLI::IsMember({"tiles", "lattice"}));
  app->add_option("--fluid-fill", a->fluid_fill, "tiles (default) or random")
      ->check(CLI::IsMember({"tiles", "random"}));
  a->flooding_only.push_back(
      app->add_option("--slab-fill", a->slab_fill, "tiles (default) or lattice")
          ->check(CLI::IsMember({"tiles", "lattice"})));
  app->add_option("--wall-density", a->wall_density, "Wall particle density (default 8)");
  app->add_option("--fluid-density", a->fluid_density, "Fluid particle density (default 6.5)");
  app->add_option("--tiles", a->tiles_db,
                  "Tile database to draw from; missing sets are built and added to it (default: "
                  "build them, saved in DIR/tiles.h5)");
  app->add_option("--tile-cache", a->tile_cache,
                  "Folder of the shared tile cache, or none (without --tiles: sets found there "
                  "are not built again; new ones are saved there)")
      ->capture_default_str();
  a->generation.add_to(app, "tile-");
  app->add_option("--a-fluid", a->a_fluid, "Fluid-fluid (and fluid-slab) A (default -40)");
  app->add_option("--a-organic", a->a_organic,
                  "Fluid-organic wall A (default -30; permeability layout -18: the no-slip plane "
                  "on the voxel faces, docs/walls.md)");
  app->add_option("--a-inorganic", a->a_inorganic,
                  "Fluid-inorganic wall A (default -40; permeability layout -18)");
  app->add_option("--a-wall", a->a_wall,
                  "Wall-wall and slab A: the wall tiles are equilibrated with it (default -40)");
  app->add_option("--density-kernel", a->density_kernel, "warren (default) or lucy")
      ->check(CLI::IsMember({"warren", "lucy"}));
  app->add_option("--B", a->B, "Many-body repulsion B of every pair (default 25)");
  app->add_option("--gamma", a->gamma, "Dissipation gamma of every pair (default 4.5)");
  app->add_option("--rd", a->rd, "Many-body cutoff rd (default 0.75)");
  app->add_option("--kbt", a->kBT, "kBT (default 1)");
  a->flooding_only.push_back(
      app->add_option("--back-pressure", a->back_pressure,
                      "Back-pressure slab's pressure (default: Warren's mDPD pressure at the fluid "
                      "density)"));
  a->flooding_only.push_back(
      app->add_option("--pressure-drop", a->pressure_drop,
                      "Pushing slab's pressure above the back pressure (default 50)"));
  app->add_option("--relax-steps", a->relax_steps, "Scene: relax stage at dt 0.002 (default 100)");
  a->flooding_only.push_back(
      app->add_option("--settle-steps", a->settle_steps,
                      "Scene: settle stage behind the virtual walls (default 200)"));
  a->flooding_only.push_back(
      app->add_option("--flood-steps", a->flood_steps, "Scene: flood stage (default 2000)"));
  app->add_option("--dt", a->dt, "Scene: time step of settle and flood (default 0.01)");
  app->add_option("--thermo-every", a->thermo_every, "Scene: thermo rows every N steps (50)");
  app->add_option("--region-every", a->region_every, "Scene: region samples every N steps (50)");
  app->add_option("--snapshot-every", a->snapshot_every, "Scene: snapshots every N steps (0)");
  app->add_option("--seed", a->seed, "Seed of the packing and the scene (default 1)");
  app->add_option("--max-particles", a->max_particles,
                  "Refuse when the set-up would hold more (default 50000000)");
  app->add_flag("--lammps", a->lammps, "Also write DIR/particles.data (LAMMPS data file)");
  app->add_option("--out", a->out, "Output folder")->required();
  app->add_flag("--quiet", a->quiet, "No progress lines");
  return {app, [a] { return run_run(*a); }};
}

}  // namespace mesorock::pipeline::prep
