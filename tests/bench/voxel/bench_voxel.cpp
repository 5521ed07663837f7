// Benchmark of rockprep part 1 on a large synthetic stack: load (TIFF folder), filter (Gaussian,
// optionally median), segment (histogram + multi-Otsu, labelling, OpenVDB phase grids), and the
// writes. Prints seconds, voxels per second, current and peak resident memory after each stage.
//
//   bench_voxel generate DIR [--size N] [--seed S]     writes DIR/grey/slice_*.tif (N^3 uint8)
//                                                      and the true labels DIR/truth.mhd
//   bench_voxel run DIR [--median] [--no-gaussian] [--label-grid uint8|int32|none]
//                                                      reads DIR/grey, writes DIR/out/
//   bench_voxel analyze DIR [--nm-per-rc X] [--thickness]
//                                                      rockprep part 2 on DIR/truth.mhd: pore
//                                                      statistics, clusters (6 and 26), wall
//                                                      sweep (as `rockprep analyze
//                                                      --no-thickness` and `rockprep walls`);
//                                                      writes DIR/walls/
//
// Two processes on purpose: peak memory (getrusage) is per process, and generating the stack
// needs the truth volume too, which the pipeline being measured does not.
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>

#include "mesorock/version.h"
#include "voxel/filters.h"
#include "voxel/load.h"
#include "voxel/local_thickness.h"
#include "voxel/phase_grids.h"
#include "voxel/pore_analysis.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"
#include "voxel/synth.h"
#include "voxel/tiff_io.h"
#include "voxel/walls.h"

namespace fs = std::filesystem;
using namespace mesorock::voxel;

namespace {

double rss_gib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / (1024.0 * 1024.0);
  }
  return 0;
}

double peak_gib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / (1024.0 * 1024.0);  // ru_maxrss is in KiB
}

// CPU seconds of this process (user + system), to tell a slow stage from a starved one on a
// shared machine: cpu / wall near the thread count means every core was ours.
double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

struct Stages {
  double total = 0;
  template <class Fn>
  decltype(auto) run(const char* name, std::int64_t voxels, Fn&& fn) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = cpu_seconds();
    auto finish = [&] {
      const double s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      total += s;
      std::printf("%-28s %7.2f s (cpu %6.2f s) %8.1f Mvoxel/s   RSS %5.2f GiB   peak %5.2f GiB\n",
                  name, s, cpu_seconds() - cpu_start, static_cast<double>(voxels) / s / 1e6,
                  rss_gib(), peak_gib());
      std::fflush(stdout);
    };
    if constexpr (std::is_void_v<decltype(fn())>) {
      fn();
      finish();
    } else {
      decltype(auto) result = fn();
      finish();
      return result;
    }
  }
};

int generate(const fs::path& dir, std::int64_t size, std::uint64_t seed) {
  ShaleOptions o;
  o.shape = {size, size, size};
  o.noise = 20;
  o.seed = seed;
  Stages stages;
  const ShaleSample sample =
      stages.run("synthesise", o.shape.voxels(), [&] { return make_shale(o); });
  stages.run("write TIFF slices + truth.mhd", o.shape.voxels(), [&] {
    StagedOutputs out = StagedOutputs::in_directory(dir);
    write_tiff_slices(sample.grey, out, "grey", {});
    write_mhd(sample.truth, out, "truth.mhd",
              {{"phase_codes", "0=outside,1=pore,2=organic,3=inorganic,4=organic_pore"}});
    out.commit();
  });
  std::printf("truth porosity %.5f\n", sample.truth_counts.porosity());
  return 0;
}

int run(const fs::path& dir, bool median, bool gaussian, LabelGridType label_grid) {
  std::printf("mesorock %s (%s), %ld hardware threads\n", mesorock::kVersion, mesorock::kGitCommit,
              sysconf(_SC_NPROCESSORS_ONLN));
  Stages stages;
  // The voxel count is known only after loading: count the slices and read one header first.
  const std::size_t slices = list_tiff_slices(dir / "grey").size();
  const Volume first = read_tiff_file(list_tiff_slices(dir / "grey").front());
  const std::int64_t n = static_cast<std::int64_t>(slices) * first.voxels();
  Volume volume = stages.run("load TIFF folder", n, [&] { return read_tiff_folder(dir / "grey"); });
  std::printf("  %s %s, %.2f GiB\n", volume.shape().str().c_str(), dtype_name(volume.dtype()),
              double(volume.byte_size()) / (1 << 30));
  if (gaussian) {
    stages.run("Gaussian sigma 1", n, [&] { gaussian_filter(volume, isotropic_gaussian(1.0)); });
  }
  if (median) {
    MedianOptions m;
    m.radius_z = 0.75;
    m.radius_y = m.radius_x = 1.5;
    m.shape = MedianShape::kBall;
    stages.run("median 3x3 in-plane (ball)", n, [&] { median_filter(volume, m); });
  }
  const std::vector<double> thresholds = stages.run("histogram + multi-Otsu 3", n, [&] {
    return multi_otsu_thresholds(histogram_of(volume), 3);
  });
  std::printf("  thresholds %.0f %.0f\n", thresholds[0], thresholds[1]);
  ThresholdSegmentation seg;
  seg.thresholds = thresholds;
  seg.phases = default_class_phases(3);
  const Shape volume_shape = volume.shape();
  Volume labels = stages.run("label (in place)", n,
                             [&] { return segment_by_thresholds(std::move(volume), seg); });
  const std::string grid_stage =
      label_grid == LabelGridType::kNone
          ? std::string("build phase grids (masks)")
          : std::string("build grids (+") + label_grid_type_name(label_grid) + " labels)";
  openvdb::GridPtrVec grids = stages.run(grid_stage.c_str(), n, [&] {
    PhaseGridOptions options;
    options.label_grid = label_grid;
    return build_phase_grids(labels, options);
  });
  const double pipeline = stages.total;
  const double pipeline_peak = peak_gib();
  std::size_t grid_bytes = 0;
  for (const auto& g : grids) {
    grid_bytes += g->memUsage();
    if (g->getName() == "labels") {
      std::printf("  label grid (%s): %zu leaves (mixed 8^3 blocks) of %lld blocks, %.2f GiB\n",
                  g->type().c_str(), std::size_t(g->baseTree().leafCount()),
                  static_cast<long long>(((volume_shape.nz + 7) / 8) * ((volume_shape.ny + 7) / 8) *
                                         ((volume_shape.nx + 7) / 8)),
                  double(g->memUsage()) / (1 << 30));
    }
  }
  std::printf("  grids in memory %.2f GiB, porosity %.5f\n", double(grid_bytes) / (1 << 30),
              count_phases(labels).porosity());
  openvdb::GridPtrVec label_grids;
  if (label_grid != LabelGridType::kNone) {
    label_grids.push_back(grids.back());
    grids.pop_back();
  }
  stages.run("write phases.vdb (+labels.vdb)", n, [&] {
    StagedOutputs out = StagedOutputs::in_directory(dir / "out");
    write_vdb(out.stage("phases.vdb"), grids, {}, "phases.vdb");
    if (!label_grids.empty()) write_vdb(out.stage("labels.vdb"), label_grids, {}, "labels.vdb");
    out.commit();
  });
  stages.run("write labels.mhd/.raw", n, [&] {
    StagedOutputs out = StagedOutputs::in_directory(dir / "out");
    write_mhd(labels, out, "labels.mhd");
    out.commit();
  });
  std::printf("load + filter + segment: %.2f s (%.1f Mvoxel/s), peak %.2f GiB\n", pipeline,
              double(n) / pipeline / 1e6, pipeline_peak);
  std::printf("with writes: %.2f s, peak %.2f GiB\n", stages.total, peak_gib());
  return 0;
}

// rockprep part 2 on the true labels of the generated stack.
int analyze(const fs::path& dir, double nm_per_rc, bool thickness) {
  std::printf("mesorock %s (%s), %ld hardware threads\n", mesorock::kVersion, mesorock::kGitCommit,
              sysconf(_SC_NPROCESSORS_ONLN));
  Stages stages;
  Volume labels = stages.run("load truth.mhd", 0, [&] { return load_volume(dir / "truth.mhd"); });
  const std::int64_t n = labels.voxels();
  std::printf("  %s %s, spacing %s\n", labels.shape().str().c_str(), dtype_name(labels.dtype()),
              labels.spacing().str().c_str());
  const double load_seconds = stages.total;
  const PoreStatistics stats =
      stages.run("porosity, interfaces, profiles", n, [&] { return measure_pores(labels); });
  std::printf("  porosity %.5f, specific surface %.5f 1/%s\n", stats.counts.porosity(),
              stats.specific_surface_area(labels.spacing()), labels.spacing().unit.c_str());
  {
    const PoreRuns runs = stages.run("pore runs", n, [&] { return find_pore_runs(labels); });
    std::printf("  %lld runs, %.2f GiB\n", static_cast<long long>(runs.count()),
                double(runs.bytes()) / (1 << 30));
    for (int c : {6, 26}) {
      ClusterOptions o;
      o.connectivity = c;
      const std::string name = "clusters " + std::to_string(c) + "-connected";
      const std::vector<Cluster> clusters =
          stages.run(name.c_str(), n, [&] { return find_pore_clusters(runs, o); });
      const PercolationSummary sum = summarize_clusters(clusters, 10);
      std::printf("  %lld clusters, percolating porosity z %.5f y %.5f x %.5f, %lld isolated\n",
                  static_cast<long long>(sum.clusters),
                  double(sum.spanning_voxels[0]) / double(stats.counts.counted()),
                  double(sum.spanning_voxels[1]) / double(stats.counts.counted()),
                  double(sum.spanning_voxels[2]) / double(stats.counts.counted()),
                  static_cast<long long>(sum.isolated_clusters));
    }
  }
  const double analysis_seconds = stages.total - load_seconds;
  const double analysis_peak = peak_gib();
  if (thickness) {
    const Volume t = stages.run("local thickness", n, [&] { return local_thickness(labels); });
    const SizeDistribution d = size_distribution(t, labels);
    std::printf("  local thickness mean %.3f max %.3f %s\n", d.mean, d.max,
                labels.spacing().unit.c_str());
  }
  // The wall sweep, as `rockprep walls`: estimate, masks, dense labels freed, sweep.
  const double before_walls = stages.total;
  LengthScale scale;
  scale.nm_per_rc = nm_per_rc;
  const std::array<double, 3> voxel_rc = voxel_size_rc(scale, labels.spacing());
  const std::array<int, 3> layers = wall_layers(1.0, voxel_rc);
  const ParticleEstimate estimate = estimate_particles(stats, voxel_rc, layers);
  std::printf("  scale %s: wall layers %d,%d,%d; estimate %s\n", scale.str().c_str(), layers[0],
              layers[1], layers[2], estimate.str().c_str());
  PhaseGridOptions grid_options;
  grid_options.label_grid = LabelGridType::kNone;
  const openvdb::GridPtrVec masks =
      stages.run("phase masks", n, [&] { return build_phase_grids(labels, grid_options); });
  labels = Volume();
  WallOptions wall_options;
  wall_options.layers = layers;
  const WallSweep sweep =
      stages.run("wall sweep", n, [&] { return sweep_walls(masks, wall_options); });
  std::size_t wall_bytes = 0;
  for (const auto& g : sweep.walls) wall_bytes += g->memUsage();
  std::printf(
      "  %lld wall voxels (organic %lld, inorganic %lld), %lld pore surface voxels, "
      "wall grids %.2f GiB\n",
      static_cast<long long>(sweep.total()), static_cast<long long>(sweep.voxels[2]),
      static_cast<long long>(sweep.voxels[3]), static_cast<long long>(sweep.surface_voxels),
      double(wall_bytes) / (1 << 30));
  std::printf("  counted: %s\n",
              count_particles(stats.pore_voxels(), sweep.total(), voxel_rc).str().c_str());
  const double walls_seconds = stages.total - before_walls;
  stages.run("write walls.vdb", n, [&] {
    StagedOutputs out = StagedOutputs::in_directory(dir / "walls");
    write_vdb(out.stage("walls.vdb"), sweep.walls, {}, "walls.vdb");
    out.commit();
  });
  std::printf("analysis (no thickness): %.2f s (%.1f Mvoxel/s), peak %.2f GiB\n", analysis_seconds,
              double(n) / analysis_seconds / 1e6, analysis_peak);
  std::printf("wall sweep (masks + sweep): %.2f s (%.1f Mvoxel/s)\n", walls_seconds,
              double(n) / walls_seconds / 1e6);
  std::printf(
      "analysis + wall sweep (no load, no write): %.2f s (%.1f Mvoxel/s); with load "
      "and write %.2f s; peak %.2f GiB\n",
      analysis_seconds + walls_seconds, double(n) / (analysis_seconds + walls_seconds) / 1e6,
      stages.total, peak_gib());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 3) {
      std::fprintf(stderr,
                   "usage: bench_voxel generate DIR [--size N] [--seed S]\n"
                   "       bench_voxel run DIR [--median] [--no-gaussian] [--label-grid "
                   "uint8|int32|none]\n"
                   "       bench_voxel analyze DIR [--nm-per-rc X] [--thickness]\n");
      return 2;
    }
    const std::string mode = argv[1];
    const fs::path dir = argv[2];
    std::int64_t size = 1024;
    std::uint64_t seed = 1;
    bool median = false, gaussian = true, thickness = false;
    double nm_per_rc = 5.0;
    LabelGridType label_grid = LabelGridType::kUInt8;
    for (int i = 3; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--size" && i + 1 < argc) {
        size = std::stoll(argv[++i]);
      } else if (a == "--seed" && i + 1 < argc) {
        seed = std::stoull(argv[++i]);
      } else if (a == "--median") {
        median = true;
      } else if (a == "--no-gaussian") {
        gaussian = false;
      } else if (a == "--nm-per-rc" && i + 1 < argc) {
        nm_per_rc = std::stod(argv[++i]);
      } else if (a == "--thickness") {
        thickness = true;
      } else if (a == "--no-label-grid") {
        label_grid = LabelGridType::kNone;
      } else if (a == "--label-grid" && i + 1 < argc) {
        label_grid = parse_label_grid_type(argv[++i]);
      } else {
        std::fprintf(stderr, "bench_voxel: unknown argument %s\n", a.c_str());
        return 2;
      }
    }
    if (mode == "generate") return generate(dir, size, seed);
    if (mode == "run") return run(dir, median, gaussian, label_grid);
    if (mode == "analyze") return analyze(dir, nm_per_rc, thickness);
    std::fprintf(stderr, "bench_voxel: unknown mode %s\n", mode.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_voxel: %s\n", e.what());
    return 1;
  }
}
