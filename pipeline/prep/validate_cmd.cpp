// rockprep validate packing-walls: a wall packed from the tile database and the same wall packed
// on a lattice, each next to the same fluid, equilibrated with the embedded solver (CPU backend,
// the wall model of Li et al. 2018 on). Reports the fluid's temperature and density deviations
// next to each wall and the preprocessing time of each packing; the tile packing must give the
// smaller near-wall temperature deviation (the 2020 paper's reason for the tile database: "the
// lattice-like packing of surface wall particles might cause undesired oscillations in fluid
// temperature in the vicinity of solid-fluid interfaces").
//
// Geometry: a slit periodic in x and y; solid voxels (0.5 rc) 1.5 rc thick at both z ends, all
// of them wall (the wall thickness is 1.5 rc), reflective box faces behind them; fluid between.
// Every pair has the liquid's parameters (A = -40, B = 25, rd = 0.75, gamma = 4.5); walls at
// density 8, fluid at 6.5 packed at random (the same particles for both walls).
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>

#include "mesorock/errors.h"
#include "packing/pack.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/validation.h"
#include "pipeline/prep/common.h"
#include "pipeline/prep/packing_common.h"
#include "sim/observables.h"
#include "sim/simulation.h"
#include "tiledb/generate.h"

namespace mesorock::pipeline::prep {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kA = -40, kB = 25, kRd = 0.75, kGamma = 4.5;
constexpr double kWallDensity = 8.0, kFluidDensity = 6.5;
constexpr double kVoxel = 0.5;   // rc
constexpr int kWallVoxels = 3;   // 1.5 rc of wall on each side
constexpr double kLayer = 0.25;  // rc: near-wall layers of the metric
constexpr int kLayers = 4;       // the first rc from each wall surface
constexpr double kProfileBin = 0.125;

struct Size {
  int nxy = 10;     // voxels along x and y
  int nfluid = 12;  // fluid voxels along z (6 rc)
  std::uint64_t equilibrate = 1000, sample = 6000, every = 10;
  double dt = 0.01;
  bool wall_model = true;
};

// Sums per near-wall layer (kLayers layers of kLayer rc from each wall surface, both walls
// pooled) and over the bulk (the middle third of the fluid), reduced from profile bin sums.
struct LayerSums {
  std::array<std::array<double, sim::kBinFields>, kLayers + 1> s{};  // [kLayers] = bulk
  std::array<double, kLayers + 1> volume{};                          // per sample
  double samples = 0;

  LayerSums& operator+=(const LayerSums& o) {
    for (std::size_t k = 0; k < s.size(); ++k)
      for (std::size_t f = 0; f < s[k].size(); ++f) s[k][f] += o.s[k][f];
    samples += o.samples;
    return *this;
  }
  LayerSums operator-(const LayerSums& o) const {
    LayerSums r = *this;
    for (std::size_t k = 0; k < s.size(); ++k)
      for (std::size_t f = 0; f < s[k].size(); ++f) r.s[k][f] -= o.s[k][f];
    r.samples -= o.samples;
    return r;
  }
  double temperature(std::size_t k) const {
    const double n = s[k][sim::kBinCount];
    if (n <= 1) return 0.0;
    double t = 0;
    for (int c = 0; c < 3; ++c) {
      const double m = s[k][static_cast<std::size_t>(sim::kBinVx + c)] / n;
      t += s[k][static_cast<std::size_t>(sim::kBinVxx + c)] / n - m * m;
    }
    return t / 3;
  }
  double density(std::size_t k) const { return s[k][sim::kBinCount] / (samples * volume[k]); }
  // Relative deviation of layer k from the bulk.
  double dT(std::size_t k) const { return temperature(k) / temperature(kLayers) - 1; }
  double drho(std::size_t k) const { return density(k) / density(kLayers) - 1; }
};

LayerSums reduce(const std::vector<double>& bins, double samples, double bin_width,
                 double bin_volume, double wall_lo, double wall_hi) {
  LayerSums L;
  L.samples = samples;
  const int n = static_cast<int>(bins.size() / sim::kBinFields);
  for (int b = 0; b < n; ++b) {
    const double z = (b + 0.5) * bin_width;
    const double from_wall = std::min(z - wall_lo, wall_hi - z);
    if (from_wall < 0) continue;
    std::size_t k = kLayers + 1;
    if (from_wall < kLayers * kLayer) k = static_cast<std::size_t>(from_wall / kLayer);
    if (std::abs(z - 0.5 * (wall_lo + wall_hi)) <= (wall_hi - wall_lo) / 6) k = kLayers;
    if (k > kLayers) continue;
    for (int f = 0; f < sim::kBinFields; ++f)
      L.s[k][static_cast<std::size_t>(f)] +=
          bins[static_cast<std::size_t>(b * sim::kBinFields + f)];
    L.volume[k] += bin_volume;
  }
  return L;
}

// The near-wall deviation of a quantity over the layers, corrected for noise: the mean over
// layers of (d_k^2 - sigma_k^2), sigma_k the error of d_k from the blocks, so that noise alone
// gives 0 on average rather than a positive RMS; reported as sqrt(max(0, .)). Its error comes
// from a jackknife over the blocks (each block left out in turn).
struct Deviation {
  double rms = 0, error = 0;
  std::vector<double> layer, layer_error;  // signed d_k and sigma_k
};

template <class D>
Deviation deviation(const std::vector<LayerSums>& blocks, D d) {
  const std::size_t nb = blocks.size();
  LayerSums total = blocks[0];
  for (std::size_t b = 1; b < nb; ++b) total += blocks[b];
  // sigma_k^2 of the full-run d_k from the spread of the block values (leaving out `skip`).
  auto estimate = [&](const LayerSums& sums, std::size_t skip, Deviation* out) {
    double msd = 0;
    const double used = static_cast<double>(skip < nb ? nb - 1 : nb);
    for (std::size_t k = 0; k < kLayers; ++k) {
      double m = 0, m2 = 0;
      for (std::size_t b = 0; b < nb; ++b) {
        if (b == skip) continue;
        const double v = d(blocks[b], k);
        m += v;
        m2 += v * v;
      }
      m /= used;
      const double var = (m2 / used - m * m) * used / (used - 1) / used;
      const double dk = d(sums, k);
      msd += dk * dk - var;
      if (out) {
        out->layer.push_back(dk);
        out->layer_error.push_back(std::sqrt(std::max(0.0, var)));
      }
    }
    return std::sqrt(std::max(0.0, msd / kLayers));
  };
  Deviation r;
  r.rms = estimate(total, nb, &r);
  std::vector<double> jack;
  for (std::size_t b = 0; b < nb; ++b) jack.push_back(estimate(total - blocks[b], b, nullptr));
  double m = 0, ss = 0;
  for (double v : jack) m += v;
  m /= static_cast<double>(nb);
  for (double v : jack) ss += (v - m) * (v - m);
  r.error = std::sqrt(ss * (static_cast<double>(nb) - 1) / static_cast<double>(nb));
  return r;
}

struct WallResult {
  std::string name;
  double pack_seconds = 0;  // packing the voxels (the tile set is made before: tile_seconds)
  double tile_seconds = 0;  // building the tile set (tiles only; once per database key)
  double run_seconds = 0;
  std::int64_t wall_particles = 0, fluid_particles = 0;
  double bulk_T = 0, bulk_T_error = 0, bulk_rho = 0;
  Deviation T, rho;                        // near-wall deviations from the bulk
  std::vector<double> layer_T, layer_rho;  // per layer, both walls pooled
  std::vector<double> z, profile_T, profile_rho;
  std::uint64_t corrections = 0;
};

WallResult run_wall(packing::Fill wall_fill, const tiledb::TileSet* tiles, double tile_seconds,
                    const Size& size, const ValidateOptions& o) {
  WallResult r;
  r.name = packing::to_string(wall_fill);
  r.tile_seconds = tile_seconds;
  const int nz = size.nfluid + 2 * kWallVoxels;
  voxel::Volume codes(voxel::Shape{nz, size.nxy, size.nxy}, voxel::DType::kUInt8);
  for (int z = 0; z < nz; ++z) {
    const bool wall = z < kWallVoxels || z >= nz - kWallVoxels;
    std::fill(codes.slice<std::uint8_t>(z), codes.slice<std::uint8_t>(z) + size.nxy * size.nxy,
              static_cast<std::uint8_t>(wall ? 1 : 2));
  }
  std::vector<packing::RoleSpec> roles(2);
  roles[0].name = "wall";
  roles[0].type = 1;
  roles[0].fill = wall_fill;
  roles[0].density = kWallDensity;
  roles[0].tiles = tiles;
  roles[1].name = "fluid";
  roles[1].type = 0;
  roles[1].fill = packing::Fill::Random;
  roles[1].density = kFluidDensity;
  roles[1].thermal = true;
  packing::PackOptions po;
  po.voxel_rc = {kVoxel, kVoxel, kVoxel};
  po.seed = 81;
  packing::MemorySink sink;
  const auto t0 = Clock::now();
  const packing::PackStats stats = packing::pack_voxels(codes, roles, po, sink);
  r.pack_seconds = seconds_since(t0);
  r.wall_particles = stats.roles[0].particles;
  r.fluid_particles = stats.roles[1].particles;

  sim::Model m;
  m.types = {{"fluid", false, {0, 0, 0}}, {"wall", true, {0, 0, 0}}};
  m.pairs.assign(4, sim::PairSpec{kA, kB, kGamma});
  m.rd = kRd;
  m.density_kernel = o.density_kernel;
  m.seed = 82;
  m.wall_model.enabled = size.wall_model;
  m.wall_model.wall_density = kWallDensity;
  sim::BoxSpec box;
  const double L = size.nxy * kVoxel, H = nz * kVoxel;
  box.lo = {0, 0, 0};
  box.hi = {L, L, H};
  box.periodic = {true, true, false};
  const auto t1 = Clock::now();
  auto s = sim::make_simulation(m, box, sink.particles, 0.002, o.sim);
  s->run(200);
  s->set_dt(size.dt);
  s->run(size.equilibrate);
  const int bins = static_cast<int>(std::lround(H / kProfileBin));
  sim::BinGrid grid = sim::BinGrid::profile(2, bins, box.lo, box.hi);
  grid.type_mask = 1u;
  constexpr int kBlocks = 16;
  const std::uint64_t per_block = size.sample / size.every / kBlocks;
  std::vector<std::vector<double>> block_sums(kBlocks);
  for (std::uint64_t k = 0; k < per_block * kBlocks; ++k) {
    s->run(size.every);
    const auto sums = s->bin_sums(grid);
    auto& blk = block_sums[static_cast<std::size_t>(k / per_block)];
    if (blk.empty()) blk.assign(sums.size(), 0.0);
    for (std::size_t q = 0; q < sums.size(); ++q) blk[q] += sums[q];
  }
  r.run_seconds = seconds_since(t1);
  r.corrections = s->wall_corrections();
  const double wall_lo = kWallVoxels * kVoxel, wall_hi = H - kWallVoxels * kVoxel;
  std::vector<LayerSums> blocks;
  std::vector<double> total(block_sums[0].size(), 0.0);
  for (const auto& blk : block_sums) {
    blocks.push_back(
        reduce(blk, static_cast<double>(per_block), H / bins, grid.bin_volume(), wall_lo, wall_hi));
    for (std::size_t q = 0; q < blk.size(); ++q) total[q] += blk[q];
  }
  LayerSums all = blocks[0];
  for (std::size_t b = 1; b < blocks.size(); ++b) all += blocks[b];
  r.bulk_T = all.temperature(kLayers);
  r.bulk_rho = all.density(kLayers);
  {
    double m1 = 0, m2 = 0;
    for (const LayerSums& b : blocks) {
      m1 += b.temperature(kLayers);
      m2 += b.temperature(kLayers) * b.temperature(kLayers);
    }
    const double nb = static_cast<double>(blocks.size());
    m1 /= nb;
    r.bulk_T_error = std::sqrt(std::max(0.0, (m2 / nb - m1 * m1) / (nb - 1)));
  }
  r.T = deviation(blocks, [](const LayerSums& l, std::size_t k) { return l.dT(k); });
  r.rho = deviation(blocks, [](const LayerSums& l, std::size_t k) { return l.drho(k); });
  for (std::size_t k = 0; k < kLayers; ++k) {
    r.layer_T.push_back(all.temperature(k));
    r.layer_rho.push_back(all.density(k));
  }
  sim::BinnedAverage avg(grid);
  avg.add(total);
  const sim::BinnedQuantity Tq = avg.temperature();
  const double samples = static_cast<double>(per_block * kBlocks);
  for (int b = 0; b < bins; ++b) {
    r.z.push_back((b + 0.5) * H / bins);
    r.profile_T.push_back(Tq.mean[static_cast<std::size_t>(b)]);
    r.profile_rho.push_back(total[static_cast<std::size_t>(b) * sim::kBinFields] /
                            (samples * grid.bin_volume()));
  }
  progress(o, "packing-walls: " + r.name + ": " + std::to_string(r.wall_particles) + " wall + " +
                  std::to_string(r.fluid_particles) + " fluid particles; bulk T " +
                  fmt(r.bulk_T, 5) + ", rho " + fmt(r.bulk_rho, 5) + "; near-wall deviation T " +
                  fmt(r.T.rms, 3) + " +- " + fmt(r.T.error, 2) + ", rho " + fmt(r.rho.rms, 3) +
                  " +- " + fmt(r.rho.error, 2) + "; pack " + fmt(r.pack_seconds, 3) + " s, run " +
                  fmt(r.run_seconds, 3) + " s");
  return r;
}

CaseResult run_packing_walls(const ValidateOptions& o, double dt, bool wall_model) {
  CaseResult r;
  r.name = "packing-walls";
  Size size;
  size.dt = dt;
  size.wall_model = wall_model;
  if (o.size == CaseSize::Full) {
    size.nxy = 20;
    size.equilibrate = 2000;
    size.sample = 40000;
  }
  tiledb::TileKey key;
  key.role = tiledb::TileRole::Wall;
  key.density = kWallDensity;
  key.edge = {kVoxel, kVoxel, kVoxel};
  key.A = kA;
  key.B = kB;
  key.rd = kRd;
  key.gamma = kGamma;
  key.density_kernel = o.density_kernel;
  tiledb::TileBuildOptions to;
  to.variants = 1024;
  to.min_box_edge = 6;
  to.equilibration_steps = 2000;
  to.seed = 83;
  to.sim = o.sim;
  to.progress = [&](const std::string& line) { progress(o, "packing-walls: " + line); };
  const auto t0 = Clock::now();
  const tiledb::TileSet tiles = tiledb::build_tile_set(key, to);
  const double tile_seconds = seconds_since(t0);
  const tiledb::TileCheck check = tiledb::check_tile_set(tiles);

  const WallResult lattice = run_wall(packing::Fill::Lattice, nullptr, 0, size, o);
  const WallResult tile = run_wall(packing::Fill::Tiles, &tiles, tile_seconds, size, o);

  const double diff = lattice.T.rms - tile.T.rms;
  const double diff_error = std::hypot(tile.T.error, lattice.T.error);
  const std::string compared = "the lattice packing's " + fmt(lattice.T.rms, 3) + " +- " +
                               fmt(lattice.T.error, 2) + " (difference " + fmt(diff, 3) + " +- " +
                               fmt(diff_error, 2) + ", " +
                               fmt(diff_error > 0 ? diff / diff_error : 0, 2) + " sigma)";
  // The difference is a few tenths of a percent at dt = 0.01 (docs/validation.md): the full size
  // resolves it and judges the "smaller"; the CI size cannot, and checks only that the
  // tiles are not worse beyond two standard errors (a test that passed or failed on noise would
  // tell nothing).
  const bool full = o.size == CaseSize::Full;
  r.quantities.push_back(judged(
      "near-wall temperature deviation, tiles (noise-corrected RMS of T/T_bulk - 1 over 4 "
      "layers of 0.25 rc)",
      tile.T.rms, tile.T.error, full ? lattice.T.rms : lattice.T.rms + 2 * diff_error, 0,
      full ? "issue 8: smaller than " + compared
           : "at most " + compared +
                 " + 2 sigma (the small size cannot resolve the difference; --size full judges "
                 "'smaller')",
      Comparison::AtMost));
  r.quantities.push_back(
      judged("near-wall density deviation, tiles (same measure for rho/rho_bulk - 1)", tile.rho.rms,
             tile.rho.error, lattice.rho.rms, 0,
             "smaller than the lattice packing's " + fmt(lattice.rho.rms, 3) + " +- " +
                 fmt(lattice.rho.error, 2) + " (the lattice layers the fluid)",
             Comparison::AtMost));
  r.quantities.push_back(judged("tile set density / target - 1", check.density_deviation, 0, 0,
                                0.01, "issue 8: within 1%"));
  r.quantities.push_back(judged("tile set temperature / kBT - 1", check.temperature_deviation,
                                tiles.stats.temperature_error, 0, 0.02, "issue 8: within 2%"));
  for (const WallResult* w : {&lattice, &tile})
    r.quantities.push_back(judged("bulk fluid temperature, " + w->name + " walls", w->bulk_T,
                                  w->bulk_T_error, 1.0, 0.02,
                                  "kBT = 1 (thermostat); 2% for the time step's error"));
  auto pct = [](double v, double e) { return fmt(100 * v, 3) + "% +- " + fmt(100 * e, 2) + "%"; };
  for (const WallResult* w : {&lattice, &tile}) {
    std::string layers_T, layers_rho;
    for (std::size_t k = 0; k < w->T.layer.size(); ++k) {
      layers_T += (k ? ", " : "") + pct(w->T.layer[k], w->T.layer_error[k]);
      layers_rho += (k ? ", " : "") + fmt(100 * w->rho.layer[k], 3) + "%";
    }
    r.notes.push_back(
        w->name + " walls: " + std::to_string(w->wall_particles) + " wall particles, " +
        std::to_string(w->fluid_particles) + " fluid; near-wall deviation of T " +
        pct(w->T.rms, w->T.error) + ", of density " + pct(w->rho.rms, w->rho.error) + "; bulk T " +
        fmt(w->bulk_T, 5) + " +- " + fmt(w->bulk_T_error, 2) + ", bulk density " +
        fmt(w->bulk_rho, 5) + "; preprocessing " + fmt(w->pack_seconds, 3) + " s packing" +
        (w->tile_seconds > 0 ? " + " + fmt(w->tile_seconds, 3) + " s building the tile set (" +
                                   std::to_string(tiles.tiles()) + " tiles, once per key)"
                             : std::string()) +
        "; solver " + fmt(w->run_seconds, 3) + " s; " + std::to_string(w->corrections) +
        " wall-model corrections");
    r.notes.push_back(
        w->name + " layers 0-0.25, 0.25-0.5, 0.5-0.75, 0.75-1 rc from the wall, T/T_bulk - 1: " +
        layers_T + "; rho/rho_bulk - 1: " + layers_rho);
  }
  for (const WallResult* w : {&lattice, &tile}) {
    std::ostringstream prof;
    prof << w->name << " profile z: rho, T ->";
    for (std::size_t k = 0; k < w->z.size(); ++k)
      if (w->z[k] > kWallVoxels * kVoxel - 0.25 && w->z[k] < kWallVoxels * kVoxel + 1.5)
        prof << " " << fmt(w->z[k], 4) << ": " << fmt(w->profile_rho[k], 4) << ", "
             << fmt(w->profile_T[k], 4) << ";";
    r.notes.push_back(prof.str());
  }
  r.notes.push_back("tile set: " + tiles.key.str() + ", " + std::to_string(tiles.tiles()) +
                    " tiles, " + check.str());
  return r;
}

}  // namespace

Command add_validate_command(CLI::App& rockprep) {
  struct Args {
    std::string name;
    std::string size = "small";
    std::string kernel = "warren";
    int threads = 0;
    bool json = false;
    bool list = false;
    double dt = 0.01;
    std::string wall_model = "li2018";
  };
  auto a = std::make_shared<Args>();
  CLI::App* app = rockprep.add_subcommand(
      "validate",
      "Physics validation of the packing (packing-walls: tile vs lattice walls next to a fluid); "
      "reports like rockflow validate, exit code 1 when a quantity fails");
  app->add_option("case", a->name, "Case name (see --list)");
  app->add_flag("--list", a->list, "Print the case names");
  app->add_option("--size", a->size, "small (CI) or full")->check(CLI::IsMember({"small", "full"}));
  app->add_option("--density-kernel", a->kernel, "warren or lucy")
      ->check(CLI::IsMember({"warren", "lucy"}));
  app->add_option("--threads", a->threads, "CPU threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  app->add_flag("--json", a->json, "Print one JSON object");
  app->add_option("--dt", a->dt, "Time step of the slit runs (default 0.01)");
  app->add_option("--wall-model", a->wall_model,
                  "li2018 (default) or none (the 2017 paper's dense-wall boundary)")
      ->check(CLI::IsMember({"li2018", "none"}));
  return {app, [a] {
            if (a->list) {
              std::cout << "packing-walls\n";
              return 0;
            }
            if (a->name != "packing-walls")
              throw ConfigError("validate: unknown case '" + a->name + "' (see --list)");
            ValidateOptions o;
            o.size = a->size == "full" ? CaseSize::Full : CaseSize::Small;
            o.density_kernel =
                a->kernel == "lucy" ? sim::DensityKernelKind::Lucy : sim::DensityKernelKind::Warren;
            o.sim.threads = a->threads;
            const auto t0 = Clock::now();
            CaseResult r = run_packing_walls(o, a->dt, a->wall_model == "li2018");
            r.seconds = seconds_since(t0);
            std::cout << (a->json ? format_case_json(r) + "\n" : format_case_text(r));
            return r.pass() ? static_cast<int>(kExitOk) : static_cast<int>(kExitFailed);
          }};
}

}  // namespace mesorock::pipeline::prep
