// Benchmark of the streaming packing (docs/benchmarks.md): synthetic shale labels -> flooding
// layout (wall sweep, reservoirs, slabs) -> tile sets -> packing streamed into an HDF5 particle
// file. Prints seconds per stage, the particles and the bytes of the particle arrays written, and
// the peak resident memory against them (the target: peak at most 1.5 x the arrays).
//
//   bench_packing generate DIR [--shape Z,Y,X] [--porosity P] [--seed S]
//                                        writes the true labels DIR/truth.mhd (+ .raw, .json)
//   bench_packing run DIR [--voxel-rc H] [--wall-fill tiles|lattice] [--fluid-fill tiles|random]
//                 [--tiles FILE] [--keep]
//                                        packs DIR/truth.mhd into DIR/out/particles.h5 (removed
//                                        afterwards unless --keep); the tile sets are read from
//                                        FILE when it holds them, else built (and saved there)
//
// Two processes on purpose: peak memory (getrusage) is per process, and generating the labels
// needs the grey image too, which the packing does not.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>

#include "mesorock/version.h"
#include "packing/flooding.h"
#include "packing/pack.h"
#include "packing/sink.h"
#include "tiledb/database.h"
#include "tiledb/generate.h"
#include "voxel/raw_io.h"
#include "voxel/staged_output.h"
#include "voxel/synth.h"

namespace fs = std::filesystem;
using namespace mesorock;

namespace {

using Clock = std::chrono::steady_clock;

double gib(double bytes) {
  return bytes / (1024.0 * 1024.0 * 1024.0);
}

double rss_bytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) * 1024.0;
  return 0;
}

double peak_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) * 1024.0;  // ru_maxrss is in KiB
}

// User + system CPU seconds of this process so far (the machine may be shared: wall time alone
// would not say how much work a stage was).
double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void report(const char* stage, double seconds) {
  std::printf("%-44s %9.2f s   rss %6.3f GiB   peak %6.3f GiB\n", stage, seconds, gib(rss_bytes()),
              gib(peak_bytes()));
  std::fflush(stdout);
}

std::string option(int argc, char** argv, const char* name, const char* fallback) {
  for (int i = 0; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return argv[i + 1];
  return fallback;
}

bool flag(int argc, char** argv, const char* name) {
  for (int i = 0; i < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return true;
  return false;
}

int generate(const fs::path& dir, int argc, char** argv) {
  voxel::ShaleOptions o;
  long long z = 0, y = 0, x = 0;
  if (std::sscanf(option(argc, argv, "--shape", "256,256,256").c_str(), "%lld,%lld,%lld", &z, &y,
                  &x) != 3) {
    std::fprintf(stderr, "--shape Z,Y,X\n");
    return 2;
  }
  o.shape = {z, y, x};
  o.spacing = {1, 1, 1, "nm"};
  o.porosity = std::stod(option(argc, argv, "--porosity", "0.2"));
  o.organic_fraction = std::stod(option(argc, argv, "--organic", "0.4"));
  o.seed = std::stoull(option(argc, argv, "--seed", "1"));
  o.noise = 0;
  const auto t = Clock::now();
  const voxel::ShaleSample s = voxel::make_shale(o);
  report("synthesise shale labels", seconds_since(t));
  fs::create_directories(dir);
  voxel::StagedOutputs out = voxel::StagedOutputs::in_directory(dir);
  nlohmann::json rec = {{"phase_codes", "0=outside,1=pore,2=organic,3=inorganic,4=organic_pore"},
                        {"generator", "bench_packing generate"}};
  voxel::write_mhd(s.truth, out, "truth.mhd", rec);
  out.commit();
  std::printf("porosity %.4f, shape %s\n", s.truth_counts.porosity(), o.shape.str().c_str());
  return 0;
}

int run(const fs::path& dir, int argc, char** argv) {
  const double h = std::stod(option(argc, argv, "--voxel-rc", "0.5"));
  const packing::Fill wall_fill = packing::parse_fill(option(argc, argv, "--wall-fill", "tiles"));
  const packing::Fill fluid_fill = packing::parse_fill(option(argc, argv, "--fluid-fill", "tiles"));
  const bool keep = flag(argc, argv, "--keep");
  std::printf("bench_packing run %s (mesorock %s, %s): voxel %.4g rc, walls %s, fluid %s\n",
              dir.c_str(), kVersion, kGitCommit, h, packing::to_string(wall_fill),
              packing::to_string(fluid_fill));
  const auto t_all = Clock::now();

  auto t = Clock::now();
  voxel::Volume labels = voxel::read_mhd(dir / "truth.mhd");
  const std::int64_t nblock = labels.voxels();
  report(("load labels " + labels.shape().str()).c_str(), seconds_since(t));

  t = Clock::now();
  packing::FloodingOptions fo;
  fo.voxel_rc = {h, h, h};
  fo.connected_only = false;
  fo.inlet_rc = 2;
  fo.outlet_rc = 2;
  fo.room_rc = 1;
  packing::FloodingLayout layout = packing::build_flooding_layout(std::move(labels), fo);
  report("layout: wall sweep, reservoirs, slabs", seconds_since(t));
  std::printf("  %lld block voxels, %lld pore, %lld wall (organic %lld, inorganic %lld)\n",
              static_cast<long long>(nblock), static_cast<long long>(layout.pore_voxels),
              static_cast<long long>(layout.role_voxels[packing::kRoleOrganicWall] +
                                     layout.role_voxels[packing::kRoleInorganicWall]),
              static_cast<long long>(layout.role_voxels[packing::kRoleOrganicWall]),
              static_cast<long long>(layout.role_voxels[packing::kRoleInorganicWall]));

  t = Clock::now();
  tiledb::TileKey wall_key;
  wall_key.edge = {h, h, h};
  tiledb::TileKey fluid_key = wall_key;
  fluid_key.role = tiledb::TileRole::Fluid;
  fluid_key.density = 6.5;
  tiledb::TileBuildOptions to;
  to.seed = 2;
  const std::string tiles_path = option(argc, argv, "--tiles", "");
  tiledb::TileDatabase db;
  if (!tiles_path.empty() && fs::exists(tiles_path)) db = tiledb::read_tile_database(tiles_path);
  const std::size_t before = db.sets.size();
  for (const tiledb::TileKey& k : {wall_key, fluid_key})
    if (!db.find(k)) db.put(tiledb::build_tile_set(k, to));
  if (!tiles_path.empty() && db.sets.size() > before) tiledb::write_tile_database(tiles_path, db);
  const tiledb::TileSet& wall_tiles = *db.find(wall_key);
  const tiledb::TileSet& fluid_tiles = *db.find(fluid_key);
  report(db.sets.size() > before ? "tile sets built (wall rho 8, fluid rho 6.5)" : "tile sets read",
         seconds_since(t));

  std::vector<packing::RoleSpec> roles(packing::kFloodingRoles);
  const char* types[] = {"source",         "working",   "source",   "organic_wall",
                         "inorganic_wall", "push_slab", "back_slab"};
  const std::int32_t type_index[] = {0, 1, 0, 2, 3, 4, 5};
  for (int c = 1; c <= packing::kFloodingRoles; ++c) {
    packing::RoleSpec& r = roles[static_cast<std::size_t>(c - 1)];
    r.name = packing::flooding_role_name(c);
    r.type = type_index[c - 1];
    const bool fluid = c <= 3;
    r.fill = fluid ? fluid_fill : wall_fill;
    r.density = fluid ? 6.5 : 8.0;
    r.tiles = fluid ? &fluid_tiles : &wall_tiles;
    r.thermal = fluid;
  }
  (void)types;
  sim::ParticleFileMeta meta;
  meta.type_names = {"source",         "working",   "organic_wall",
                     "inorganic_wall", "push_slab", "back_slab"};
  meta.box = layout.box;
  meta.created_by = "bench_packing";
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const double before_pack = peak_bytes();
  const double cpu_before_pack = cpu_seconds();
  t = Clock::now();
  packing::PackStats stats;
  {
    packing::ParticleFileSink sink(out / "particles.h5", meta);
    packing::PackOptions po;
    po.voxel_rc = {h, h, h};
    po.origin = layout.origin;
    po.seed = 3;
    stats = packing::pack_voxels(layout.codes, roles, po, sink);
    sink.commit();
  }
  const double pack_seconds = seconds_since(t);
  report("pack + write particles.h5", pack_seconds);
  const double written = static_cast<double>(stats.particles) * packing::kParticleBytes;
  const double file = static_cast<double>(fs::file_size(out / "particles.h5"));
  const double peak = peak_bytes();
  std::printf("particles %lld (", static_cast<long long>(stats.particles));
  for (int c = 1; c <= packing::kFloodingRoles; ++c)
    std::printf("%s%s %lld", c > 1 ? ", " : "", roles[static_cast<std::size_t>(c - 1)].name.c_str(),
                static_cast<long long>(stats.roles[static_cast<std::size_t>(c - 1)].particles));
  std::printf(")\n");
  std::printf("packing rate %.2f M particles/s (pack + write; %.2f M per CPU second)\n",
              static_cast<double>(stats.particles) / pack_seconds / 1e6,
              static_cast<double>(stats.particles) / (cpu_seconds() - cpu_before_pack) / 1e6);
  std::printf(
      "particle arrays written %.3f GiB (file %.3f GiB); packer's largest buffer %.3f GiB\n",
      gib(written), gib(file), gib(static_cast<double>(stats.peak_buffer_bytes)));
  std::printf("peak RSS before packing %.3f GiB, overall %.3f GiB = %.3f x the arrays written\n",
              gib(before_pack), gib(peak), peak / written);
  std::printf("total %.2f s\n", seconds_since(t_all));
  if (!keep) fs::remove(out / "particles.h5");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_packing generate|run DIR [options] (see the source)\n");
    return 2;
  }
  const std::string what = argv[1];
  const fs::path dir = argv[2];
  try {
    if (what == "generate") return generate(dir, argc, argv);
    if (what == "run") return run(dir, argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_packing: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "bench_packing: unknown command %s\n", what.c_str());
  return 2;
}
