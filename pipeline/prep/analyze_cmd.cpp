// rockprep analyze: pore statistics of a phase-label volume (porosity, surface area, clusters and
// percolation, local thickness, porosity profiles): DIR/analysis.json and PNG plots.
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/plot.h"
#include "pipeline/prep/common.h"
#include "voxel/local_thickness.h"
#include "voxel/pore_analysis.h"
#include "voxel/staged_output.h"

namespace fs = std::filesystem;

namespace mesorock::pipeline::prep {
namespace {

struct AnalyzeArgs {
  LabelInputArgs input;
  std::string connectivity = "both";
  int largest = 10;
  std::string profile_axis = "z";
  bool no_thickness = false;
  int psd_bins = 0;
  std::string out;
  bool quiet = false;
};

std::string fixed(double v, int digits = 5) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

nlohmann::json per_axis(const std::array<double, 3>& v) {
  return {{"z", v[0]}, {"y", v[1]}, {"x", v[2]}};
}

nlohmann::json cluster_record(const voxel::PercolationSummary& sum, double counted,
                              double voxel_volume) {
  nlohmann::json j;
  j["count"] = sum.clusters;
  std::array<double, 3> perc{}, spanning{};
  for (std::size_t a = 0; a < 3; ++a) {
    perc[a] = counted > 0 ? double(sum.spanning_voxels[a]) / counted : 0.0;
    spanning[a] = double(sum.spanning_clusters[a]);
  }
  j["percolating_porosity"] = per_axis(perc);
  j["spanning_clusters"] = per_axis(spanning);
  j["percolating_porosity_any_axis"] = counted > 0 ? double(sum.percolating_voxels) / counted : 0.0;
  j["isolated_clusters"] = sum.isolated_clusters;
  j["isolated_porosity"] = counted > 0 ? double(sum.isolated_voxels) / counted : 0.0;
  j["enclosed_clusters"] = sum.enclosed_clusters;
  j["enclosed_porosity"] = counted > 0 ? double(sum.enclosed_voxels) / counted : 0.0;
  nlohmann::json largest = nlohmann::json::array();
  for (const voxel::Cluster& c : sum.largest_isolated) {
    largest.push_back({{"voxels", c.voxels},
                       {"volume", double(c.voxels) * voxel_volume},
                       {"bbox_lo_zyx", c.lo},
                       {"bbox_hi_zyx", c.hi},
                       {"touches_boundary", c.touches_boundary()}});
  }
  j["largest_isolated"] = largest;
  return j;
}

// What every analyze step reads: the options, the labels and their measured statistics, and the
// progress and record they report to.
struct AnalyzeContext {
  const AnalyzeArgs& args;
  int profile_axis;         // of the plotted profile
  const std::string& name;  // the input, for messages
  const voxel::Volume& labels;
  const voxel::PoreStatistics& stats;
  Progress& progress;
  nlohmann::json& record;
  double counted() const { return double(stats.counts.counted()); }
  double voxel_volume() const {
    const voxel::Spacing& s = labels.spacing();
    return s.dz * s.dy * s.dx;
  }
};

std::vector<int> connectivities_of(const std::string& option) {
  std::vector<int> connectivities;
  if (option == "6" || option == "both") connectivities.push_back(6);
  if (option == "26" || option == "both") connectivities.push_back(26);
  return connectivities;
}

// The parameters, the definitions of every quantity, and the block's voxel counts: the record's
// description of what was measured, apart from the measurements themselves.
void record_block(const AnalyzeContext& c, const std::vector<int>& connectivities) {
  const AnalyzeArgs& a = c.args;
  const voxel::Shape shape = c.labels.shape();
  const voxel::Spacing spacing = c.labels.spacing();
  nlohmann::json& record = c.record;
  record["parameters"] = {{"connectivity", connectivities},
                          {"largest", a.largest},
                          {"profile_axis", a.profile_axis},
                          {"local_thickness", !a.no_thickness},
                          {"psd_bins", a.psd_bins}};
  record["definitions"] = {
      {"pore", "phase codes 1 (pore) and 4 (organic_pore)"},
      {"solid",
       "phase codes 2 (organic) and 3 (inorganic); 0 (outside) is neither and is not "
       "counted"},
      {"porosity", "pore voxels / counted voxels"},
      {"interface",
       "faces between face-adjacent pore and solid voxels, each dy*dz, dx*dz or "
       "dx*dy by its normal"},
      {"specific_surface_area", "interface area / bulk volume of the counted voxels"},
      {"percolating_porosity",
       "voxels of the clusters holding voxels in both the first and the "
       "last slice along the axis / counted voxels"},
      {"isolated", "clusters spanning no axis; enclosed: isolated and touching no face"},
      {"local_thickness",
       "diameter of the largest sphere centred on a pore voxel, holding only "
       "pore voxels (|q - c| < R, R = distance to the nearest voxel that is "
       "not pore; the volume's faces are not walls) that contains the voxel"}};
  record["shape_zyx"] = {shape.nz, shape.ny, shape.nx};
  record["spacing_zyx"] = {spacing.dz, spacing.dy, spacing.dx};
  record["unit"] = spacing.unit;
  const voxel::PoreStatistics& stats = c.stats;
  nlohmann::json phases = nlohmann::json::object();
  for (int p = 0; p < voxel::kPhaseCount; ++p) {
    phases[voxel::phase_name(static_cast<voxel::Phase>(p))] =
        stats.counts.voxels[static_cast<std::size_t>(p)];
  }
  record["voxels"] = {
      {"counted", stats.counts.counted()}, {"pore", stats.pore_voxels()}, {"by_phase", phases}};
  record["porosity"] = stats.counts.porosity();
  record["pore_volume"] = double(stats.pore_voxels()) * c.voxel_volume();
  record["bulk_volume"] = c.counted() * c.voxel_volume();
}

// The pore-solid interface: face counts, areas, and the area by solid phase.
void record_surface(const AnalyzeContext& c) {
  const voxel::PoreStatistics& stats = c.stats;
  const voxel::Spacing spacing = c.labels.spacing();
  nlohmann::json s;
  std::array<double, 3> faces{};
  for (std::size_t ax = 0; ax < 3; ++ax) faces[ax] = double(stats.faces_normal_to(int(ax)));
  s["faces"] = per_axis(faces);
  s["interface_area"] = stats.interface_area(spacing);
  s["specific_surface_area"] = stats.specific_surface_area(spacing);
  s["specific_surface_area_unit"] = "1/" + spacing.unit;
  s["area_per_pore_volume"] =
      stats.pore_voxels()
          ? stats.interface_area(spacing) / (double(stats.pore_voxels()) * c.voxel_volume())
          : 0.0;
  nlohmann::json by_phase = nlohmann::json::object();
  for (voxel::Phase p : {voxel::Phase::kOrganic, voxel::Phase::kInorganic}) {
    std::int64_t f = 0;
    for (std::size_t ax = 0; ax < 3; ++ax) f += stats.faces[ax][static_cast<std::size_t>(p)];
    if (f == 0) continue;
    by_phase[voxel::phase_name(p)] = {{"faces", f},
                                      {"interface_area", stats.interface_area(spacing, p)}};
  }
  s["by_solid_phase"] = by_phase;
  c.record["surface"] = s;
  c.progress.note("specific surface area " + fixed(stats.specific_surface_area(spacing)) + " 1/" +
                  spacing.unit + " (voxel faces)");
}

// Porosity profiles along every axis, at the slice centres.
void record_profiles(const AnalyzeContext& c) {
  const voxel::Spacing spacing = c.labels.spacing();
  nlohmann::json profiles = nlohmann::json::object();
  const double h[3] = {spacing.dz, spacing.dy, spacing.dx};
  for (int ax = 0; ax < 3; ++ax) {
    const std::vector<double> p = c.stats.porosity_profile(ax);
    std::vector<double> position(p.size());
    for (std::size_t i = 0; i < p.size(); ++i) position[i] = (double(i) + 0.5) * h[ax];
    profiles[voxel::axis_name(ax)] = {{"position", position}, {"porosity", p}};
  }
  c.record["profiles"] = profiles;
}

// Pore clusters and percolation for each connectivity; the pore runs are found once for all.
void record_clusters(const AnalyzeContext& c, const std::vector<int>& connectivities) {
  Progress& progress = c.progress;
  const std::int64_t n = c.labels.voxels();
  const voxel::PoreRuns runs = progress.stage("pore runs", n, [&] {
    return about_file(c.name, [&] { return voxel::find_pore_runs(c.labels); });
  });
  progress.note(std::to_string(runs.count()) + " pore runs, " +
                fixed(double(runs.bytes()) / double(1 << 20), 4) + " MiB");
  c.record["pore_runs"] = runs.count();
  nlohmann::json clusters = nlohmann::json::object();
  for (int k : connectivities) {
    voxel::ClusterOptions o;
    o.connectivity = k;
    const std::vector<voxel::Cluster> found =
        progress.stage("clusters, " + std::to_string(k) + "-connected", n,
                       [&] { return voxel::find_pore_clusters(runs, o); });
    const voxel::PercolationSummary sum =
        voxel::summarize_clusters(found, static_cast<std::size_t>(c.args.largest));
    nlohmann::json j = cluster_record(sum, c.counted(), c.voxel_volume());
    clusters[std::to_string(k)] = j;
    progress.note(std::to_string(k) + "-connected: " + std::to_string(sum.clusters) +
                  " clusters; percolating porosity z " +
                  fixed(j["percolating_porosity"]["z"].get<double>()) + ", y " +
                  fixed(j["percolating_porosity"]["y"].get<double>()) + ", x " +
                  fixed(j["percolating_porosity"]["x"].get<double>()) + "; " +
                  std::to_string(sum.isolated_clusters) + " isolated clusters");
  }
  c.record["clusters"] = clusters;
}

// The local-thickness pore-size distribution, or none when skipped or when it cannot be
// measured (a warning: the other statistics stand without it).
std::optional<voxel::SizeDistribution> measure_local_thickness(const AnalyzeContext& c) {
  if (c.args.no_thickness) return std::nullopt;
  try {
    const voxel::Volume thickness = c.progress.stage(
        "local thickness", c.labels.voxels(), [&] { return voxel::local_thickness(c.labels); });
    return voxel::size_distribution(thickness, c.labels, c.args.psd_bins);
  } catch (const ConfigError& e) {
    c.progress.warn(c.name + ": " + e.what());
  }
  return std::nullopt;
}

void record_local_thickness(const AnalyzeContext& c,
                            const std::optional<voxel::SizeDistribution>& psd) {
  if (!psd) {
    c.record["local_thickness"] = nullptr;
    return;
  }
  const std::string& unit = c.labels.spacing().unit;
  nlohmann::json j;
  j["unit"] = unit;
  j["mean"] = psd->mean;
  j["median"] = psd->median;
  j["max"] = psd->max;
  j["bin_lower"] = std::vector<double>(psd->edges.begin(), psd->edges.end() - 1);
  j["bin_upper"] = std::vector<double>(psd->edges.begin() + 1, psd->edges.end());
  j["voxels"] = psd->voxels;
  j["pore_volume_fraction"] = psd->volume_fraction;
  c.record["local_thickness"] = j;
  c.progress.note("local thickness: mean " + fixed(psd->mean, 4) + ", median " +
                  fixed(psd->median, 4) + ", max " + fixed(psd->max, 4) + " " + unit);
}

// The plots and analysis.json, which take their names together.
void write_analysis(const AnalyzeContext& c, const std::optional<voxel::SizeDistribution>& psd) {
  const AnalyzeArgs& a = c.args;
  const std::string& unit = c.labels.spacing().unit;
  const fs::path out(a.out);
  c.progress.stage("write " + a.out, 0, [&] {
    voxel::StagedOutputs staged = voxel::StagedOutputs::in_directory(out);
    {
      mesorock::plot::Plot plot;
      plot.title = "Porosity profile along " + a.profile_axis;
      plot.x_label = a.profile_axis + " (" + unit + ")";
      plot.y_label = "porosity";
      plot.x = c.record["profiles"][a.profile_axis]["position"].get<std::vector<double>>();
      plot.y = c.stats.porosity_profile(c.profile_axis);
      mesorock::plot::write_plot_png(plot, staged.stage("porosity_profile.png"),
                                     (out / "porosity_profile.png").string());
    }
    if (psd) {
      mesorock::plot::Plot plot;
      plot.title = "Pore size distribution (local thickness)";
      plot.x_label = "local thickness (" + unit + ")";
      plot.y_label = "pore volume fraction";
      plot.style = mesorock::plot::PlotStyle::kBars;
      plot.x.assign(psd->edges.begin(), psd->edges.end() - 1);
      plot.y = psd->volume_fraction;
      plot.bar_width = psd->edges.size() > 1 ? psd->edges[1] - psd->edges[0] : 1.0;
      mesorock::plot::write_plot_png(plot, staged.stage("pore_size_distribution.png"),
                                     (out / "pore_size_distribution.png").string());
    }
    write_json(staged.stage("analysis.json"), c.record, (out / "analysis.json").string());
    staged.commit();
  });
}

int run_analyze(const AnalyzeArgs& a) {
  const std::vector<int> connectivities = connectivities_of(a.connectivity);
  const int profile_axis = voxel::parse_axis(a.profile_axis);
  check_output_folder(a.out);

  Progress progress(a.quiet);
  nlohmann::json record = provenance("analyze");
  nlohmann::json input;
  const voxel::Volume labels = load_labels(a.input, progress, &input);
  record["input"] = input;
  const std::string& name = input["path"].get_ref<const std::string&>();

  const voxel::PoreStatistics stats = progress.stage(
      "porosity, interfaces, profiles", labels.voxels(),
      [&] { return about_file(name, [&] { return voxel::measure_pores(labels); }); });
  progress.note("porosity " + fixed(stats.counts.porosity()) + " (" +
                std::to_string(stats.pore_voxels()) + " pore of " +
                std::to_string(stats.counts.counted()) + " counted voxels)");
  const std::string warning = voxel::porosity_warning(stats.counts);
  if (!warning.empty()) progress.warn(name + ": " + warning);

  const AnalyzeContext c{a, profile_axis, name, labels, stats, progress, record};
  record_block(c, connectivities);
  record_surface(c);
  record_profiles(c);
  record_clusters(c, connectivities);
  const std::optional<voxel::SizeDistribution> psd = measure_local_thickness(c);
  record_local_thickness(c, psd);

  nlohmann::json outputs = {"analysis.json", "porosity_profile.png"};
  if (psd) outputs.push_back("pore_size_distribution.png");
  record["outputs"] = outputs;
  record["warnings"] = progress.warnings();
  write_analysis(c, psd);
  return 0;
}

}  // namespace

Command add_analyze_command(CLI::App& rockprep) {
  auto args = std::make_shared<AnalyzeArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "analyze",
      "Pore analysis of a phase-label volume: porosity, specific surface area, connected "
      "clusters and percolating porosity (6- and 26-connectivity), largest isolated pores, "
      "local-thickness pore-size distribution, porosity profiles; writes DIR/analysis.json, "
      "DIR/pore_size_distribution.png and DIR/porosity_profile.png");
  args->input.add_to(app);
  app->add_option("--connectivity", args->connectivity,
                  "Pore clusters with 6 (faces), 26 (faces, edges, corners) or both (default)")
      ->check(CLI::IsMember({"6", "26", "both"}));
  app->add_option("--largest", args->largest,
                  "How many of the largest isolated pores to list (default 10)")
      ->check(CLI::Range(0, 1000000));
  app->add_option("--profile-axis", args->profile_axis,
                  "Axis of the plotted porosity profile: z (default), y or x")
      ->check(CLI::IsMember({"z", "y", "x"}));
  app->add_flag("--no-thickness", args->no_thickness,
                "Skip the local thickness (it needs 4 bytes per voxel and the most time)");
  app->add_option("--psd-bins", args->psd_bins,
                  "Bins of the size distribution (default: one per smallest voxel spacing, at "
                  "most 100)")
      ->check(CLI::Range(1, 100000));
  app->add_option("--out", args->out, "Output folder")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_analyze(*args); }};
}

}  // namespace mesorock::pipeline::prep
