#pragma once
// The physical model of a run as plain data (double precision, backend-independent).
// pipeline/ fills it from a scene file; sim/ never reads files of its own accord.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/injection.h"
#include "sim/rigid_slabs.h"
#include "sim/solid_grid.h"
#include "sim/wall_model.h"

namespace mesorock::sim {

enum class ConservativeKind { DPD, MDPD };
enum class DensityKernelKind { Warren, Lucy };
enum class Precision { Single, Double };
// Uniform: F = g_type everywhere. Reversed: +g_type below the box's mid-plane along
// body_force_axis, -g_type above (reverse Poiseuille flow, for measuring viscosity).
enum class BodyForceProfile { Uniform, Reversed };

inline const char* to_string(ConservativeKind k) {
  return k == ConservativeKind::DPD ? "dpd" : "mdpd";
}
inline const char* to_string(DensityKernelKind k) {
  return k == DensityKernelKind::Warren ? "warren" : "lucy";
}
inline const char* to_string(BodyForceProfile p) {
  return p == BodyForceProfile::Uniform ? "uniform" : "reversed";
}
inline const char* to_string(Precision p) {
  return p == Precision::Single ? "single" : "double";
}

struct TypeSpec {
  std::string name;
  bool frozen = false;                        // frozen wall particles never move
  std::array<double, 3> body_force{0, 0, 0};  // force per particle (m = 1)
};

struct PairSpec {
  double A = 0;      // conservative amplitude (DPD: a = A > 0 repels; mDPD: A < 0 attracts)
  double B = 0;      // many-body repulsion (mDPD only)
  double gamma = 0;  // dissipation (thermostat only)
};

// The boundary model of Li et al. 2018 (sim/wall_model.h, docs/walls.md). Off unless enabled.
struct WallModelSpec {
  bool enabled = false;
  std::uint32_t wall_types = 0;  // bit t: type t is wall (must be frozen); 0 = every frozen type
  double wall_density = 8.0;     // n_w, the number density of the wall particles
  double penetration_threshold = 0.5;  // phi_c
  WallReflection reflection = WallReflection::Li2018;
  double slip_factor = 1.0;  // 1 = no slip; in [0, 1) partial slip
  // Cap of kappa: 8.2 = kappa at the authors' floor of the wall distance, h = 0.025 rc.
  double max_dissipation_factor = 8.2;
};

// A plane that keeps the particles of some types on one side until a step (sim/kernels.h).
struct VirtualWallSpec {
  int axis = 0;
  double position = 0;
  std::uint32_t types = 0;       // bit t: type t is kept on its side
  bool keep_below = true;        // the types stay at coordinates below `position` (else above)
  std::uint64_t until_step = 0;  // active while the step is below this
};

// A rigid slab (piston) of one type, moving along `axis` under an applied pressure
// (sim/rigid_slabs.h). P > 0 pushes towards +axis.
struct RigidSlabSpec {
  int type = 0;
  int axis = 0;
  double applied_pressure = 0;
};

// An injection/ejection boundary (sim/injection.h): every `every` steps after start_step, up to
// stop_step, `per_event` particles of the eject types inside the outlet box are taken out and put
// back at random points of the inlet box as inject_type. Equal rates: N stays constant.
struct InjectionSpec {
  int inject_type = 0;
  std::uint32_t eject_types = 0;  // bit t: type t may be taken at the outlet
  std::array<double, 3> inlet_lo{0, 0, 0}, inlet_hi{0, 0, 0};
  std::array<double, 3> outlet_lo{0, 0, 0}, outlet_hi{0, 0, 0};
  std::uint64_t every = 1;
  int per_event = 1;
  std::uint64_t start_step = 0;
  std::uint64_t stop_step = ~std::uint64_t(0);
};

struct Model {
  std::vector<TypeSpec> types;
  std::vector<PairSpec> pairs;  // ntypes x ntypes, symmetric
  ConservativeKind conservative = ConservativeKind::MDPD;
  DensityKernelKind density_kernel = DensityKernelKind::Warren;
  bool thermostat = true;
  double rd = 0.75;     // many-body cutoff (density kernel and repulsion range)
  double kBT = 1.0;     // thermostat temperature
  double lambda = 0.5;  // velocity-Verlet lambda (Groot & Warren); 0.5 = plain velocity Verlet
  BodyForceProfile body_force_profile = BodyForceProfile::Uniform;
  int body_force_axis = 2;  // Reversed only: the axis across which the force changes sign
  std::uint64_t seed = 1;
  Precision precision = Precision::Double;
  WallModelSpec wall_model;
  // The solid as voxels (sim/solid_grid.h): mobile particles are kept out of it and counted
  // when they get in. Off (no mask) unless the scene gives one.
  SolidSpec solid;
  std::vector<VirtualWallSpec> virtual_walls;  // at most kMaxVirtualWalls
  std::vector<RigidSlabSpec> rigid_slabs;      // at most kMaxRigidSlabs
  std::vector<InjectionSpec> injections;       // at most kMaxInjections

  // The frozen types (never moved, never integrated).
  std::uint32_t frozen_mask() const {
    std::uint32_t m = 0;
    for (int t = 0; t < ntypes(); ++t)
      if (types[static_cast<size_t>(t)].frozen) m |= 1u << t;
    return m;
  }
  // The types that move freely: neither frozen nor the body of a rigid slab. Injection, ejection
  // and the driven types of a sweep must be among them.
  std::uint32_t mobile_mask() const {
    std::uint32_t m = ~frozen_mask() & (ntypes() >= 32 ? ~0u : (1u << ntypes()) - 1u);
    for (const RigidSlabSpec& r : rigid_slabs)
      if (r.type >= 0 && r.type < 32) m &= ~(1u << r.type);
    return m;
  }
  bool is_mobile(int type) const {
    return type >= 0 && type < 32 && ((mobile_mask() >> type) & 1u);
  }
  // The wall types of the wall model: the given ones, or every frozen type.
  std::uint32_t wall_mask() const {
    return wall_model.wall_types != 0 ? wall_model.wall_types : frozen_mask();
  }

  int ntypes() const { return static_cast<int>(types.size()); }
  PairSpec& pair(int a, int b) { return pairs[static_cast<size_t>(a * ntypes() + b)]; }
  const PairSpec& pair(int a, int b) const { return pairs[static_cast<size_t>(a * ntypes() + b)]; }
  // Sets both (a,b) and (b,a).
  void set_pair(int a, int b, const PairSpec& p) {
    pair(a, b) = p;
    pair(b, a) = p;
  }
  bool has_body_force() const {
    for (const auto& t : types)
      if (t.body_force[0] != 0 || t.body_force[1] != 0 || t.body_force[2] != 0) return true;
    return false;
  }
  int type_index(const std::string& name) const {
    for (int t = 0; t < ntypes(); ++t)
      if (types[static_cast<size_t>(t)].name == name) return t;
    return -1;
  }
  // Adds a type with zeroed pair entries; returns its index.
  int add_type(const TypeSpec& t) {
    const int old = ntypes();
    std::vector<PairSpec> grown(static_cast<size_t>((old + 1) * (old + 1)));
    for (int a = 0; a < old; ++a)
      for (int b = 0; b < old; ++b)
        grown[static_cast<size_t>(a * (old + 1) + b)] = pairs[static_cast<size_t>(a * old + b)];
    pairs = std::move(grown);
    types.push_back(t);
    return old;
  }
};

struct BoxSpec {
  std::array<double, 3> lo{0, 0, 0};
  std::array<double, 3> hi{10, 10, 10};
  std::array<bool, 3> periodic{true, true, true};
  double length(int a) const { return hi[static_cast<size_t>(a)] - lo[static_cast<size_t>(a)]; }
  double volume() const { return length(0) * length(1) * length(2); }
};

// Host-side particle data in double precision: what files hold and what the solver starts from.
struct ParticleSet {
  std::vector<double> x, y, z, vx, vy, vz;
  std::vector<std::int32_t> type;
  std::vector<std::int64_t> id;

  size_t size() const { return x.size(); }
  void reserve(size_t n) {
    for (auto* v : {&x, &y, &z, &vx, &vy, &vz}) v->reserve(n);
    type.reserve(n);
    id.reserve(n);
  }
  void add(double px, double py, double pz, double ux, double uy, double uz, std::int32_t t,
           std::int64_t pid) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    vx.push_back(ux);
    vy.push_back(uy);
    vz.push_back(uz);
    type.push_back(t);
    id.push_back(pid);
  }
};

}  // namespace mesorock::sim
