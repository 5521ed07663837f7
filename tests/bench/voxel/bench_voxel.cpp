// Benchmark of rockprep part 1 on a large synthetic stack: load (TIFF folder), filter (Gaussian,
// optionally median), segment (histogram + multi-Otsu, labelling, OpenVDB phase grids), and the
// writes. Prints seconds, voxels per second, current and peak resident memory after each stage.
//
//   bench_voxel generate DIR [--size N] [--seed S]     writes DIR/grey/slice_*.tif (N^3 uint8)
//   bench_voxel run DIR [--median] [--no-gaussian] [--no-label-grid]
//                                                      reads DIR/grey, writes DIR/out/
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
#include "voxel/phase_grids.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"
#include "voxel/synth.h"
#include "voxel/tiff_io.h"

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
  stages.run("write TIFF slices", o.shape.voxels(), [&] {
    StagedOutputs out = StagedOutputs::in_directory(dir);
    write_tiff_slices(sample.grey, out, "grey", {});
    out.commit();
  });
  std::printf("truth porosity %.5f\n", sample.truth_counts.porosity());
  return 0;
}

int run(const fs::path& dir, bool median, bool gaussian, bool label_grid) {
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
  const openvdb::GridPtrVec grids =
      stages.run(label_grid ? "build phase grids (+labels)" : "build phase grids (masks)", n, [&] {
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
      const auto tree = openvdb::gridConstPtrCast<openvdb::Int32Grid>(g)->treePtr();
      std::printf("  label grid: %zu leaves (mixed 8^3 blocks) of %lld blocks, %.2f GiB\n",
                  std::size_t(tree->leafCount()),
                  static_cast<long long>(((volume_shape.nz + 7) / 8) * ((volume_shape.ny + 7) / 8) *
                                         ((volume_shape.nx + 7) / 8)),
                  double(g->memUsage()) / (1 << 30));
    }
  }
  std::printf("  grids in memory %.2f GiB, porosity %.5f\n", double(grid_bytes) / (1 << 30),
              count_phases(labels).porosity());
  stages.run("write phases.vdb", n, [&] {
    StagedOutputs out = StagedOutputs::in_directory(dir / "out");
    write_vdb(out.stage("phases.vdb"), grids, {}, "phases.vdb");
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

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 3) {
      std::fprintf(stderr,
                   "usage: bench_voxel generate DIR [--size N] [--seed S]\n"
                   "       bench_voxel run DIR [--median] [--no-gaussian] [--no-label-grid]\n");
      return 2;
    }
    const std::string mode = argv[1];
    const fs::path dir = argv[2];
    std::int64_t size = 1024;
    std::uint64_t seed = 1;
    bool median = false, gaussian = true, label_grid = true;
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
      } else if (a == "--no-label-grid") {
        label_grid = false;
      } else {
        std::fprintf(stderr, "bench_voxel: unknown argument %s\n", a.c_str());
        return 2;
      }
    }
    if (mode == "generate") return generate(dir, size, seed);
    if (mode == "run") return run(dir, median, gaussian, label_grid);
    std::fprintf(stderr, "bench_voxel: unknown mode %s\n", mode.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_voxel: %s\n", e.what());
    return 1;
  }
}
