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
#include "mesorock/number_text.h"
#include "mesorock/output_lock.h"
#include "mesorock/version.h"
#include "packing/flooding.h"
#include "packing/pack.h"
#include "packing/permeability.h"
#include "packing/sink.h"
#include "pipeline/cli_checks.h"
#include "pipeline/flow/interrupt.h"
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
  double inlet_rc = 4, outlet_rc = 4, slab_rc = 2.0, room_rc = -1;
  // Slabs: a lattice, which holds the fluid back; fluid soaks into a slab of wall tiles and some
  // gets through (docs/packing.md).
  std::string wall_fill = "tiles", fluid_fill = "tiles", slab_fill = "lattice";
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
  // --body-force when given (body_force_option); otherwise the scene takes the top of the forces
  // suggested for rockflow sweep (g d^2 = 2.29 for the median pore): a fixed 0.02 barely showed a
  // flow at 0.5 rc per voxel (docs/permeability.md).
  double body_force = 0;
  const CLI::Option* body_force_option = nullptr;
  std::uint64_t flow_steps = 2000;
  // Options of one layout only, when given: an error with the other layout.
  std::vector<const CLI::Option*> flooding_only, permeability_only;
};

// Whether `o` was given on the command line.
bool given(const CLI::Option* o) {
  return o && o->count() > 0;
}
// The first option of `options` given on the command line, or "".
std::string first_given(const std::vector<const CLI::Option*>& options) {
  for (const CLI::Option* o : options)
    if (given(o)) return o->get_name();
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

// What the options decide before the load. Everything the user typed is checked here, so a
// mistake costs no loading time.
struct RunPlan {
  voxel::LengthScale scale;  // as given: none, or the rc per voxel, chosen after the load
  int flow_axis = 0;
  packing::Fill wall_fill = packing::Fill::Tiles, fluid_fill = packing::Fill::Tiles,
                slab_fill = packing::Fill::Tiles;
  bool permeability = false;
  double a_organic = 0, a_inorganic = 0;  // the layout's defaults where not given
  std::optional<voxel::VoxelBox> crop;
};

RunPlan plan_run(const RunArgs& a) {
  if (a.nm_per_rc > 0 && a.rc_per_voxel > 0)
    throw ConfigError(
        "run: the length scale is explicit: give one of --nm-per-rc X (physical nanopores) or "
        "--rc-per-voxel Y, or neither (the rc per voxel is then chosen from the pore sizes)");
  if (a.nm_per_rc < 0 || a.rc_per_voxel < 0)
    throw ConfigError("run: --nm-per-rc and --rc-per-voxel must be positive");
  RunPlan plan;
  plan.scale.nm_per_rc = a.nm_per_rc;
  plan.scale.rc_per_voxel = a.rc_per_voxel;
  plan.flow_axis = a.flow_axis == "x" ? 0 : a.flow_axis == "y" ? 1 : 2;
  plan.wall_fill = packing::parse_fill(a.wall_fill);
  plan.fluid_fill = packing::parse_fill(a.fluid_fill);
  plan.slab_fill = packing::parse_fill(a.slab_fill);
  if (plan.wall_fill == packing::Fill::Random || plan.slab_fill == packing::Fill::Random)
    throw ConfigError("run: walls and slabs are packed from tiles or a lattice, not at random");
  if (plan.fluid_fill == packing::Fill::Lattice)
    throw ConfigError("run: fluid is packed from tiles or at random, not on a lattice");
  if (!(a.wall_density > 0) || !(a.fluid_density > 0))
    throw ConfigError("run: --wall-density and --fluid-density must be positive");
  if (a.max_particles < 1) throw ConfigError("run: --max-particles must be positive");
  if (!(a.dt > 0) || a.dt > 0.1) throw ConfigError("run: --dt must be in (0, 0.1]");
  if (a.pressure_drop < 0) throw ConfigError("run: --pressure-drop must be >= 0");
  const bool permeability = a.layout == "permeability";
  plan.permeability = permeability;
  plan.a_organic = std::isnan(a.a_organic) ? (permeability ? kNoSlipWallA : -30.0) : a.a_organic;
  plan.a_inorganic =
      std::isnan(a.a_inorganic) ? (permeability ? kNoSlipWallA : -40.0) : a.a_inorganic;
  if (!std::isfinite(plan.a_organic) || !std::isfinite(plan.a_inorganic))
    throw ConfigError("run: --a-organic and --a-inorganic must be finite");
  if (permeability) {
    const std::string o = first_given(a.flooding_only);
    if (!o.empty()) throw ConfigError("run: " + o + " belongs to --layout flooding");
    if (given(a.body_force_option) && !(std::isfinite(a.body_force) && a.body_force > 0))
      throw ConfigError("run: --body-force must be a positive number");
  } else {
    const std::string o = first_given(a.permeability_only);
    if (!o.empty()) throw ConfigError("run: " + o + " belongs to --layout permeability");
  }
  check_output_folder(a.out);
  if (!a.crop.empty()) plan.crop = voxel::parse_voxel_box(a.crop, "--crop");
  return plan;
}

// What every step after the plan reads and reports to.
struct RunContext {
  const RunArgs& args;
  const RunPlan& plan;
  Progress& progress;
  nlohmann::json& record;  // run.json, filled in as the steps go
  std::chrono::steady_clock::time_point start;
  const std::string& name() const { return args.input.input.path; }  // for messages
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
};

// The block's labels: segmented or read (labels_of), cropped; a permeability block without
// solid is refused here, before any work on it.
voxel::Volume load_block(const RunContext& c) {
  nlohmann::json input;
  voxel::Volume labels = labels_of(c.args, c.progress, &input);
  c.record["input"] = input;
  const std::optional<voxel::VoxelBox>& crop = c.plan.crop;
  if (crop) {
    about_file(c.name(), [&] { voxel::check_box(*crop, labels.shape()); });
    labels = c.progress.stage("crop " + crop->str(), crop->shape().voxels(),
                              [&] { return voxel::crop(labels, *crop); });
  }
  // A sample without solid has no permeability (its driven fluid would accelerate without bound).
  if (c.plan.permeability) {
    const voxel::PhaseCounts counts = voxel::count_phases(labels);
    if (counts.voxels[2] + counts.voxels[3] == 0)
      throw ConfigError(c.name() +
                        ": permeability layout: the block has no solid voxel, and a sample "
                        "without solid has no permeability");
  }
  return labels;
}

// The block's size in rc: its pore sizes, the length scale (the rc per voxel chosen from them
// when none was given) and the voxel edges in rc.
struct BlockScale {
  voxel::LengthScale scale;
  PoreSizes sizes;
  std::array<double, 3> voxel_rc{};  // voxel edges in rc (x, y, z)
  double nm_per_rc = 0;              // 0: no physical size
};

BlockScale scale_block(const RunContext& c, const voxel::Volume& labels) {
  const RunArgs& a = c.args;
  BlockScale b;
  b.scale = c.plan.scale;
  // Pore sizes and, without a length scale, the rc per voxel that resolves the throats
  // (pipeline/prep/stokes_regime.h).
  b.sizes = pore_sizes_of(labels, c.plan.flow_axis, c.progress, c.name());
  if (a.nm_per_rc == 0 && a.rc_per_voxel == 0) {
    b.scale.rc_per_voxel = auto_rc_per_voxel(b.sizes.critical_voxels);
    std::ostringstream s;
    s.precision(3);
    s << "no length scale given: " << b.scale.rc_per_voxel
      << " rc per voxel, so the critical pore diameter along " << a.flow_axis << " ("
      << b.sizes.critical_voxels << " voxels) is " << b.sizes.critical_voxels * b.scale.rc_per_voxel
      << " rc (at least " << kResolvedThroatRc << " rc: docs/accuracy.md, resolution on real rock)";
    c.progress.note(s.str());
  }
  const std::array<double, 3> voxel_zyx =
      about_file(c.name(), [&] { return voxel::voxel_size_rc(b.scale, labels.spacing()); });
  b.voxel_rc = {voxel_zyx[2], voxel_zyx[1], voxel_zyx[0]};
  b.nm_per_rc = a.nm_per_rc;
  if (b.nm_per_rc == 0 && labels.spacing().known())
    b.nm_per_rc =
        voxel::nanometres_per(labels.spacing().unit) * labels.spacing().dx / b.scale.rc_per_voxel;
  std::ostringstream s;
  s.precision(4);
  s << "block " << labels.shape().str() << " voxels of " << b.voxel_rc[2] << " x " << b.voxel_rc[1]
    << " x " << b.voxel_rc[0] << " rc (z, y, x), scale " << b.scale.str() << "; flow along "
    << a.flow_axis;
  if (c.plan.permeability)
    s << "; permeability layout, periodic" << (a.no_mirror ? "" : ", mirrored along the flow axis");
  c.progress.note(s.str());
  return b;
}

// One of the two layouts, whichever --layout asks for; active() is the one in use.
struct RunLayout {
  bool permeability = false;
  packing::FloodingLayout flooding;
  packing::PermeabilityLayout periodic;
  packing::VoxelLayout& active() {
    return permeability ? static_cast<packing::VoxelLayout&>(periodic) : flooding;
  }
  const packing::VoxelLayout& active() const {
    return permeability ? static_cast<const packing::VoxelLayout&>(periodic) : flooding;
  }
};

// The options both layouts take alike: flow axis, voxel size, wall thickness, pore clusters.
template <class LayoutOptions>
LayoutOptions layout_options(const RunContext& c, const BlockScale& b) {
  LayoutOptions o;
  o.flow_axis = c.plan.flow_axis;
  o.voxel_rc = b.voxel_rc;
  o.wall_thickness_rc = c.args.wall_thickness_rc;
  o.connected_only = !c.args.all_pores;
  o.connectivity = c.args.connectivity;
  return o;
}

// Connected pores, wall sweep, and the reservoirs and slabs (flooding) or the mirror image and
// periodic box (permeability); progress lines say what became of the voxels.
RunLayout build_layout(const RunContext& c, const BlockScale& b, voxel::Volume labels) {
  const RunArgs& a = c.args;
  const bool permeability = c.plan.permeability;
  const std::int64_t nblock = labels.voxels();
  RunLayout l;
  l.permeability = permeability;
  if (permeability) {
    auto po = layout_options<packing::PermeabilityOptions>(c, b);
    po.mirror = !a.no_mirror;
    l.periodic = c.progress.stage("pore clusters, wall sweep, periodic layout", nblock, [&] {
      return about_file(c.name(),
                        [&] { return packing::build_permeability_layout(std::move(labels), po); });
    });
  } else {
    auto fo = layout_options<packing::FloodingOptions>(c, b);
    fo.inlet_rc = a.inlet_rc;
    fo.outlet_rc = a.outlet_rc;
    fo.slab_rc = a.slab_rc;
    fo.room_rc = a.room_rc;
    l.flooding = c.progress.stage("pore clusters, wall sweep, layout", nblock, [&] {
      return about_file(c.name(),
                        [&] { return packing::build_flooding_layout(std::move(labels), fo); });
    });
  }
  const packing::VoxelLayout& layout = l.active();
  if (!a.all_pores) {
    c.progress.note(std::to_string(layout.spanning_clusters) + " of " +
                    std::to_string(layout.clusters) +
                    (permeability ? " pore clusters join the block's faces along " + a.flow_axis
                                  : std::string(" pore clusters join the inlet and outlet")) +
                    "; " + std::to_string(layout.pore_voxels_dropped) +
                    " pore voxels of the others become solid");
  }
  const auto& rv = layout.role_voxels;
  c.progress.note(std::to_string(layout.pore_voxels) + " pore voxels, " +
                  std::to_string(rv[packing::kRoleOrganicWall] + rv[packing::kRoleInorganicWall]) +
                  " wall voxels (organic " + std::to_string(rv[packing::kRoleOrganicWall]) +
                  ", inorganic " + std::to_string(rv[packing::kRoleInorganicWall]) + ") of " +
                  std::to_string(layout.solid_voxels) + " solid" +
                  (permeability ? " (pore and solid in the block, walls in the box; " +
                                      std::to_string(rv[packing::kRoleBlockFluid]) +
                                      " fluid voxels in the box)"
                                : std::string()));
  return l;
}

// The pore sizes in rc: a progress line, the record's "pore_sizes", and for a permeability
// measurement a warning when the throats are not resolved (docs/accuracy.md).
void report_pore_sizes(const RunContext& c, const BlockScale& b) {
  const PoreSizes& sizes = b.sizes;
  if (!sizes.available) return;
  const std::string& axis = c.args.flow_axis;
  const double rc = b.voxel_rc[0];  // rc per voxel edge (local thickness is in voxels along x)
  std::ostringstream s;
  s.precision(3);
  s << "pore sizes (local thickness by pore volume): d10 " << sizes.d10_voxels * rc << ", median "
    << sizes.median_voxels * rc << ", mean " << sizes.mean_voxels * rc << ", max "
    << sizes.max_voxels * rc << " rc; critical diameter along " << axis << " "
    << sizes.critical_voxels * rc << " rc (the largest sphere that passes through)";
  c.progress.note(s.str());
  // Only a permeability measurement has a resolution to meet (docs/accuracy.md).
  if (c.plan.permeability && sizes.critical_voxels * rc < kResolvedThroatRc) {
    std::ostringstream w;
    w.precision(3);
    w << "the throats that control the flow are " << sizes.critical_voxels * rc
      << " rc across (critical pore diameter along " << axis << "), below the " << kResolvedThroatRc
      << " rc at which the resolution study found the permeability within 10% of a "
         "continuum solution (docs/accuracy.md): use --rc-per-voxel "
      << auto_rc_per_voxel(sizes.critical_voxels) << " or more";
    c.progress.warn(w.str());
  }
  c.record["pore_sizes"] = {{"method",
                             "local thickness by pore volume of the block; critical diameter: the "
                             "largest sphere whose centres connect the faces along the flow axis"},
                            {"d10_rc", sizes.d10_voxels * rc},
                            {"median_rc", sizes.median_voxels * rc},
                            {"mean_rc", sizes.mean_voxels * rc},
                            {"max_rc", sizes.max_voxels * rc},
                            {"critical_rc", sizes.critical_voxels * rc},
                            {"resolved_critical_rc", kResolvedThroatRc}};
}

// The tile sets the packing draws from, and where they came from.
struct RunTiles {
  tiledb::TileDatabase db;  // --tiles (when it exists), grown by the sets built here
  std::size_t sets_before = 0;
  fs::path cache_dir;  // empty: no cache
  const tiledb::TileSet* wall = nullptr;
  const tiledb::TileSet* fluid = nullptr;
  bool built_any = false;
  nlohmann::json sources = nlohmann::json::object();
};

// The wall and fluid sets the fills need: from --tiles, else the shared cache, else built (the
// record so far is their provenance).
void find_tile_sets(const RunContext& c, const BlockScale& b, RunTiles& t) {
  const RunArgs& a = c.args;
  tiledb::TileKey wall_key;
  wall_key.role = tiledb::TileRole::Wall;
  wall_key.density = a.wall_density;
  wall_key.edge = b.voxel_rc;
  wall_key.A = a.a_wall;
  wall_key.B = a.B;
  wall_key.rd = a.rd;
  wall_key.gamma = a.gamma;
  wall_key.kBT = a.kBT;
  wall_key.density_kernel =
      a.density_kernel == "lucy" ? sim::DensityKernelKind::Lucy : sim::DensityKernelKind::Warren;
  tiledb::TileKey fluid_key = wall_key;  // the same pair set but the fluid-fluid A
  fluid_key.role = tiledb::TileRole::Fluid;
  fluid_key.density = a.fluid_density;
  fluid_key.A = a.a_fluid;
  t.sets_before = t.db.sets.size();
  // Sets missing from --tiles come from the shared cache when there is one (a second run with
  // the same fluid builds nothing); the cache is not used when --tiles names the database.
  t.cache_dir = a.tiles_db.empty() && a.tile_cache != "none" ? fs::path(a.tile_cache) : fs::path();
  auto say = [&](const std::string& line) { c.progress.note(line); };
  auto tiles_for = [&](const char* what, const tiledb::TileKey& key) {
    TileSource source = TileSource::Built;
    c.progress.stage(std::string(what) + " tiles", 0, [&] {
      find_or_build_tiles(t.db, key, a.generation, c.record.dump(), say, &source, t.cache_dir);
    });
    t.built_any = t.built_any || source == TileSource::Built;
    t.sources[what] = to_string(source);
  };
  const RunPlan& p = c.plan;
  if (p.wall_fill == packing::Fill::Tiles ||
      (!p.permeability && p.slab_fill == packing::Fill::Tiles))
    tiles_for("wall", wall_key);
  if (p.fluid_fill == packing::Fill::Tiles) tiles_for("fluid", fluid_key);
  // Pointers only now: building a set may have grown the vector.
  t.wall = t.db.find(wall_key);
  t.fluid = t.db.find(fluid_key);
}

// The particle types and what each role of the layout is packed with.
struct ParticleRoles {
  std::vector<std::string> types;
  std::vector<packing::RoleSpec> roles;  // role code c at c - 1
};

ParticleRoles particle_roles(const RunContext& c, const RunLayout& l, const RunTiles& t) {
  const RunArgs& a = c.args;
  const bool permeability = c.plan.permeability;
  const packing::VoxelLayout& layout = l.active();
  ParticleRoles p;
  // The permeability layout has one fluid type; its pores are the flooding layout's block-fluid
  // role, and the reservoir and slab roles have no voxels.
  p.types = permeability ? std::vector<std::string>{"fluid"}
                         : std::vector<std::string>{"source", "working"};
  auto type_of = [&](const std::string& name) {
    for (std::size_t i = 0; i < p.types.size(); ++i)
      if (p.types[i] == name) return static_cast<std::int32_t>(i);
    p.types.push_back(name);
    return static_cast<std::int32_t>(p.types.size() - 1);
  };
  p.roles.resize(packing::kFloodingRoles);
  auto fluid_role = [&](int code, const std::string& type) {
    packing::RoleSpec& r = p.roles[static_cast<std::size_t>(code - 1)];
    r.name = packing::flooding_role_name(code);
    r.type = type_of(type);
    r.fill = c.plan.fluid_fill;
    r.density = a.fluid_density;
    r.tiles = t.fluid;
    r.thermal = true;
    r.kBT = a.kBT;
  };
  auto solid_role = [&](int code, const std::string& type, packing::Fill fill) {
    packing::RoleSpec& r = p.roles[static_cast<std::size_t>(code - 1)];
    r.name = packing::flooding_role_name(code);
    r.type = layout.has_role(code) ? type_of(type) : 0;
    // A role the layout lacks (the permeability layout's slabs) packs nothing and needs no tiles:
    // with tiles it stopped `--wall-fill lattice --fluid-fill random` ("no tiles").
    r.fill = layout.has_role(code) ? fill : packing::Fill::Lattice;
    r.density = a.wall_density;
    r.tiles = t.wall;
    r.thermal = false;
  };
  fluid_role(packing::kRoleBlockFluid, permeability ? "fluid" : "source");
  fluid_role(packing::kRoleInletFluid, permeability ? "fluid" : "working");
  fluid_role(packing::kRoleOutletFluid, permeability ? "fluid" : "source");
  if (permeability)
    p.roles[static_cast<std::size_t>(packing::kRoleBlockFluid) - 1].name = "fluid in the pores";
  solid_role(packing::kRoleOrganicWall, "organic_wall", c.plan.wall_fill);
  solid_role(packing::kRoleInorganicWall, "inorganic_wall", c.plan.wall_fill);
  solid_role(packing::kRolePushSlab, "push_slab", c.plan.slab_fill);
  solid_role(packing::kRoleBackSlab, "back_slab", c.plan.slab_fill);
  return p;
}

// The particle count expected from the densities, checked against --max-particles before
// anything is written.
void check_estimate(const RunContext& c, const BlockScale& b, const RunLayout& l,
                    const ParticleRoles& p) {
  const std::array<double, 3>& voxel_rc = b.voxel_rc;
  const double voxel_volume = voxel_rc[0] * voxel_rc[1] * voxel_rc[2];
  double expected = 0;
  for (int code = 1; code <= packing::kFloodingRoles; ++code) {
    const packing::RoleSpec& r = p.roles[static_cast<std::size_t>(code - 1)];
    const double rho =
        r.fill == packing::Fill::Tiles && r.tiles ? r.tiles->stats.density : r.density;
    expected += static_cast<double>(l.active().role_voxels[static_cast<std::size_t>(code)]) *
                voxel_volume * rho;
  }
  c.progress.note("estimate: " + std::to_string(static_cast<std::int64_t>(expected)) +
                  " particles, " + gib(expected * packing::kParticleBytes) + " of particle arrays");
  if (expected > static_cast<double>(c.args.max_particles))
    throw LimitError(c.name() + ": the set-up would hold about " +
                     std::to_string(static_cast<std::int64_t>(expected)) +
                     " particles, more than --max-particles " +
                     std::to_string(c.args.max_particles));
}

// The output folder while it is written: its staged files and the particle sinks the packing
// streams into (committed with the rest by write_outputs).
struct RunOutputs {
  voxel::StagedOutputs staged;
  std::unique_ptr<packing::ParticleFileSink> particles;
  std::unique_ptr<packing::LammpsDataSink> lammps;  // with --lammps
};

RunOutputs open_outputs(const RunContext& c, const RunLayout& l, const ParticleRoles& p) {
  const RunArgs& a = c.args;
  RunOutputs o{voxel::StagedOutputs::in_directory(fs::path(a.out)), nullptr, nullptr};
  sim::ParticleFileMeta meta;
  meta.type_names = p.types;
  meta.box = l.active().box;
  meta.created_by = "rockprep run";
  meta.length_unit = "rc";
  if (c.plan.permeability) {
    // What rockflow sweep needs and the scene cannot say for a file block: the driven fluid's
    // density (its default n_f).
    nlohmann::json provenance = {{"layout", "permeability"},
                                 {"fluid_types", {"fluid"}},
                                 {"fluid_density", a.fluid_density},
                                 {"flow_axis", a.flow_axis},
                                 {"mirrored", !a.no_mirror}};
    // And the pore sizes, from which rockflow sweep sets its default warm-up.
    if (c.record.contains("pore_sizes")) provenance["pore_sizes"] = c.record["pore_sizes"];
    meta.provenance_json = provenance.dump();
  }
  o.particles = std::make_unique<packing::ParticleFileSink>(o.staged.stage("particles.h5"), meta);
  if (a.lammps) {
    o.lammps = std::make_unique<packing::LammpsDataSink>(o.staged.stage("particles.data"), p.types,
                                                         l.active().box, "mesorock rockprep run");
  }
  return o;
}

// The packing's results: its statistics, the box's voxel count, the solid's voxels, and the
// particles by type and by role.
struct PackedBlock {
  packing::PackStats stats;
  std::int64_t box_voxels = 0;  // the layout's voxels (block, reservoirs and slabs, or the box)
  sim::SolidMask solid;
  std::vector<std::int64_t> per_type;
  nlohmann::json role_table = nlohmann::json::array();
};

// Packs the layout's voxels, streaming into the particle file (and the LAMMPS file); the layout's
// voxel codes are dropped afterwards (the solid mask keeps what the solver needs).
PackedBlock pack_block(const RunContext& c, const BlockScale& b, RunLayout& l,
                       const ParticleRoles& p, RunOutputs& o) {
  packing::VoxelLayout& layout = l.active();
  std::vector<packing::ParticleSink*> sinks{o.particles.get()};
  if (o.lammps) sinks.push_back(o.lammps.get());
  packing::TeeSink tee(sinks);
  packing::PackOptions po;
  po.voxel_rc = b.voxel_rc;
  po.origin = layout.origin;
  po.seed = c.args.seed;
  po.progress = [&](double f) {
    char line[64];
    std::snprintf(line, sizeof line, "  packed %.0f%% of the layers", 100 * f);
    c.progress.note(line);
  };
  PackedBlock packed;
  packed.stats = c.progress.stage(
      "pack " + std::to_string(layout.codes.voxels()) + " voxels", layout.codes.voxels(),
      [&] { return packing::pack_voxels(layout.codes, p.roles, po, tee); });
  packed.box_voxels = layout.codes.voxels();
  // The solid's voxels for the solver (grains stay dry whatever the wall particles do) and for
  // a continuum reference on the identical geometry (rockflow lbm).
  packed.solid = l.permeability
                     ? packing::solid_mask_of(layout, -1e300, 1e300)
                     : packing::solid_mask_of(layout, l.flooding.block_lo, l.flooding.block_hi);
  packed.solid.nm_per_rc = b.nm_per_rc;
  layout.codes = voxel::Volume();

  packed.per_type.assign(p.types.size(), 0);
  for (int code = 1; code <= packing::kFloodingRoles; ++code) {
    const packing::RoleCount& k = packed.stats.roles[static_cast<std::size_t>(code - 1)];
    const packing::RoleSpec& r = p.roles[static_cast<std::size_t>(code - 1)];
    if (k.voxels == 0) continue;
    packed.per_type[static_cast<std::size_t>(r.type)] += k.particles;
    packed.role_table.push_back({{"role", r.name},
                                 {"type", p.types[static_cast<std::size_t>(r.type)]},
                                 {"fill", packing::to_string(r.fill)},
                                 {"voxels", k.voxels},
                                 {"particles", k.particles},
                                 {"expected", k.expected},
                                 {"standard_deviation", std::sqrt(k.variance)}});
  }
  return packed;
}

// The forces that rockprep suggests for rockflow sweep: from the block's median pore
// (suggested_sweep_forces), or a fixed list when its pore sizes are unknown.
std::array<double, 4> suggested_force_list(const RunContext& c) {
  const nlohmann::json& sizes = c.record.value("pore_sizes", nlohmann::json::object());
  if (!sizes.contains("median_rc") || !(sizes["median_rc"].get<double>() > 0))
    return {0.01, 0.02, 0.03, 0.04};
  return suggested_sweep_forces(sizes["median_rc"].get<double>());
}
std::string suggested_forces(const RunContext& c) {
  std::string list;
  for (double g : suggested_force_list(c)) list += (list.empty() ? "" : ",") + fmt(g, 3);
  return list;
}
// The scene's body force: --body-force, else the top suggested force as printed (3 digits).
double scene_body_force(const RunContext& c) {
  if (given(c.args.body_force_option)) return c.args.body_force;
  return std::stod(fmt(suggested_force_list(c).back(), 3));
}

// The scene file's header comment: what the set-up is and how to run it.
std::string scene_comment(const RunContext& rc, bool permeability) {
  const RunArgs& a = rc.args;
  std::ostringstream c;
  if (permeability) {
    c << "Permeability set-up written by rockprep run (mesorock " << kVersion << ", " << kGitCommit
      << "): the block" << (a.no_mirror ? "" : " and its mirror image along " + a.flow_axis)
      << " in a periodic box, the fluid driven by a body force along " << a.flow_axis
      << ".\nSweep it: rockflow sweep scene.toml --out OUT --forces " << suggested_forces(rc)
      << " (docs/permeability.md); or watch it flow: rockflow run scene.toml --out OUT (its flow "
         "rate settles only after thousands of steps).\nSeed "
      << a.seed << "; provenance in run.json.";
  } else {
    c << "Flooding set-up written by rockprep run (mesorock " << kVersion << ", " << kGitCommit
      << ").\nRun it: rockflow run scene.toml --out OUT (regions.csv, saturation.csv: the "
         "recovery curve).\nSeed "
      << a.seed << "; provenance in run.json.";
  }
  return c.str();
}

// The scene's parameters (either layout's scene is written from them).
PermeabilitySceneParams scene_params(const RunContext& c, const BlockScale& b,
                                     const ParticleRoles& p, const RunTiles& t) {
  const RunArgs& a = c.args;
  PermeabilitySceneParams sp;
  sp.name =
      fs::path(a.out).filename().string().empty() ? a.layout : fs::path(a.out).filename().string();
  sp.seed = a.seed;
  sp.type_names = p.types;
  sp.a_fluid = a.a_fluid;
  sp.a_organic = c.plan.a_organic;
  sp.a_inorganic = c.plan.a_inorganic;
  sp.a_wall = a.a_wall;
  sp.B = a.B;
  sp.gamma = a.gamma;
  sp.rd = a.rd;
  sp.kBT = a.kBT;
  sp.density_kernel = a.density_kernel;
  sp.wall_density =
      c.plan.wall_fill == packing::Fill::Tiles ? t.wall->stats.density : a.wall_density;
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
  sp.nm_per_rc = b.nm_per_rc;
  sp.body_force = scene_body_force(c);
  sp.flow_steps = a.flow_steps;
  sp.comment = scene_comment(c, c.plan.permeability);
  return sp;
}

// run.json's "parameters": the options as used (the layout's defaults filled in).
void record_parameters(const RunContext& c, const BlockScale& b,
                       const PermeabilitySceneParams& sp) {
  const RunArgs& a = c.args;
  const voxel::LengthScale& scale = b.scale;
  const std::array<double, 3>& voxel_rc = b.voxel_rc;
  c.record["parameters"] = {
      {"scale", scale.nm_per_rc > 0 ? nlohmann::json{{"nm_per_rc", scale.nm_per_rc}}
                                    : nlohmann::json{{"rc_per_voxel", scale.rc_per_voxel}}},
      {"crop", a.crop},
      {"voxel_rc_zyx", {voxel_rc[2], voxel_rc[1], voxel_rc[0]}},
      {"layout", a.layout},
      {"flow_axis", a.flow_axis},
      {"wall_thickness_rc", a.wall_thickness_rc},
      {"connected_only", !a.all_pores},
      {"connectivity", a.connectivity},
      {"wall_fill", a.wall_fill},
      {"fluid_fill", a.fluid_fill},
      {"wall_density", a.wall_density},
      {"fluid_density", a.fluid_density},
      {"seed", a.seed},
      {"density_kernel", a.density_kernel},
      {"pairs",
       {{"a_fluid", a.a_fluid},
        {"a_organic", c.plan.a_organic},
        {"a_inorganic", c.plan.a_inorganic},
        {"a_wall", a.a_wall},
        {"B", a.B},
        {"gamma", a.gamma},
        {"rd", a.rd},
        {"kBT", a.kBT}}}};
  nlohmann::json& parameters = c.record["parameters"];
  if (c.plan.permeability) {
    parameters["mirror"] = !a.no_mirror;
    parameters["body_force"] = sp.body_force;
    parameters["body_force_from"] = given(a.body_force_option) ? "--body-force" : "median pore";
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
}

// run.json's "tiles": the sets used and where they came from.
void record_tiles(const RunContext& c, const RunTiles& t) {
  nlohmann::json tiles_used = nlohmann::json::array();
  for (const tiledb::TileSet* s : {t.wall, t.fluid})
    if (s)
      tiles_used.push_back({{"key", s->key.str()},
                            {"tiles", s->tiles()},
                            {"measured_density", s->stats.density},
                            {"temperature", s->stats.temperature},
                            {"seed", s->build.seed}});
  const std::string& tiles_db = c.args.tiles_db;
  c.record["tiles"] = {{"database", tiles_db.empty() ? "(built here)" : tiles_db},
                       {"cache", t.cache_dir.empty() ? "none" : t.cache_dir.string()},
                       {"copy", "tiles.h5"},
                       {"sets", tiles_used},
                       {"source", t.sources},
                       {"built_here", t.built_any}};
}

// run.json's "layout", "voxels" and "particles": the box's regions and what they hold.
void record_layout(const RunContext& c, const RunLayout& l, const ParticleRoles& p,
                   const PackedBlock& packed) {
  const bool permeability = l.permeability;
  const packing::VoxelLayout& layout = l.active();
  const packing::FloodingLayout& flooding = l.flooding;
  nlohmann::json& record = c.record;
  const std::array<double, 3> box_lo = layout.box.lo, box_hi = layout.box.hi;
  if (permeability) {
    const std::array<double, 3> block_hi = l.periodic.block_extent;
    record["layout"] = {{"kind", "permeability"},
                        {"box_lo", box_lo},
                        {"box_hi", box_hi},
                        {"periodic", {true, true, true}},
                        {"block_lo", std::array<double, 3>{0, 0, 0}},
                        {"block_hi", block_hi},
                        {"mirrored", l.periodic.mirrored},
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
  const auto& rv = layout.role_voxels;
  record["voxels"] = {{"block", layout.block_voxels},
                      {permeability ? "box" : "extended", packed.box_voxels},
                      {"pore", layout.pore_voxels},
                      {"pore_dropped", layout.pore_voxels_dropped},
                      {"solid", layout.solid_voxels},
                      {"wall_organic", rv[packing::kRoleOrganicWall]},
                      {"wall_inorganic", rv[packing::kRoleInorganicWall]},
                      {"clusters", layout.clusters},
                      {"spanning_clusters", layout.spanning_clusters}};
  if (permeability) record["voxels"]["fluid_in_box"] = rv[packing::kRoleBlockFluid];
  nlohmann::json by_type = nlohmann::json::object();
  for (std::size_t i = 0; i < p.types.size(); ++i) by_type[p.types[i]] = packed.per_type[i];
  record["particles"] = {
      {"total", packed.stats.particles}, {"by_type", by_type}, {"by_role", packed.role_table}};
}

// What write_outputs writes besides the particles: the solid, the scene, the tile sets.
struct RunProducts {
  const PackedBlock& packed;
  const RunLayout& layout;
  const PermeabilitySceneParams& scene;
  const RunTiles& tiles;
};

// Commits the particle files and writes the solid, the scene, the tile sets and run.json (the
// completion record, last); they take their names together. A --tiles database that grew is
// saved too.
void write_outputs(const RunContext& c, RunOutputs& o, const RunProducts& w) {
  const RunArgs& a = c.args;
  const bool permeability = c.plan.permeability;
  const fs::path out(a.out);
  nlohmann::json& record = c.record;
  voxel::StagedOutputs& staged = o.staged;
  c.progress.stage("write " + a.out, 0, [&] {
    o.particles->commit();
    if (o.lammps) o.lammps->commit();
    sim::write_particle_xdmf(staged.stage("particles.xmf"),
                             staged.final_path("particles.xmf").parent_path() / "particles.h5",
                             static_cast<std::size_t>(w.packed.stats.particles));
    sim::write_solid_file(staged.stage("solid.h5"), w.packed.solid, "rockprep run",
                          nlohmann::json{{"layout", a.layout},
                                         {"input", record["input"]},
                                         {"crop", a.crop},
                                         {"flow_axis", a.flow_axis},
                                         {"mirrored", permeability && !a.no_mirror},
                                         {"solid", "wall voxels and the empty voxels of the block"}}
                              .dump());
    mesorock::write_text_atomically(staged.stage("scene.toml"),
                                    permeability
                                        ? permeability_scene_toml(w.layout.periodic, w.scene)
                                        : flooding_scene_toml(w.layout.flooding, w.scene));
    // The sets used, with the output (a few MB at most): the packing can be repeated from it.
    tiledb::TileDatabase used;
    for (const tiledb::TileSet* s : {w.tiles.wall, w.tiles.fluid})
      if (s) used.put(*s);
    tiledb::write_tile_database(staged.stage("tiles.h5"), used);
    if (!a.tiles_db.empty() && w.tiles.db.sets.size() > w.tiles.sets_before)
      tiledb::write_tile_database(a.tiles_db, w.tiles.db);
    const packing::PackStats& stats = w.packed.stats;
    record["memory"] = {{"peak_rss_bytes", peak_rss_bytes()},
                        {"particle_bytes", stats.particles * packing::kParticleBytes},
                        {"peak_pack_buffer_bytes", stats.peak_buffer_bytes}};
    record["seconds"] = {{"pack", stats.seconds}, {"total", c.seconds()}};
    record["outputs"] =
        a.lammps ? nlohmann::json{"particles.h5", "particles.xmf", "particles.data", "solid.h5",
                                  "scene.toml",   "tiles.h5",      "run.json"}
                 : nlohmann::json{"particles.h5", "particles.xmf", "solid.h5",
                                  "scene.toml",   "tiles.h5",      "run.json"};
    record["warnings"] = c.progress.warnings();
    write_json(staged.stage("run.json"), record, (out / "run.json").string());
    staged.commit();
  });
}

// The closing lines on stdout: what was set up, its size, and the command that runs it.
void print_summary(const RunContext& c, const RunLayout& l, const ParticleRoles& p,
                   const PackedBlock& packed) {
  const RunArgs& a = c.args;
  const bool permeability = c.plan.permeability;
  const packing::VoxelLayout& layout = l.active();
  const auto& rv = layout.role_voxels;
  const std::int64_t particles = packed.stats.particles;
  const double seconds = c.seconds();
  std::ostringstream s;
  s << "summary: " << layout.block_voxels << " block voxels (" << packed.box_voxels
    << (permeability ? a.no_mirror ? " in the periodic box" : " in the periodic box, mirrored"
                     : " with reservoirs and slabs")
    << "), " << layout.pore_voxels << " pore, "
    << rv[packing::kRoleOrganicWall] + rv[packing::kRoleInorganicWall]
    << (permeability ? " wall in the box; " : " wall; ") << particles << " particles:";
  for (std::size_t t = 0; t < p.types.size(); ++t)
    s << " " << p.types[t] << " " << packed.per_type[t];
  s << "; particle arrays " << gib(static_cast<double>(particles * packing::kParticleBytes))
    << ", peak memory " << gib(static_cast<double>(peak_rss_bytes())) << "; " << seconds << " s";
  if (a.quiet) return;
  const fs::path out(a.out);
  std::cout << "rockprep: " << s.str() << "\n";
  if (permeability)
    std::cout << "rockprep: next: rockflow sweep " << (out / "scene.toml").string()
              << " --out OUT --forces " << suggested_forces(c) << "\n"
              << "rockprep: or watch it flow: rockflow run " << (out / "scene.toml").string()
              << " --out OUT (body force " << scene_body_force(c) << " along " << a.flow_axis
              << ", " << a.flow_steps
              << " steps; the flow rate takes thousands of steps to settle, docs/permeability.md: "
                 "measure k with the sweep)\n";
  else
    std::cout << "rockprep: next: rockflow run " << (out / "scene.toml").string() << " --out OUT\n";
}

// rockprep run, step by step in the order the work is done.
int run_run(const RunArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  const RunPlan plan = plan_run(a);
  // One owner per folder, before the load: a second rockprep run on it is refused at once.
  const OutputLock lock(a.out);
  lock.remove_earlier_record("run.json");  // a failure must not leave the old one
  exit_on_interrupt("rockprep", "nothing was written to " + a.out +
                                    " (the outputs appear when the set-up is complete): run it "
                                    "again");
  RunTiles tiles;
  if (!a.tiles_db.empty() && fs::exists(a.tiles_db))
    tiles.db = tiledb::read_tile_database(a.tiles_db);

  if (a.generation.threads > 0) omp_set_num_threads(a.generation.threads);
  Progress progress(a.quiet);
  nlohmann::json record = provenance("run");
  const RunContext c{a, plan, progress, record, start};
  voxel::Volume labels = load_block(c);
  const BlockScale block = scale_block(c, labels);
  RunLayout layout = build_layout(c, block, std::move(labels));
  report_pore_sizes(c, block);
  find_tile_sets(c, block, tiles);

  const ParticleRoles roles = particle_roles(c, layout, tiles);
  check_estimate(c, block, layout, roles);
  RunOutputs outputs = open_outputs(c, layout, roles);
  const PackedBlock packed = pack_block(c, block, layout, roles, outputs);

  const PermeabilitySceneParams scene = scene_params(c, block, roles, tiles);
  record_parameters(c, block, scene);
  record_tiles(c, tiles);
  record_layout(c, layout, roles, packed);
  write_outputs(c, outputs, RunProducts{packed, layout, scene, tiles});
  print_summary(c, layout, roles, packed);
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
      a->body_force_option = app->add_option(
          "--body-force", a->body_force,
          "permeability: the fluid's body force along the flow axis (default: the top force "
          "suggested for rockflow sweep, 2.29 / d^2 for the median pore d in rc)"),
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
  a->flooding_only.push_back(app->add_option(
      "--slab-rc", a->slab_rc, "Slab thickness, rc (default 2; fluid passes through 1 rc slabs)"));
  a->flooding_only.push_back(
      app->add_option("--room-rc", a->room_rc,
                      "Empty room behind the back slab, rc (default: the block's pore volume over "
                      "its cross-section, + 1)"));
  app->add_option("--wall-fill", a->wall_fill, "tiles (default) or lattice")
      ->check(CLI::IsMember({"tiles", "lattice"}));
  app->add_option("--fluid-fill", a->fluid_fill, "tiles (default) or random")
      ->check(CLI::IsMember({"tiles", "random"}));
  a->flooding_only.push_back(
      app->add_option("--slab-fill", a->slab_fill, "lattice (default) or tiles")
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
