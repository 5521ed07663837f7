#include "tiledb/tile_set.h"

#include <cmath>
#include <sstream>

#include "mesorock/errors.h"

namespace mesorock::tiledb {

const char* to_string(TileRole role) {
  return role == TileRole::Wall ? "wall" : "fluid";
}

TileRole parse_tile_role(const std::string& name) {
  if (name == "wall") return TileRole::Wall;
  if (name == "fluid") return TileRole::Fluid;
  throw ConfigError("unknown tile role '" + name + "' (wall or fluid)");
}

std::string TileKey::str() const {
  std::ostringstream s;
  s.precision(6);
  s << to_string(role) << ", rho " << density << ", tile " << edge[0] << " x " << edge[1] << " x "
    << edge[2] << " rc, A " << A << " B " << B << " rd " << rd << " gamma " << gamma << " kBT "
    << kBT << " (" << sim::to_string(density_kernel) << ")";
  return s.str();
}

namespace {
bool same(double a, double b) {
  return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)) || a == b;
}
}  // namespace

bool TileKey::matches(const TileKey& o) const {
  return role == o.role && density_kernel == o.density_kernel && same(density, o.density) &&
         same(edge[0], o.edge[0]) && same(edge[1], o.edge[1]) && same(edge[2], o.edge[2]) &&
         same(A, o.A) && same(B, o.B) && same(rd, o.rd) && same(gamma, o.gamma) && same(kBT, o.kBT);
}

void TileKey::validate() const {
  auto positive = [](double v, const char* what) {
    if (!(v > 0) || !std::isfinite(v))
      throw ConfigError(std::string("tile key: ") + what + " must be a positive number");
  };
  positive(density, "density");
  for (double e : edge) positive(e, "tile edges");
  positive(rd, "rd");
  positive(kBT, "kBT");
  if (rd > 1) throw ConfigError("tile key: rd must be at most 1 (rc)");
  if (!std::isfinite(A)) throw ConfigError("tile key: A must be finite");
  if (!(B >= 0) || !std::isfinite(B)) throw ConfigError("tile key: B must be >= 0");
  if (!(gamma > 0) || !std::isfinite(gamma))
    throw ConfigError("tile key: gamma must be positive (the thermostat equilibrates the box)");
}

std::size_t TileSet::bytes() const {
  return offsets.size() * sizeof(std::int64_t) +
         (position.size() + velocity.size()) * sizeof(double);
}

void measure_tiles(TileSet& set) {
  const std::size_t n = set.tiles();
  const double np = static_cast<double>(set.particles());
  set.stats.density = n > 0 ? np / (static_cast<double>(n) * set.tile_volume()) : 0.0;
  double v2 = 0;
  for (double v : set.velocity) v2 += v * v;
  set.stats.temperature_at_cuts = np > 0 ? v2 / (3 * np) : 0.0;
  set.stats.mean_count = n > 0 ? np / static_cast<double>(n) : 0.0;
  double var = 0;
  for (std::size_t t = 0; t < n; ++t) {
    const double d =
        static_cast<double>(set.offsets[t + 1] - set.offsets[t]) - set.stats.mean_count;
    var += d * d;
  }
  set.stats.count_std = n > 1 ? std::sqrt(var / static_cast<double>(n - 1)) : 0.0;
}

}  // namespace mesorock::tiledb
