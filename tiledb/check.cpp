// The acceptance checks of a tile set (tiledb/database.h).
#include <cmath>
#include <cstdio>
#include <sstream>

#include "tiledb/database.h"

namespace mesorock::tiledb {

namespace {
std::string percent(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%+.3f%%", 100 * x);
  return buf;
}
}  // namespace

TileCheck check_tile_set(const TileSet& set, const TileCheckOptions& o) {
  TileCheck c;
  auto problem = [&](const std::string& p) {
    c.pass = false;
    c.problems.push_back(p);
  };
  const TileKey& k = set.key;
  if (set.offsets.empty() || set.offsets.front() != 0 ||
      set.offsets.back() != static_cast<std::int64_t>(set.particles())) {
    problem("offsets do not run from 0 to the particle count");
    return c;
  }
  if (set.velocity.size() != set.position.size()) problem("velocity and position differ in length");
  if (set.tiles() == 0) problem("no tiles");
  std::size_t outside = 0;
  for (std::size_t t = 0; t < set.tiles(); ++t) {
    if (set.offsets[t + 1] < set.offsets[t]) {
      problem("offsets decrease at tile " + std::to_string(t));
      return c;
    }
    for (auto i = static_cast<std::size_t>(set.offsets[t]);
         i < static_cast<std::size_t>(set.offsets[t + 1]); ++i)
      for (int a = 0; a < 3; ++a) {
        const double u = set.position[3 * i + static_cast<std::size_t>(a)];
        if (!(u >= 0 && u < k.edge[static_cast<std::size_t>(a)])) ++outside;
      }
  }
  if (outside > 0) problem(std::to_string(outside) + " coordinates lie outside their tile");

  // What the data give must be what the file records.
  TileSet measured;
  measured.key = k;
  measured.offsets = set.offsets;
  measured.position = set.position;
  measured.velocity = set.velocity;
  measure_tiles(measured);
  if (std::abs(measured.stats.density - set.stats.density) > 1e-9 * k.density)
    problem("recorded density " + std::to_string(set.stats.density) + " differs from the data's " +
            std::to_string(measured.stats.density));

  c.density_deviation = measured.stats.density / k.density - 1;
  c.temperature_deviation = set.stats.temperature / k.kBT - 1;
  if (std::abs(c.density_deviation) > o.density_tolerance)
    problem("density " + std::to_string(measured.stats.density) + " is " +
            percent(c.density_deviation) + " off the target " + std::to_string(k.density) +
            " (tolerance " + percent(o.density_tolerance) + ")");
  if (std::abs(c.temperature_deviation) > o.temperature_tolerance)
    problem("temperature " + std::to_string(set.stats.temperature) + " is " +
            percent(c.temperature_deviation) + " off kBT " + std::to_string(k.kBT) +
            " (tolerance " + percent(o.temperature_tolerance) + ")");
  return c;
}

std::string TileCheck::str() const {
  std::ostringstream s;
  if (pass) {
    s << "pass: density " << percent(density_deviation) << ", temperature "
      << percent(temperature_deviation);
  } else {
    s << "FAIL:";
    for (std::size_t i = 0; i < problems.size(); ++i) s << (i ? ";" : "") << " " << problems[i];
  }
  return s.str();
}

}  // namespace mesorock::tiledb
