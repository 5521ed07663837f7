#include "packing/pack.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>

#include "mesorock/errors.h"
#include "sim/init.h"
#include "tiledb/draw.h"

namespace mesorock::packing {

const char* to_string(Fill fill) {
  switch (fill) {
    case Fill::Tiles:
      return "tiles";
    case Fill::Lattice:
      return "lattice";
    case Fill::Random:
      return "random";
  }
  return "?";
}

Fill parse_fill(const std::string& name) {
  if (name == "tiles") return Fill::Tiles;
  if (name == "lattice") return Fill::Lattice;
  if (name == "random") return Fill::Random;
  throw ConfigError("unknown fill '" + name + "' (tiles, lattice or random)");
}

namespace {

constexpr std::uint64_t kStreamRandomPosition = 0x72706f73;  // "rpos"
constexpr std::uint64_t kStreamRandomCount = 0x72636e74;     // "rcnt"
constexpr std::uint64_t kStreamRandomVelocity = 0x7276656c;  // "rvel"
constexpr double kMaxRandomPerVoxel = 65535;                 // particle k of a voxel: 16 bits

// What each role needs in the inner loop, computed once.
struct Prepared {
  const RoleSpec* spec = nullptr;
  std::vector<tiledb::Symmetry> symmetries;
  double lambda = 0;   // random: expected particles per voxel
  double spacing = 0;  // lattice
  double per_voxel_variance = 0;
  double density = 0;
};

struct Layer {
  sim::ParticleSet particles;
  std::vector<RoleCount> counts;
};

// Empties a set but keeps its capacity: the buffers are reused layer after layer, so the packer
// does not fault fresh pages in for every layer.
void clear(sim::ParticleSet& p) {
  for (auto* v : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz}) v->clear();
  p.type.clear();
  p.id.clear();
}

void append(sim::ParticleSet& to, const sim::ParticleSet& from) {
  to.x.insert(to.x.end(), from.x.begin(), from.x.end());
  to.y.insert(to.y.end(), from.y.begin(), from.y.end());
  to.z.insert(to.z.end(), from.z.begin(), from.z.end());
  to.vx.insert(to.vx.end(), from.vx.begin(), from.vx.end());
  to.vy.insert(to.vy.end(), from.vy.begin(), from.vy.end());
  to.vz.insert(to.vz.end(), from.vz.begin(), from.vz.end());
  to.type.insert(to.type.end(), from.type.begin(), from.type.end());
  to.id.insert(to.id.end(), from.id.begin(), from.id.end());
}

class LayerPacker {
 public:
  LayerPacker(const voxel::Volume& codes, const std::vector<Prepared>& roles, const PackOptions& o)
      : codes_(codes), roles_(roles), o_(o), shape_(codes.shape()) {
    for (int a = 0; a < 3; ++a) h_[a] = o.voxel_rc[static_cast<std::size_t>(a)];
  }

  void pack(std::int64_t z, Layer& out) const {
    clear(out.particles);
    out.counts.assign(roles_.size(), RoleCount{});
    const std::uint8_t* row0 = codes_.slice<std::uint8_t>(z);
    // Reserve from the expected counts, so a layer's arrays do not double past their need.
    double expect = 0;
    for (std::int64_t i = 0; i < shape_.slice_voxels(); ++i) {
      const std::uint8_t c = row0[i];
      if (c == 0) continue;
      if (c > roles_.size()) {
        throw ConfigError("voxel code " + std::to_string(c) + " has no role (" +
                          std::to_string(roles_.size()) + " roles)");
      }
      expect += roles_[c - 1u].density * h_[0] * h_[1] * h_[2];
    }
    out.particles.reserve(static_cast<std::size_t>(expect * 1.05 + 16));
    for (std::int64_t y = 0; y < shape_.ny; ++y) {
      const std::uint8_t* row = row0 + y * shape_.nx;
      for (std::int64_t x = 0; x < shape_.nx; ++x) {
        const std::uint8_t c = row[x];
        if (c == 0) continue;
        const Prepared& r = roles_[c - 1u];
        const std::uint64_t voxel = static_cast<std::uint64_t>((z * shape_.ny + y) * shape_.nx + x);
        const std::int64_t idx[3] = {x, y, z};
        const std::size_t before = out.particles.size();
        switch (r.spec->fill) {
          case Fill::Tiles:
            tiles(r, voxel, idx, out.particles);
            break;
          case Fill::Lattice:
            lattice(r, idx, out.particles);
            break;
          case Fill::Random:
            random(r, voxel, idx, out.particles);
            break;
        }
        RoleCount& k = out.counts[c - 1u];
        ++k.voxels;
        k.particles += static_cast<std::int64_t>(out.particles.size() - before);
        k.expected += r.density * h_[0] * h_[1] * h_[2];
        k.variance += r.per_voxel_variance;
      }
    }
  }

 private:
  // The voxel's extent along axis a, computed the same way for both neighbours of a face.
  double lo(int a, std::int64_t i) const {
    return o_.origin[static_cast<std::size_t>(a)] + static_cast<double>(i) * h_[a];
  }
  double hi(int a, std::int64_t i) const { return lo(a, i + 1); }
  double inside(int a, std::int64_t i, double v) const {
    const double l = lo(a, i), u = hi(a, i);
    if (v < l) return l;
    if (v >= u) return std::nextafter(u, l);
    return v;
  }

  void add(sim::ParticleSet& p, const std::int64_t idx[3], const double pos[3], const double vel[3],
           std::int32_t type) const {
    p.add(inside(0, idx[0], pos[0]), inside(1, idx[1], pos[1]), inside(2, idx[2], pos[2]), vel[0],
          vel[1], vel[2], type, 0);
  }

  void tiles(const Prepared& r, std::uint64_t voxel, const std::int64_t idx[3],
             sim::ParticleSet& p) const {
    const tiledb::TileSet& set = *r.spec->tiles;
    const tiledb::TileDraw d = tiledb::draw_tile(o_.seed, voxel, set.tiles(), r.symmetries.size());
    const tiledb::Symmetry& s = r.symmetries[d.symmetry];
    const auto begin = static_cast<std::size_t>(set.offsets[d.tile]);
    const auto end = static_cast<std::size_t>(set.offsets[d.tile + 1]);
    for (std::size_t i = begin; i < end; ++i) {
      const auto u = tiledb::apply_to_position(s, set.key.edge, &set.position[3 * i]);
      const double pos[3] = {lo(0, idx[0]) + u[0], lo(1, idx[1]) + u[1], lo(2, idx[2]) + u[2]};
      double vel[3] = {0, 0, 0};
      if (r.spec->thermal) {
        const auto v = tiledb::apply_to_velocity(s, &set.velocity[3 * i]);
        vel[0] = v[0];
        vel[1] = v[1];
        vel[2] = v[2];
      }
      add(p, idx, pos, vel, r.spec->type);
    }
  }

  void lattice(const Prepared& r, const std::int64_t idx[3], sim::ParticleSet& p) const {
    const double a = r.spacing;
    std::int64_t first[3], last[3];
    for (int k = 0; k < 3; ++k) {
      // Sites (i + 1/2) a from the origin with lo <= site < hi.
      const double l = static_cast<double>(idx[k]) * h_[k];
      const double u = static_cast<double>(idx[k] + 1) * h_[k];
      first[k] = static_cast<std::int64_t>(std::ceil(l / a - 0.5));
      last[k] = static_cast<std::int64_t>(std::ceil(u / a - 0.5));
    }
    const double vel[3] = {0, 0, 0};
    for (std::int64_t k = first[2]; k < last[2]; ++k)
      for (std::int64_t j = first[1]; j < last[1]; ++j)
        for (std::int64_t i = first[0]; i < last[0]; ++i) {
          const double pos[3] = {o_.origin[0] + (static_cast<double>(i) + 0.5) * a,
                                 o_.origin[1] + (static_cast<double>(j) + 0.5) * a,
                                 o_.origin[2] + (static_cast<double>(k) + 0.5) * a};
          add(p, idx, pos, vel, r.spec->type);
        }
  }

  void random(const Prepared& r, std::uint64_t voxel, const std::int64_t idx[3],
              sim::ParticleSet& p) const {
    const double whole = std::floor(r.lambda);
    const double u = sim::seeded_uniform(o_.seed, kStreamRandomCount, voxel, 0);
    const auto n = static_cast<std::uint64_t>(whole) + (u < r.lambda - whole ? 1 : 0);
    const double s = std::sqrt(r.spec->kBT);
    for (std::uint64_t k = 0; k < n; ++k) {
      const std::uint64_t key = (voxel << 16) | k;
      double pos[3], vel[3] = {0, 0, 0};
      for (int a = 0; a < 3; ++a) {
        pos[a] = lo(a, idx[a]) + h_[a] * sim::seeded_uniform(o_.seed, kStreamRandomPosition, key,
                                                             static_cast<std::uint32_t>(a));
        if (r.spec->thermal)
          vel[a] = s * sim::seeded_normal(o_.seed, kStreamRandomVelocity, key,
                                          static_cast<std::uint32_t>(a));
      }
      add(p, idx, pos, vel, r.spec->type);
    }
  }

  const voxel::Volume& codes_;
  const std::vector<Prepared>& roles_;
  const PackOptions& o_;
  voxel::Shape shape_;
  double h_[3];
};

bool same_edge(double a, double b) {
  return std::abs(a - b) <= 1e-6 * std::max(std::abs(a), std::abs(b));
}

}  // namespace

PackStats pack_voxels(const voxel::Volume& codes, const std::vector<RoleSpec>& roles,
                      const PackOptions& o, ParticleSink& sink) {
  const auto t0 = std::chrono::steady_clock::now();
  if (codes.dtype() != voxel::DType::kUInt8)
    throw ConfigError("packing: the voxel codes must be uint8");
  if (roles.size() > 255) throw ConfigError("packing: at most 255 roles");
  for (int a = 0; a < 3; ++a)
    if (!(o.voxel_rc[static_cast<std::size_t>(a)] > 0))
      throw ConfigError("packing: voxel edges must be positive");
  const double voxel_volume = o.voxel_rc[0] * o.voxel_rc[1] * o.voxel_rc[2];
  const voxel::Shape shape = codes.shape();
  if (static_cast<double>(shape.voxels()) >= 281474976710656.0)  // 2^48: voxel << 16 must fit
    throw LimitError("packing: more than 2^48 voxels");

  std::vector<Prepared> prepared(roles.size());
  for (std::size_t k = 0; k < roles.size(); ++k) {
    const RoleSpec& r = roles[k];
    Prepared& p = prepared[k];
    p.spec = &r;
    const std::string where = "packing: role '" + r.name + "': ";
    if (r.fill == Fill::Tiles) {
      if (!r.tiles || r.tiles->tiles() == 0) throw ConfigError(where + "no tiles");
      for (int a = 0; a < 3; ++a)
        if (!same_edge(r.tiles->key.edge[static_cast<std::size_t>(a)],
                       o.voxel_rc[static_cast<std::size_t>(a)]))
          throw ConfigError(where + "the tiles (" + r.tiles->key.str() +
                            ") do not have the voxel's edges");
      p.symmetries = tiledb::box_symmetries(o.voxel_rc);
      p.density = r.tiles->stats.density;
      p.per_voxel_variance = r.tiles->stats.count_std * r.tiles->stats.count_std;
    } else {
      if (!(r.density > 0) || !std::isfinite(r.density))
        throw ConfigError(where + "density must be positive");
      p.density = r.density;
      p.lambda = r.density * voxel_volume;
      p.spacing = std::cbrt(1.0 / r.density);
      if (r.fill == Fill::Random) {
        if (p.lambda > kMaxRandomPerVoxel)
          throw LimitError(where + "more than 65535 particles per voxel");
        const double f = p.lambda - std::floor(p.lambda);
        p.per_voxel_variance = f * (1 - f);
      }
    }
  }

  PackStats stats;
  stats.roles.assign(roles.size(), RoleCount{});
  const int threads = std::max(1, omp_get_max_threads());
  const std::int64_t block = std::max<std::int64_t>(1, 2 * threads);
  LayerPacker packer(codes, prepared, o);
  std::vector<Layer> layers(static_cast<std::size_t>(block));
  sim::ParticleSet pending;
  std::int64_t next_id = o.first_id;
  std::int64_t reported = -1;

  pending.reserve(o.chunk_particles);
  auto flush = [&]() {
    if (pending.size() == 0) return;
    sink.append(pending);
    clear(pending);
  };
  auto take = [&](sim::ParticleSet& p) {
    for (std::size_t i = 0; i < p.size(); ++i) p.id[i] = next_id++;
    // pending never grows past a chunk, so its buffers are allocated once.
    if (pending.size() + p.size() > o.chunk_particles) flush();
    if (p.size() >= o.chunk_particles) {
      sink.append(p);
      return;
    }
    append(pending, p);
  };

  for (std::int64_t z0 = 0; z0 < shape.nz; z0 += block) {
    const std::int64_t z1 = std::min(shape.nz, z0 + block);
    std::exception_ptr error;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::int64_t z = z0; z < z1; ++z) {
      try {
        packer.pack(z, layers[static_cast<std::size_t>(z - z0)]);
      } catch (...) {
#pragma omp critical(packing_error)
        if (!error) error = std::current_exception();
      }
    }
    if (error) std::rethrow_exception(error);
    // What the packer holds: the buffers' capacities (kept from layer to layer).
    std::size_t held = pending.x.capacity();
    for (const Layer& l : layers) held += l.particles.x.capacity();
    stats.peak_buffer_bytes = std::max(stats.peak_buffer_bytes, held * kParticleBytes);
    for (std::int64_t z = z0; z < z1; ++z) {
      Layer& l = layers[static_cast<std::size_t>(z - z0)];
      for (std::size_t k = 0; k < roles.size(); ++k) {
        stats.roles[k].voxels += l.counts[k].voxels;
        stats.roles[k].particles += l.counts[k].particles;
        stats.roles[k].expected += l.counts[k].expected;
        stats.roles[k].variance += l.counts[k].variance;
      }
      take(l.particles);
    }
    if (o.progress) {
      const std::int64_t tenth = z1 * 10 / shape.nz;
      if (tenth != reported) {
        reported = tenth;
        o.progress(static_cast<double>(z1) / static_cast<double>(shape.nz));
      }
    }
  }
  flush();
  for (const RoleCount& r : stats.roles) {
    stats.particles += r.particles;
    stats.voxels_filled += r.voxels;
  }
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return stats;
}

}  // namespace mesorock::packing
