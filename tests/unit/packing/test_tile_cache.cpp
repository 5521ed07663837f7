// The shared tile cache of `rockprep run` (docs/packing.md, "Tile cache"): a second run with the
// same fluid and tile options builds no tiles and packs the same particles; other options miss;
// --tile-cache none and --tiles leave the cache alone; a damaged cache file is rebuilt.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>

#include "sim/particle_io.h"
#include "support/test_support.h"

namespace {

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::run_command;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

// A 12 x 16 x 20 voxel synthetic shale and `rockprep run` of it with small tile sets.
struct Stack {
  TempDir dir;
  Stack() {
    const CommandResult r = run_command(
        shell_quote(MESOROCK_ROCKPREP) +
            " synth --shape 12,16,20 --spacing 1,1,1 --unit nm --porosity 0.35 --organic 0.5"
            " --blob 5 --pore-radius 2.5 --matrix-pores 0.5 --noise 10 --seed 3 --quiet --out " +
            shell_quote((dir / "syn").string()),
        dir.path());
    EXPECT_EQ(r.exit_code, 0) << r.err;
  }
  CommandResult run(const std::string& out, const std::string& extra) const {
    return run_command("OMP_NUM_THREADS=1 " + shell_quote(MESOROCK_ROCKPREP) + " run " +
                           shell_quote((dir / "syn/truth.mhd").string()) +
                           " --rc-per-voxel 0.5 --layout permeability --tile-variants 500"
                           " --tile-box-edge 4 --tile-relax-steps 100 --tile-equilibrate-steps 1000"
                           " --seed 5 --out " +
                           shell_quote((dir / out).string()) + " " + extra,
                       dir.path());
  }
  nlohmann::json record(const std::string& out) const {
    return nlohmann::json::parse(mesorock::test::read_file(dir / out / "run.json"));
  }
};

std::vector<std::string> files_in(const fs::path& d) {
  std::vector<std::string> out;
  std::error_code ec;
  if (fs::exists(d, ec))
    for (const auto& e : fs::directory_iterator(d)) out.push_back(e.path().filename().string());
  return out;
}

TEST(TileCache, ASecondRunBuildsNoTilesAndPacksTheSameParticles) {
  Stack s;
  const fs::path cache = s.dir / "cache";
  const std::string with_cache = "--tile-cache " + shell_quote(cache.string());
  const CommandResult first = s.run("a", with_cache);
  ASSERT_EQ(first.exit_code, 0) << first.out << first.err;
  const auto ra = s.record("a");
  EXPECT_EQ(ra["tiles"]["source"]["wall"], "built");
  EXPECT_EQ(ra["tiles"]["source"]["fluid"], "built");
  EXPECT_EQ(ra["tiles"]["built_here"], true);
  EXPECT_EQ(files_in(cache).size(), 2u);  // one file per set

  const CommandResult second = s.run("b", with_cache);
  ASSERT_EQ(second.exit_code, 0) << second.out << second.err;
  const auto rb = s.record("b");
  EXPECT_EQ(rb["tiles"]["source"]["wall"], "cache");
  EXPECT_EQ(rb["tiles"]["source"]["fluid"], "cache");
  EXPECT_EQ(rb["tiles"]["built_here"], false);
  EXPECT_NE(second.out.find("from the tile cache"), std::string::npos) << second.out;
  // The same tiles, so the same particles, bit for bit.
  const auto pa = mesorock::sim::read_particle_file(s.dir / "a" / "particles.h5");
  const auto pb = mesorock::sim::read_particle_file(s.dir / "b" / "particles.h5");
  EXPECT_EQ(pa.x, pb.x);
  EXPECT_EQ(pa.y, pb.y);
  EXPECT_EQ(pa.z, pb.z);
  EXPECT_EQ(pa.vx, pb.vx);
  EXPECT_EQ(pa.type, pb.type);

  // Other tile options are another set: built, and cached beside the first two.
  const CommandResult other = s.run("c", with_cache + " --tile-seed 2");
  ASSERT_EQ(other.exit_code, 0) << other.err;
  EXPECT_EQ(s.record("c")["tiles"]["source"]["wall"], "built");
  EXPECT_EQ(files_in(cache).size(), 4u);

  // --tile-cache none builds and leaves the cache alone.
  const CommandResult none = s.run("d", "--tile-cache none");
  ASSERT_EQ(none.exit_code, 0) << none.err;
  EXPECT_EQ(s.record("d")["tiles"]["source"]["fluid"], "built");
  EXPECT_EQ(s.record("d")["tiles"]["cache"], "none");
  EXPECT_EQ(files_in(cache).size(), 4u);
}

TEST(TileCache, ADamagedCacheFileIsBuiltAgainAndReplaced) {
  Stack s;
  const fs::path cache = s.dir / "cache";
  const std::string with_cache = "--tile-cache " + shell_quote(cache.string());
  ASSERT_EQ(s.run("a", with_cache).exit_code, 0);
  for (const std::string& f : files_in(cache)) std::ofstream(cache / f) << "not a tile database";
  const CommandResult r = s.run("b", with_cache);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("unreadable, building it again"), std::string::npos) << r.out;
  EXPECT_EQ(s.record("b")["tiles"]["source"]["wall"], "built");
  const CommandResult again = s.run("c", with_cache);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(s.record("c")["tiles"]["source"]["wall"], "cache");
}

}  // namespace
