// Voxels to particles: counts within 3 standard deviations of voxel volume x density, no particle
// outside a voxel of its role (no wall particle in a pore voxel), the same particles for any
// thread count and chunk size, streaming into a file, and memory that follows the layers.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <fstream>

#include "mesorock/errors.h"
#include "packing/pack.h"
#include "packing/sink.h"
#include "sim/particle_io.h"
#include "support/test_support.h"
#include "tiledb/generate.h"

namespace mesorock::packing {
namespace {

using mesorock::test::TempDir;

// A 0.5 rc wall set shared by the tests (about a second to build).
const tiledb::TileSet& wall_tiles() {
  static const tiledb::TileSet set = [] {
    tiledb::TileKey key;
    key.density = 8;
    key.edge = {0.5, 0.5, 0.5};
    tiledb::TileBuildOptions o;
    o.variants = 500;
    o.min_box_edge = 4;
    o.equilibration_steps = 600;
    o.seed = 11;
    o.sim.threads = 1;  // a small box: one thread is faster (same result)
    return tiledb::build_tile_set(key, o);
  }();
  return set;
}

// Codes: 1 (wall) in a spherical shell, 2 (fluid) inside it, 0 elsewhere, plus a sprinkle of
// isolated wall voxels in the fluid (a rough wall).
voxel::Volume shell_codes(int n) {
  voxel::Volume v(voxel::Shape{n, n, n}, voxel::DType::kUInt8);
  std::uint8_t* p = v.data<std::uint8_t>();
  const double c = 0.5 * n;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double r = std::sqrt((x + 0.5 - c) * (x + 0.5 - c) + (y + 0.5 - c) * (y + 0.5 - c) +
                                   (z + 0.5 - c) * (z + 0.5 - c));
        std::uint8_t code = r < 0.3 * n ? 2 : r < 0.45 * n ? 1 : 0;
        if (code == 2 && (x * 7 + y * 13 + z * 29) % 23 == 0) code = 1;
        p[(static_cast<std::int64_t>(z) * n + y) * n + x] = code;
      }
  return v;
}

std::vector<RoleSpec> roles_for(Fill wall, Fill fluid) {
  std::vector<RoleSpec> r(2);
  r[0].name = "wall";
  r[0].type = 1;
  r[0].fill = wall;
  r[0].density = 8;
  r[0].tiles = &wall_tiles();
  r[1].name = "fluid";
  r[1].type = 0;
  r[1].fill = fluid;
  r[1].density = 6.5;
  r[1].thermal = true;
  return r;
}

// The code of the voxel a particle sits in (-1 outside the volume).
int code_at(const voxel::Volume& codes, const PackOptions& o, double x, double y, double z) {
  const double p[3] = {x, y, z};
  std::int64_t i[3];
  const std::int64_t n[3] = {codes.shape().nx, codes.shape().ny, codes.shape().nz};
  for (int a = 0; a < 3; ++a) {
    i[a] = static_cast<std::int64_t>(
        std::floor((p[a] - o.origin[static_cast<size_t>(a)]) / o.voxel_rc[static_cast<size_t>(a)]));
    if (i[a] < 0 || i[a] >= n[a]) return -1;
  }
  return codes.data<std::uint8_t>()[(i[2] * n[1] + i[1]) * n[0] + i[0]];
}

TEST(Pack, CountsWithinThreeSigmaAndParticlesInTheirVoxels) {
  const voxel::Volume codes = shell_codes(40);
  PackOptions o;
  o.voxel_rc = {0.5, 0.5, 0.5};
  o.origin = {-3.0, 1.0, 2.0};
  o.seed = 5;
  for (Fill fluid : {Fill::Random, Fill::Tiles}) {
    std::vector<RoleSpec> roles = roles_for(Fill::Tiles, fluid);
    if (fluid == Fill::Tiles) roles[1].tiles = &wall_tiles();  // any set of the voxel's shape
    MemorySink sink;
    const PackStats st = pack_voxels(codes, roles, o, sink);
    ASSERT_EQ(sink.particles.size(), static_cast<size_t>(st.particles));
    for (int r = 0; r < 2; ++r) {
      const RoleCount& k = st.roles[static_cast<size_t>(r)];
      const double density = roles[static_cast<size_t>(r)].fill == Fill::Tiles
                                 ? wall_tiles().stats.density
                                 : roles[static_cast<size_t>(r)].density;
      // Acceptance: within 3 standard deviations of voxel volume x density.
      EXPECT_NEAR(k.expected, k.voxels * 0.125 * density, 1e-6 * k.expected);
      const double sigma = std::sqrt(k.variance);
      EXPECT_GT(sigma, 0.0);
      EXPECT_LE(std::abs(k.particles - k.expected), 3 * sigma)
          << "role " << r << ": " << k.particles << " particles, expected " << k.expected << " +- "
          << sigma;
      // The Poisson standard deviation bounds the packings' (a liquid fluctuates less).
      EXPECT_LE(sigma, std::sqrt(k.expected));
    }
    // No particle outside a voxel of its own role: no wall particle in a pore voxel.
    const sim::ParticleSet& p = sink.particles;
    for (size_t i = 0; i < p.size(); ++i) {
      const int c = code_at(codes, o, p.x[i], p.y[i], p.z[i]);
      ASSERT_EQ(c, p.type[i] == 1 ? 1 : 2) << "particle " << i;
      ASSERT_EQ(p.id[i], static_cast<std::int64_t>(i));
      if (p.type[i] == 1) ASSERT_EQ(p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i], 0);
    }
    // Fluid velocities are thermal.
    double v2 = 0;
    std::int64_t nf = 0;
    for (size_t i = 0; i < p.size(); ++i)
      if (p.type[i] == 0) {
        v2 += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
        ++nf;
      }
    EXPECT_NEAR(v2 / (3.0 * nf), 1.0, 0.05);
  }
}

TEST(Pack, SameParticlesForAnyThreadCountAndChunk) {
  const voxel::Volume codes = shell_codes(24);
  PackOptions o;
  o.seed = 9;
  const std::vector<RoleSpec> roles = roles_for(Fill::Tiles, Fill::Random);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  MemorySink one;
  pack_voxels(codes, roles, o, one);
  omp_set_num_threads(2);
  o.chunk_particles = 100;
  MemorySink two;
  pack_voxels(codes, roles, o, two);
  omp_set_num_threads(saved);
  EXPECT_EQ(one.particles.x, two.particles.x);
  EXPECT_EQ(one.particles.vz, two.particles.vz);
  EXPECT_EQ(one.particles.type, two.particles.type);
  EXPECT_EQ(one.particles.id, two.particles.id);
  // Another seed gives other particles.
  o.seed = 10;
  MemorySink other;
  pack_voxels(codes, roles, o, other);
  EXPECT_NE(one.particles.x, other.particles.x);
}

TEST(Pack, LatticeFillsWithTheLatticeSites) {
  // 0.5 rc voxels at density 8: one site per voxel, at its centre.
  voxel::Volume codes(voxel::Shape{3, 4, 5}, voxel::DType::kUInt8);
  std::fill(codes.data<std::uint8_t>(), codes.data<std::uint8_t>() + codes.voxels(), 1);
  codes.data<std::uint8_t>()[7] = 0;
  std::vector<RoleSpec> roles = roles_for(Fill::Lattice, Fill::Random);
  PackOptions o;
  MemorySink sink;
  const PackStats st = pack_voxels(codes, roles, o, sink);
  EXPECT_EQ(st.particles, 59);
  EXPECT_EQ(st.roles[0].variance, 0.0);
  for (size_t i = 0; i < sink.particles.size(); ++i) {
    EXPECT_NEAR(std::fmod(sink.particles.x[i], 0.5), 0.25, 1e-12);
    EXPECT_NEAR(std::fmod(sink.particles.z[i], 0.5), 0.25, 1e-12);
  }
  // A coarser voxel (1 rc, density 8): 2 x 2 x 2 sites per voxel.
  o.voxel_rc = {1.0, 1.0, 1.0};
  MemorySink coarse;
  EXPECT_EQ(pack_voxels(codes, roles, o, coarse).particles, 59 * 8);
}

TEST(Pack, RejectsBadRoles) {
  voxel::Volume codes(voxel::Shape{2, 2, 2}, voxel::DType::kUInt8);
  std::fill(codes.data<std::uint8_t>(), codes.data<std::uint8_t>() + 8, 3);  // no role 3
  PackOptions o;
  MemorySink sink;
  EXPECT_THROW(pack_voxels(codes, roles_for(Fill::Tiles, Fill::Random), o, sink), ConfigError);
  std::fill(codes.data<std::uint8_t>(), codes.data<std::uint8_t>() + 8, 1);
  o.voxel_rc = {0.5, 0.5, 1.0};  // the tiles are 0.5 cubes
  EXPECT_THROW(pack_voxels(codes, roles_for(Fill::Tiles, Fill::Random), o, sink), ConfigError);
  std::vector<RoleSpec> r = roles_for(Fill::Lattice, Fill::Random);
  r[0].density = 0;
  o.voxel_rc = {0.5, 0.5, 0.5};
  EXPECT_THROW(pack_voxels(codes, r, o, sink), ConfigError);
}

TEST(Pack, StreamsIntoAParticleFileAndALammpsFile) {
  TempDir dir;
  const voxel::Volume codes = shell_codes(20);
  PackOptions o;
  o.chunk_particles = 500;  // several appends
  const std::vector<RoleSpec> roles = roles_for(Fill::Tiles, Fill::Random);
  MemorySink memory;
  const PackStats st = pack_voxels(codes, roles, o, memory);
  sim::ParticleFileMeta meta;
  meta.type_names = {"fluid", "wall"};
  meta.box.lo = {0, 0, 0};
  meta.box.hi = {10, 10, 10};
  meta.box.periodic = {false, false, false};
  meta.created_by = "test";
  {
    ParticleFileSink file(dir / "p.h5", meta);
    LammpsDataSink lammps(dir / "p.data", meta.type_names, meta.box, "test");
    TeeSink tee({&file, &lammps});
    pack_voxels(codes, roles, o, tee);
    EXPECT_FALSE(std::filesystem::exists(dir / "p.h5")) << "visible before commit";
    file.commit();
    lammps.commit();
  }
  sim::ParticleFileMeta back_meta;
  const sim::ParticleSet back = sim::read_particle_file(dir / "p.h5", &back_meta);
  EXPECT_EQ(back.x, memory.particles.x);
  EXPECT_EQ(back.vy, memory.particles.vy);
  EXPECT_EQ(back.type, memory.particles.type);
  EXPECT_EQ(back.id, memory.particles.id);
  EXPECT_EQ(back_meta.type_names, meta.type_names);
  EXPECT_EQ(back_meta.created_by, "test");
  const std::string data = mesorock::test::read_file(dir / "p.data");
  EXPECT_NE(data.find(std::to_string(st.particles) + " atoms\n2 atom types"), std::string::npos);
  EXPECT_NE(data.find("Atoms  # atomic"), std::string::npos);
  EXPECT_NE(data.find("Velocities"), std::string::npos);
  EXPECT_NE(data.find("\n1 "), std::string::npos);  // ids start at 1
  // A writer that never commits leaves nothing behind.
  {
    ParticleFileSink file(dir / "q.h5", meta);
    LammpsDataSink lammps(dir / "q.data", meta.type_names, meta.box, "test");
    pack_voxels(codes, roles, o, file);
  }
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_TRUE(e.path().filename() == "p.h5" || e.path().filename() == "p.data") << e.path();
}

// A sink that only counts: what pack_voxels holds is its own buffer.
class CountingSink : public ParticleSink {
 public:
  void append(const sim::ParticleSet& c) override {
    particles += static_cast<std::int64_t>(c.size());
    ++chunks;
  }
  std::int64_t particles = 0, chunks = 0;
};

TEST(Pack, BufferFollowsTheLayersNotTheBox) {
  // 64 x 64 x 256 voxels of fluid and wall: about a million particles; the packer holds a few
  // layers (2 per thread) plus one chunk.
  voxel::Volume codes(voxel::Shape{256, 64, 64}, voxel::DType::kUInt8);
  std::uint8_t* p = codes.data<std::uint8_t>();
  for (std::int64_t i = 0; i < codes.voxels(); ++i) p[i] = (i / 64) % 3 == 0 ? 1 : 2;
  PackOptions o;
  o.chunk_particles = 20000;
  CountingSink sink;
  const PackStats st = pack_voxels(codes, roles_for(Fill::Tiles, Fill::Random), o, sink);
  EXPECT_EQ(sink.particles, st.particles);
  EXPECT_GT(sink.chunks, 10);
  const double total = static_cast<double>(st.particles) * kParticleBytes;
  const double per_layer = total / 256;
  EXPECT_LE(static_cast<double>(st.peak_buffer_bytes),
            (2.0 * omp_get_max_threads() + 1) * per_layer * 1.2 + 20000.0 * kParticleBytes);
  EXPECT_LT(static_cast<double>(st.peak_buffer_bytes), 0.1 * total);
}

}  // namespace
}  // namespace mesorock::packing
