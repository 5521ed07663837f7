// rockprep segment: grey or labelled stack -> phase labels, OpenVDB phase grids, statistics.
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/prep/common.h"
#include "voxel/load.h"
#include "voxel/phase_grids.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"

namespace fs = std::filesystem;

namespace mesorock::pipeline::prep {
namespace {

struct SegmentArgs {
  InputArgs input;
  FilterArgs filters;
  std::string thresholds;
  int otsu = 0;
  int bins = 0;
  std::string labels;
  std::string phases;
  std::string exclude_value;
  bool organic_pores = false;
  bool no_label_grid = false;
  std::string label_grid = "uint8";
  std::string truth;
  std::string out;
  bool quiet = false;
};

// Re-throws a library ConfigError with the input's name in front, so the one-line message says
// which file the problem is in.
template <class Fn>
decltype(auto) about_input(const std::string& input, Fn&& fn) {
  try {
    return fn();
  } catch (const ConfigError& e) {
    throw ConfigError(input + ": " + e.what());
  }
}

std::vector<voxel::Phase> class_phases(const std::string& names, int classes) {
  if (names.empty()) return voxel::default_class_phases(classes);
  std::vector<voxel::Phase> phases;
  for (const std::string& n : voxel::split(names, ',')) phases.push_back(voxel::parse_phase(n));
  if (static_cast<int>(phases.size()) != classes) {
    throw ConfigError("--phases names " + std::to_string(phases.size()) + " phases for " +
                      std::to_string(classes) + " classes");
  }
  return phases;
}

// Everything the user typed, parsed and checked before the (possibly long) load.
struct SegmentPlan {
  voxel::LabelGridType label_grid_type;
  voxel::LabelMap label_map;
  std::vector<double> thresholds;  // --thresholds; --otsu finds them after the load
  std::vector<voxel::Phase> phases;
  std::optional<double> exclude_value;
};

SegmentPlan plan_segment(const SegmentArgs& a) {
  const int modes = (!a.thresholds.empty()) + (a.otsu > 0) + (!a.labels.empty());
  if (modes != 1) {
    throw ConfigError("segment: give exactly one of --thresholds, --otsu or --labels");
  }
  if (!a.labels.empty() && (!a.filters.median.empty() || a.filters.gaussian > 0)) {
    throw ConfigError("segment: filters make no sense on a labelled volume (--labels)");
  }
  if (!a.labels.empty() && !a.phases.empty()) {
    throw ConfigError("segment: --phases is for --thresholds/--otsu; --labels names its phases");
  }
  SegmentPlan plan;
  plan.label_grid_type = voxel::parse_label_grid_type(a.label_grid);
  const fs::path out(a.out);
  if (!out.parent_path().empty() && !fs::is_directory(out.parent_path())) {
    throw IoError(a.out + ": parent folder does not exist");
  }
  if (fs::exists(out) && !fs::is_directory(out))
    throw IoError(a.out + ": exists and is not a folder");
  if (!a.truth.empty() && !fs::exists(a.truth)) throw IoError(a.truth + ": no such file");
  plan.label_map = a.labels.empty() ? voxel::LabelMap{} : voxel::LabelMap::parse(a.labels);
  plan.thresholds =
      a.thresholds.empty() ? std::vector<double>{} : parse_numbers(a.thresholds, "--thresholds");
  const int classes = a.otsu > 0 ? a.otsu : static_cast<int>(plan.thresholds.size()) + 1;
  if (a.labels.empty()) plan.phases = class_phases(a.phases, classes);
  if (!a.exclude_value.empty()) {
    const std::vector<double> v = parse_numbers(a.exclude_value, "--exclude-value");
    if (v.size() != 1) throw ConfigError("--exclude-value takes one number");
    plan.exclude_value = v[0];
  }
  return plan;
}

// The loaded stack and what the steps after the load share: the progress, the record and the
// segmentation's parameters (params, recorded as "parameters").
struct SegmentContext {
  const SegmentArgs& args;
  SegmentPlan& plan;
  Progress& progress;
  nlohmann::json& record;
  nlohmann::json params;
};

// Runs the filters and finds the voxels that are outside: the field of view (from the filters or
// the input's sidecar), --exclude-value, and non-finite values.
voxel::Exclusion filter_and_exclude(SegmentContext& c, voxel::Volume& volume,
                                    const voxel::ReadReport& report) {
  const SegmentArgs& a = c.args;
  Progress& progress = c.progress;
  std::optional<voxel::FieldOfView> fov;
  nlohmann::json filters =
      about_input(a.input.path, [&] { return apply_filters(a.filters, volume, progress, &fov); });
  if (!fov && report.provenance.is_object() && report.provenance.contains("filters") &&
      report.provenance["filters"].contains("field_of_view")) {
    const auto& f = report.provenance["filters"]["field_of_view"];
    fov = voxel::FieldOfView{f.at("cx").get<double>(), f.at("cy").get<double>(),
                             f.at("radius").get<double>()};
    filters["field_of_view"] = f;
    filters["field_of_view_from"] = "input sidecar";
    progress.note("field of view from the input's sidecar: voxels outside it are excluded");
  }
  voxel::Exclusion exclusion;
  exclusion.field_of_view = fov;
  exclusion.value = c.plan.exclude_value;
  c.params = filters;
  if (c.plan.exclude_value) c.params["exclude_value"] = *c.plan.exclude_value;
  // NaN and infinite voxels are no data: labelled outside (load_input said so for the input; a
  // Gaussian or median filter spreads a NaN to its neighbours, so they are counted again here).
  const voxel::NonFiniteCounts non_finite = voxel::count_non_finite(volume);
  if (non_finite.total() > 0) {
    c.params["non_finite_voxels_labelled_outside"] = non_finite.total();
    if (non_finite.total() != report.non_finite.total())
      progress.warn(a.input.path + ": after the filters, " +
                    voxel::non_finite_note(non_finite, volume.voxels()) + " (the input had " +
                    std::to_string(report.non_finite.total()) + ")");
  }
  return exclusion;
}

// The stack -> phase labels: by thresholds (given, or multi-Otsu's) or by the label map; then,
// with --organic-pores, the organic-hosted pores relabelled.
voxel::Volume label_phases(SegmentContext& c, voxel::Volume volume,
                           const voxel::Exclusion& exclusion) {
  const SegmentArgs& a = c.args;
  Progress& progress = c.progress;
  nlohmann::json& params = c.params;
  std::vector<double>& thresholds = c.plan.thresholds;
  const voxel::Spacing spacing = volume.spacing();
  const std::int64_t n = volume.voxels();
  if (a.otsu > 0) {
    const voxel::Histogram histogram = progress.stage("histogram", n, [&] {
      return about_input(a.input.path,
                         [&] { return voxel::histogram_of(volume, exclusion, a.bins); });
    });
    thresholds =
        about_input(a.input.path, [&] { return voxel::multi_otsu_thresholds(histogram, a.otsu); });
    std::ostringstream s;
    s << "multi-Otsu, " << a.otsu << " classes over " << histogram.counts.size()
      << " bins: thresholds";
    for (double t : thresholds) s << " " << t;
    progress.note(s.str());
    params["method"] = "multi-otsu";
    params["classes"] = a.otsu;
    params["histogram_bins"] = histogram.counts.size();
  } else if (!a.thresholds.empty()) {
    params["method"] = "thresholds";
  }
  voxel::Volume labels;
  if (a.labels.empty()) {
    params["thresholds"] = thresholds;
    nlohmann::json names = nlohmann::json::array();
    for (voxel::Phase p : c.plan.phases) names.push_back(voxel::phase_name(p));
    params["class_phases"] = names;
    params["class_rule"] = "class c holds values v with thresholds[c-1] <= v < thresholds[c]";
    voxel::ThresholdSegmentation seg{thresholds, c.plan.phases, exclusion};
    labels = progress.stage("label by thresholds", n, [&] {
      return about_input(a.input.path,
                         [&] { return voxel::segment_by_thresholds(std::move(volume), seg); });
    });
  } else {
    const voxel::LabelMap& label_map = c.plan.label_map;
    params["method"] = "label-map";
    params["label_map"] = label_map.str();
    labels = progress.stage("label by map " + label_map.str(), n, [&] {
      return about_input(a.input.path, [&] {
        return voxel::segment_by_label_map(std::move(volume), label_map, exclusion);
      });
    });
  }
  labels.set_spacing(spacing);
  if (a.organic_pores) {
    const std::int64_t moved = progress.stage("organic-hosted pores", n,
                                              [&] { return voxel::split_organic_pores(labels); });
    progress.note("organic_pore: " + std::to_string(moved) + " pore voxels are organic-hosted");
    params["organic_pores"] = true;
  }
  return labels;
}

// The phase fractions (a progress line and the record's table), and with --truth the agreement
// with known labels.
void record_phases(SegmentContext& c, const voxel::Volume& labels) {
  const SegmentArgs& a = c.args;
  Progress& progress = c.progress;
  const voxel::PhaseCounts counts = voxel::count_phases(labels);
  const std::string warning = voxel::porosity_warning(counts);
  if (!warning.empty()) progress.warn(a.input.path + ": " + warning);
  nlohmann::json phase_table = nlohmann::json::object();
  for (int p = 1; p < voxel::kPhaseCount; ++p) {
    const auto phase = static_cast<voxel::Phase>(p);
    if (counts.voxels[static_cast<std::size_t>(p)] == 0) continue;
    phase_table[voxel::phase_name(phase)] = {{"code", p},
                                             {"voxels", counts.voxels[static_cast<std::size_t>(p)]},
                                             {"fraction", counts.fraction(phase)}};
  }
  std::ostringstream summary;
  summary.precision(5);
  summary << "porosity " << counts.porosity() << " (" << counts.counted() << " voxels";
  if (counts.voxels[0]) summary << ", " << counts.voxels[0] << " outside";
  summary << ");";
  for (auto it = phase_table.begin(); it != phase_table.end(); ++it) {
    summary << " " << it.key() << " " << it.value()["fraction"].get<double>();
  }
  progress.note(summary.str());

  if (!a.truth.empty()) {
    voxel::ReadReport truth_report;
    const voxel::Volume truth = voxel::load_volume(a.truth, {}, &truth_report);
    const double agreement = about_input(a.truth, [&] {
      return voxel::label_agreement(labels, truth, /*merge_pores=*/!a.organic_pores);
    });
    std::ostringstream s;
    s.precision(5);
    s << "agreement with " << a.truth << ": " << agreement * 100 << "% of voxels";
    progress.note(s.str());
    c.record["truth"] = {
        {"path", a.truth}, {"agreement", agreement}, {"pores_merged", !a.organic_pores}};
  }
  c.record["phases"] = phase_table;
  c.record["porosity"] = counts.porosity();
  c.record["counted_voxels"] = counts.counted();
  c.record["outside_voxels"] = counts.voxels[0];
}

// The OpenVDB grids: the phase masks go to phases.vdb (standard grid types only), the label grid
// (when there is one) to labels.vdb.
struct PhaseGrids {
  openvdb::GridPtrVec masks;
  openvdb::GridPtrVec labels;
};

PhaseGrids build_grids(SegmentContext& c, const voxel::Volume& labels) {
  voxel::PhaseGridOptions grid_options;
  grid_options.label_grid =
      c.args.no_label_grid ? voxel::LabelGridType::kNone : c.plan.label_grid_type;
  PhaseGrids grids;
  grids.masks = c.progress.stage("build OpenVDB phase grids", labels.voxels(),
                                 [&] { return voxel::build_phase_grids(labels, grid_options); });
  if (grid_options.label_grid != voxel::LabelGridType::kNone) {
    grids.labels.push_back(grids.masks.back());
    grids.masks.pop_back();
  }
  c.params["label_grid"] = voxel::label_grid_type_name(grid_options.label_grid);
  std::size_t grid_bytes = 0;
  for (const auto& grid : grids.masks) grid_bytes += grid->memUsage();
  for (const auto& grid : grids.labels) grid_bytes += grid->memUsage();
  std::ostringstream s;
  s.precision(3);
  s << grids.masks.size() + grids.labels.size() << " grids, "
    << double(grid_bytes) / double(1 << 20) << " MiB in memory";
  c.progress.note(s.str());
  return grids;
}

// The output folder's files, which take their names together.
void write_segmentation(SegmentContext& c, const voxel::Volume& labels, const PhaseGrids& grids) {
  const nlohmann::json& record = c.record;
  const fs::path out(c.args.out);
  c.progress.stage("write " + c.args.out, labels.voxels(), [&] {
    voxel::StagedOutputs outputs = voxel::StagedOutputs::in_directory(out);
    const std::map<std::string, std::string> vdb_meta = {
        {"mesorock_version", kVersion}, {"git_commit", kGitCommit}, {"provenance", record.dump()}};
    voxel::write_vdb(outputs.stage("phases.vdb"), grids.masks, vdb_meta,
                     (out / "phases.vdb").string());
    if (!grids.labels.empty()) {
      voxel::write_vdb(outputs.stage("labels.vdb"), grids.labels, vdb_meta,
                       (out / "labels.vdb").string());
    }
    nlohmann::json labels_record = provenance("segment");
    labels_record["input"] = record["input"];
    labels_record["phase_codes"] = "0=outside,1=pore,2=organic,3=inorganic,4=organic_pore";
    voxel::write_mhd(labels, outputs, "labels.mhd", labels_record);
    {
      std::ofstream s(outputs.stage("segment.json"));
      s << record.dump(2) << "\n";
      if (!s) throw IoError((out / "segment.json").string() + ": write failed");
    }
    outputs.commit();
  });
}

int run_segment(const SegmentArgs& a) {
  SegmentPlan plan = plan_segment(a);

  Progress progress(a.quiet);
  voxel::ReadReport report;
  voxel::Volume volume = load_input(a.input, progress, &report);
  nlohmann::json record = provenance("segment");
  record["input"] = input_record(a.input, volume, report);
  const voxel::Shape shape = volume.shape();
  const voxel::Spacing spacing = volume.spacing();

  SegmentContext c{a, plan, progress, record, nlohmann::json()};
  const voxel::Exclusion exclusion = filter_and_exclude(c, volume, report);
  const voxel::Volume labels = label_phases(c, std::move(volume), exclusion);
  record_phases(c, labels);
  const PhaseGrids grids = build_grids(c, labels);

  record["parameters"] = c.params;
  record["shape_zyx"] = {shape.nz, shape.ny, shape.nx};
  record["spacing_zyx"] = {spacing.dz, spacing.dy, spacing.dx};
  record["unit"] = spacing.unit;
  record["outputs"] = {"phases.vdb", "labels.mhd", "labels.raw", "labels.json", "segment.json"};
  if (!grids.labels.empty()) record["outputs"].push_back("labels.vdb");
  record["warnings"] = progress.warnings();
  write_segmentation(c, labels, grids);
  return 0;
}

}  // namespace

Command add_segment_command(CLI::App& rockprep) {
  auto args = std::make_shared<SegmentArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "segment",
      "Segment a stack into phases (pore, organic, inorganic, organic_pore): thresholds, "
      "multi-Otsu or an explicit label map; writes DIR/phases.vdb, DIR/labels.vdb, "
      "DIR/labels.mhd (+.raw, .json) and DIR/segment.json");
  args->input.add_to(app);
  args->filters.add_to(app, /*with_fill=*/false);
  app->add_option("--thresholds", args->thresholds,
                  "T1,T2,...: class c holds values in [T(c), T(c+1)); darkest class first");
  app->add_option("--otsu", args->otsu, "Multi-Otsu thresholds for K classes")
      ->check(CLI::Range(2, 8));
  app->add_option("--bins", args->bins,
                  "Histogram bins for --otsu (default: one per grey level up to 1024 levels, "
                  "else 256)");
  app->add_option("--labels", args->labels,
                  "Labelled input: value=phase,... e.g. '0=pore,255=inorganic' or "
                  "'true=pore,false=solid'; every value present must be mapped");
  app->add_option("--phases", args->phases,
                  "Phase of each class, darkest first (default: 2 classes pore,inorganic; 3 "
                  "classes pore,organic,inorganic)");
  app->add_option("--exclude-value", args->exclude_value,
                  "Voxels with this value are outside (not counted), e.g. a scanner's fill value");
  app->add_flag("--organic-pores", args->organic_pores,
                "Relabel pore clusters surrounded mostly by organic matter as organic_pore");
  app->add_option("--label-grid", args->label_grid,
                  "Label grid written to labels.vdb: uint8 (default; 1 byte per voxel of mixed "
                  "8x8x8 blocks, a grid type mesorock registers), int32 (openvdb::Int32Grid, "
                  "readable by any OpenVDB program, 4 bytes per voxel) or none")
      ->check(CLI::IsMember({"uint8", "int32", "none"}));
  app->add_flag("--no-label-grid", args->no_label_grid,
                "Same as --label-grid none: only the per-phase masks (phases.vdb); labels.mhd has "
                "the labels too");
  app->add_option("--truth", args->truth,
                  "Known labels (e.g. from 'synth') to measure the segmentation against");
  app->add_option("--out", args->out, "Output folder")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_segment(*args); }};
}

}  // namespace mesorock::pipeline::prep
