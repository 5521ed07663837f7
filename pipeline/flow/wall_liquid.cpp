#include "pipeline/flow/wall_liquid.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "sim/init.h"
#include "sim/simulation.h"
#include "sim/wall_model.h"

namespace mesorock::pipeline::wall_liquid {

// Walls are frozen liquid: this is the packing of Liu et al. that the 2020 paper describes,
// affordable here because the boxes are small; it gives the wall the liquid's own structure and
// density, which is what the wall model's no-slip derivation assumes.
BuiltSystem liquid_with_walls(const double L[3], const std::array<bool, 3>& periodic,
                              const SolidDepth& depth, double thickness, std::uint64_t equilibrate,
                              std::uint64_t seed, const ValidateOptions& o) {
  BuiltSystem bulk =
      make_bulk_mdpd(kA, kB, kRd, kGamma, kRho, L, seed + o.seed_offset, o.density_kernel);
  {
    auto sim = sim::make_simulation(bulk.model, bulk.box, bulk.particles, 0.01, o.sim);
    sim->run(equilibrate);
    bulk.particles = sim->particles();
  }
  BuiltSystem s;
  s.model = bulk.model;
  s.model.add_type({"wall", true, {0, 0, 0}});
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) s.model.set_pair(a, b, {kA, kB, kGamma});
  s.model.wall_model.enabled = true;
  s.model.wall_model.wall_density = kRho;  // the frozen liquid keeps the liquid's density
  s.box = bulk.box;
  s.box.periodic = periodic;
  const sim::ParticleSet& p = bulk.particles;
  for (size_t i = 0; i < p.size(); ++i) {
    const double d = depth(p.x[i], p.y[i], p.z[i]);
    if (d > thickness) continue;
    const bool wall = d > 0;
    s.particles.add(p.x[i], p.y[i], p.z[i], wall ? 0 : p.vx[i], wall ? 0 : p.vy[i],
                    wall ? 0 : p.vz[i], wall ? 1 : 0, p.id[i]);
  }
  return s;
}

int add_second_liquid(sim::Model& model, double A_WN, int wall_type, double A_SN) {
  const int n = model.add_type({"N", false, {0, 0, 0}});
  model.set_pair(n, n, {kA, kB, kGamma});
  model.set_pair(0, n, {A_WN, kB, kGamma});
  if (wall_type >= 0) model.set_pair(wall_type, n, {A_SN, kB, kGamma});
  return n;
}

Slit make_slit(double h, double Lxy, std::uint64_t seed, const ValidateOptions& o) {
  Slit s;
  s.h = h;
  s.h_eff = h + 2 * kSlipLength;
  s.L[0] = s.L[1] = Lxy;
  s.L[2] = h + kWallThickness;
  s.z0 = 0.5 * kWallThickness;
  s.z1 = s.L[2] - 0.5 * kWallThickness;
  const double z0 = s.z0, z1 = s.z1;
  s.system = liquid_with_walls(
      s.L, {true, true, true}, [&](double, double, double z) { return std::max(z0 - z, z - z1); },
      kWallThickness, 500, seed, o);
  return s;
}

void Slit::start_on_profile(double g) {
  sim::ParticleSet& p = system.particles;
  for (size_t i = 0; i < p.size(); ++i) {
    if (p.type[i] != 0) continue;
    const double d = p.z[i] - (z0 - kSlipLength);
    p.vx[i] += std::max(0.0, kRho * g / (2 * kBulkViscosity) * d * (h_eff - d));
  }
}

Pistons add_pistons(BuiltSystem& s, double Lliq, double slab, double room, double push_pressure,
                    double back_pressure) {
  sim::Model& m = s.model;
  Pistons p;
  p.push = m.add_type({"push", false, {0, 0, 0}});
  p.back = m.add_type({"back", false, {0, 0, 0}});
  for (int t = 0; t < m.ntypes(); ++t)
    for (int slab_type : {p.push, p.back}) m.set_pair(slab_type, t, {kA, kB, kGamma});
  m.set_pair(p.push, p.push, {0, 0, 0});  // a rigid body exerts nothing on itself
  m.set_pair(p.back, p.back, {0, 0, 0});
  const double W = s.box.length(1), H = s.box.length(2);
  s.box.lo = {-slab - 0.5, s.box.lo[1], s.box.lo[2]};
  s.box.hi = {Lliq + slab + room, s.box.hi[1], s.box.hi[2]};
  s.box.periodic[0] = false;
  std::int64_t next = 0;
  for (auto id : s.particles.id) next = std::max<std::int64_t>(next, id + 1);
  constexpr double kSlabDensity = 8;
  sim::fill_lattice(s.particles, p.push, {-slab, s.box.lo[1], s.box.lo[2]},
                    {0, s.box.lo[1] + W, s.box.lo[2] + H}, kSlabDensity, next);
  sim::fill_lattice(s.particles, p.back, {Lliq, s.box.lo[1], s.box.lo[2]},
                    {Lliq + slab, s.box.lo[1] + W, s.box.lo[2] + H}, kSlabDensity, next);
  m.rigid_slabs.push_back({p.push, 0, push_pressure});
  m.rigid_slabs.push_back({p.back, 0, -back_pressure});
  return p;
}

}  // namespace mesorock::pipeline::wall_liquid
