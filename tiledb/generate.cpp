#include "tiledb/generate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/init.h"

namespace mesorock::tiledb {

namespace {

constexpr std::uint64_t kStreamCut = 0x637574;  // "cut"
constexpr std::int64_t kMaxBoxParticles = 2'000'000;
constexpr std::uint64_t kTemperatureEvery = 10;

void say(const TileBuildOptions& o, const std::string& line) {
  if (o.progress) o.progress(line);
}

// Mean and its standard error from `blocks` block means (the samples are correlated in time).
void block_mean(const std::vector<double>& x, double* mean, double* error) {
  const std::size_t n = x.size();
  *mean = 0;
  *error = 0;
  if (n == 0) return;
  for (double v : x) *mean += v;
  *mean /= static_cast<double>(n);
  const std::size_t blocks = std::min<std::size_t>(10, n);
  const std::size_t per = n / blocks;
  if (blocks < 2 || per == 0) return;
  std::vector<double> m(blocks, 0.0);
  for (std::size_t b = 0; b < blocks; ++b) {
    for (std::size_t i = b * per; i < (b + 1) * per; ++i) m[b] += x[i];
    m[b] /= static_cast<double>(per);
  }
  double mm = 0, var = 0;
  for (double v : m) mm += v;
  mm /= static_cast<double>(blocks);
  for (double v : m) var += (v - mm) * (v - mm);
  *error = std::sqrt(var / static_cast<double>(blocks - 1) / static_cast<double>(blocks));
}

// Cuts one snapshot into tiles_per_box tiles (grid shifted by `shift`, periodic) and appends them.
void cut_snapshot(const sim::ParticleSet& p, const sim::BoxSpec& box, const TileKey& key,
                  const std::array<int, 3>& n, const std::array<double, 3>& shift, TileSet& set) {
  const std::size_t tiles = static_cast<std::size_t>(n[0]) * n[1] * n[2];
  std::vector<std::size_t> tile_of(p.size());
  std::vector<std::array<double, 3>> local(p.size());
  std::vector<std::int64_t> count(tiles + 1, 0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double pos[3] = {p.x[i], p.y[i], p.z[i]};
    std::array<int, 3> idx{};
    for (int a = 0; a < 3; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      const double L = box.length(a), e = key.edge[ua];
      double q = std::fmod(pos[a] - box.lo[ua] - shift[ua], L);
      if (q < 0) q += L;
      int k = static_cast<int>(std::floor(q / e));
      k = std::clamp(k, 0, n[ua] - 1);
      double u = q - k * e;
      // Round-off at the tile's faces: keep the point inside [0, e).
      if (u < 0) u = 0;
      if (u >= e) u = std::nextafter(e, 0.0);
      idx[ua] = k;
      local[i][ua] = u;
    }
    tile_of[i] = (static_cast<std::size_t>(idx[2]) * n[1] + idx[1]) * n[0] + idx[0];
    ++count[tile_of[i] + 1];
  }
  for (std::size_t t = 0; t < tiles; ++t) count[t + 1] += count[t];
  const std::size_t base = set.particles();
  set.position.resize(3 * (base + p.size()));
  set.velocity.resize(3 * (base + p.size()));
  std::vector<std::int64_t> fill(count.begin(), count.end() - 1);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t slot = base + static_cast<std::size_t>(fill[tile_of[i]]++);
    for (int a = 0; a < 3; ++a)
      set.position[3 * slot + static_cast<std::size_t>(a)] = local[i][static_cast<std::size_t>(a)];
    set.velocity[3 * slot] = p.vx[i];
    set.velocity[3 * slot + 1] = p.vy[i];
    set.velocity[3 * slot + 2] = p.vz[i];
  }
  const std::int64_t offset0 = set.offsets.back();
  for (std::size_t t = 0; t < tiles; ++t) set.offsets.push_back(offset0 + count[t + 1]);
}

}  // namespace

TileSet build_tile_set(const TileKey& key, const TileBuildOptions& o) {
  key.validate();
  if (o.variants < 1) throw ConfigError("tiles: variants must be at least 1");
  if (!(o.dt > 0) || o.dt > 0.1) throw ConfigError("tiles: dt must be in (0, 0.1]");
  if (!(o.min_box_edge >= 2)) {
    throw ConfigError("tiles: the box edge must be at least 2 rc (periodic minimum image)");
  }
  const auto t0 = std::chrono::steady_clock::now();

  sim::Model model;
  model.types.push_back({"tile", false, {0, 0, 0}});
  model.pairs.assign(1, sim::PairSpec{key.A, key.B, key.gamma});
  model.conservative = sim::ConservativeKind::MDPD;
  model.density_kernel = key.density_kernel;
  model.rd = key.rd;
  model.kBT = key.kBT;
  model.thermostat = true;
  model.seed = o.seed;

  sim::BoxSpec box;
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    n[ua] = std::max(1, static_cast<int>(std::ceil(o.min_box_edge / key.edge[ua] - 1e-9)));
    box.lo[ua] = 0;
    box.hi[ua] = n[ua] * key.edge[ua];
    box.periodic[ua] = true;
  }
  const double volume = box.volume();
  const auto count = static_cast<std::int64_t>(std::llround(key.density * volume));
  if (count > kMaxBoxParticles) {
    throw ConfigError("tiles: the equilibration box would hold " + std::to_string(count) +
                      " particles (more than " + std::to_string(kMaxBoxParticles) +
                      "); use smaller tiles or a smaller --box-edge");
  }
  if (count < 2) throw ConfigError("tiles: the equilibration box holds fewer than 2 particles");
  const std::size_t per_box = static_cast<std::size_t>(n[0]) * n[1] * n[2];
  const int cuts = static_cast<int>((o.variants + per_box - 1) / per_box);

  sim::ParticleSet p;
  std::int64_t next_id = 0;
  sim::fill_random(p, 0, box.lo, box.hi, count, o.seed, next_id);
  sim::assign_maxwell_velocities(p, model, key.kBT, o.seed ^ 0x9e3779b97f4a7c15ull);

  TileSet set;
  set.key = key;
  set.build.seed = o.seed;
  set.build.relax_steps = o.relax_steps;
  set.build.equilibration_steps = o.equilibration_steps;
  set.build.decorrelation_steps = o.decorrelation_steps;
  set.build.dt = o.dt;
  set.build.box = {box.hi[0], box.hi[1], box.hi[2]};
  set.build.tiles_per_box = n;
  set.build.cuts = cuts;
  set.build.box_particles = count;
  set.build.mesorock_version = kVersion;
  set.build.git_commit = kGitCommit;
  set.build.provenance_json = o.provenance_json;
  set.offsets.assign(1, 0);
  set.position.reserve(3 * static_cast<std::size_t>(count) * static_cast<std::size_t>(cuts));
  set.velocity.reserve(set.position.capacity());

  {
    std::ostringstream s;
    s.precision(4);
    s << "tiles " << key.str() << ": box " << box.hi[0] << " x " << box.hi[1] << " x " << box.hi[2]
      << " rc, " << count << " particles, " << per_box << " tiles per cut, " << cuts << " cut"
      << (cuts == 1 ? "" : "s");
    say(o, s.str());
  }
  auto simulation = sim::make_simulation(model, box, p, o.dt / 5, o.sim);
  set.build.backend = simulation->backend_name();
  // Where the build stands: steps done of all it will run, the time so far and the time left at
  // the rate so far (a relax step costs what any other step costs).
  const std::uint64_t total_steps = o.relax_steps + o.equilibration_steps +
                                    static_cast<std::uint64_t>(cuts - 1) * o.decorrelation_steps;
  auto standing = [&] {
    const double done = static_cast<double>(simulation->step());
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::ostringstream s;
    s.precision(3);
    s << "step " << simulation->step() << " of " << total_steps << ", " << seconds << " s";
    if (done > 0 && done < static_cast<double>(total_steps))
      s << ", ETA " << seconds * (static_cast<double>(total_steps) - done) / done << " s";
    return s.str();
  };
  simulation->run(o.relax_steps);
  simulation->set_dt(o.dt);
  say(o, "  relaxed (" + standing() + ")");
  // Temperature samples: the second half of the equilibration and every decorrelation span.
  std::vector<double> temperatures;
  const std::uint64_t first_half = o.equilibration_steps / 2;
  simulation->run(first_half);
  auto sample = [&](std::uint64_t steps) {
    std::uint64_t done = 0;
    while (done < steps) {
      const std::uint64_t k = std::min(kTemperatureEvery, steps - done);
      simulation->run(k);
      done += k;
      temperatures.push_back(simulation->kinetic_temperature());
    }
  };
  sample(o.equilibration_steps - first_half);
  say(o, "  equilibrated (" + standing() + ")");
  for (int c = 0; c < cuts; ++c) {
    if (c > 0) sample(o.decorrelation_steps);
    const sim::ParticleSet snapshot = simulation->particles();
    std::array<double, 3> shift{};
    for (int a = 0; a < 3; ++a)
      shift[static_cast<std::size_t>(a)] =
          sim::seeded_uniform(o.seed, kStreamCut, static_cast<std::uint64_t>(c),
                              static_cast<std::uint32_t>(a)) *
          key.edge[static_cast<std::size_t>(a)];
    cut_snapshot(snapshot, box, key, n, shift, set);
    if (cuts > 1 && ((c + 1) % std::max(1, cuts / 10) == 0 || c + 1 == cuts)) {
      say(o, "  cut " + std::to_string(c + 1) + " of " + std::to_string(cuts) + " (" + standing() +
                 ")");
    }
  }
  block_mean(temperatures, &set.stats.temperature, &set.stats.temperature_error);
  measure_tiles(set);
  set.build.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  {
    std::ostringstream s;
    s.precision(5);
    s << "  " << set.tiles() << " tiles, " << set.particles() << " particles: density "
      << set.stats.density << " (target " << key.density << "), T " << set.stats.temperature
      << " +- " << set.stats.temperature_error << " (kBT " << key.kBT << "), " << set.build.seconds
      << " s";
    say(o, s.str());
  }
  return set;
}

}  // namespace mesorock::tiledb
