// Reduced mDPD units -> SI: hand-computed conversions and the water model's numbers from
// docs/physics.md ("Unit conversion").
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "mesorock/errors.h"
#include "sim/units.h"

using mesorock::ConfigError;
using mesorock::sim::kAvogadroPerMol;
using mesorock::sim::kBoltzmannJPerK;
using mesorock::sim::make_unit_system;
using mesorock::sim::particle_mass_kg;
using mesorock::sim::UnitSystem;
using mesorock::sim::water_model;
using mesorock::sim::WaterModel;

namespace {

// Relative comparison for quantities spanning many orders of magnitude.
void expect_rel(double got, double want, double rel, const char* what) {
  EXPECT_NEAR(got, want, std::abs(want) * rel) << what;
}

// A system chosen so every unit is a power of ten:
//   rc = 1 nm = 1e-9 m, kBT = 1e-21 J (T = 1e-21 / kB = 72.43 K), m = 1e-25 kg.
UnitSystem decimal_system() {
  return make_unit_system(1.0, 1e-21 / kBoltzmannJPerK, 1e-25);
}

}  // namespace

TEST(Units, DecimalSystemByHand) {
  const UnitSystem u = decimal_system();
  const double r = 1e-12;
  expect_rel(u.rc_m(), 1e-9, r, "rc");
  expect_rel(u.kBT_J(), 1e-21, r, "kBT");
  // tau = rc sqrt(m / kBT) = 1e-9 * sqrt(1e-25 / 1e-21) = 1e-9 * 1e-2 = 1e-11 s.
  expect_rel(u.tau_s(), 1e-11, r, "tau");
  expect_rel(u.time_s(250), 2.5e-9, r, "time");  // 250 * 1e-11
  // length: 3.5 rc = 3.5e-9 m.
  expect_rel(u.length_m(3.5), 3.5e-9, r, "length");
  // mass: 2 m = 2e-25 kg.
  expect_rel(u.mass_kg(2), 2e-25, r, "mass");
  // energy: 4 kBT = 4e-21 J.
  expect_rel(u.energy_J(4), 4e-21, r, "energy");
  // velocity: rc / tau = 1e-9 / 1e-11 = 100 m/s; 0.3 -> 30 m/s.
  expect_rel(u.velocity_m_per_s(0.3), 30, r, "velocity");
  // force: kBT / rc = 1e-21 / 1e-9 = 1e-12 N; 5 -> 5e-12 N.
  expect_rel(u.force_N(5), 5e-12, r, "force");
  // acceleration: rc / tau^2 = 1e-9 / 1e-22 = 1e13 m/s^2; 0.02 -> 2e11 m/s^2.
  expect_rel(u.acceleration_m_per_s2(0.02), 2e11, r, "acceleration");
  // pressure: kBT / rc^3 = 1e-21 / 1e-27 = 1e6 Pa; 23.65 -> 2.365e7 Pa.
  expect_rel(u.pressure_pa(23.65), 2.365e7, r, "pressure");
  // surface tension: kBT / rc^2 = 1e-21 / 1e-18 = 1e-3 N/m; 7.67 -> 7.67e-3 N/m.
  expect_rel(u.surface_tension_n_per_m(7.67), 7.67e-3, r, "surface tension");
  // viscosity: m / (rc tau) = 1e-25 / (1e-9 * 1e-11) = 1e-5 Pa s; 2.5 -> 2.5e-5 Pa s.
  expect_rel(u.viscosity_pa_s(2.5), 2.5e-5, r, "viscosity");
  // permeability: rc^2 = 1e-18 m^2; 0.04 -> 4e-20 m^2.
  expect_rel(u.permeability_m2(0.04), 4e-20, r, "permeability");
  // number density: 1 / rc^3 = 1e27 m^-3; 6.88 -> 6.88e27 m^-3.
  expect_rel(u.number_density_per_m3(6.88), 6.88e27, r, "number density");
  // mass density: m / rc^3 = 1e-25 / 1e-27 = 100 kg/m^3; 6.88 -> 688 kg/m^3.
  expect_rel(u.mass_density_kg_per_m3(6.88), 688, r, "mass density");
  // diffusivity: rc^2 / tau = 1e-18 / 1e-11 = 1e-7 m^2/s; 0.1 -> 1e-8 m^2/s.
  expect_rel(u.diffusivity_m2_per_s(0.1), 1e-8, r, "diffusivity");
}

TEST(Units, ScalingOfEachUnitWithItsInputs) {
  // Doubling rc: tau x2, velocity x1, pressure x1/8, surface tension x1/4, viscosity x1/4,
  // permeability x4 (tau = rc sqrt(m/kBT); eta = sqrt(m kBT) / rc^2).
  const UnitSystem a = decimal_system();
  UnitSystem b = a;
  b.length_per_rc_nm *= 2;
  const double r = 1e-12;
  expect_rel(b.tau_s() / a.tau_s(), 2, r, "tau");
  expect_rel(b.velocity_m_per_s(1) / a.velocity_m_per_s(1), 1, r, "velocity");
  expect_rel(b.pressure_pa(1) / a.pressure_pa(1), 0.125, r, "pressure");
  expect_rel(b.surface_tension_n_per_m(1) / a.surface_tension_n_per_m(1), 0.25, r, "tension");
  expect_rel(b.viscosity_pa_s(1) / a.viscosity_pa_s(1), 0.25, r, "viscosity");
  expect_rel(b.permeability_m2(1) / a.permeability_m2(1), 4, r, "permeability");
  // Four times the mass: tau x2, velocity x1/2, viscosity x2 (sqrt(m kBT)), pressure x1.
  UnitSystem c = a;
  c.mass_per_particle_kg *= 4;
  expect_rel(c.tau_s() / a.tau_s(), 2, r, "tau(m)");
  expect_rel(c.velocity_m_per_s(1) / a.velocity_m_per_s(1), 0.5, r, "velocity(m)");
  expect_rel(c.viscosity_pa_s(1) / a.viscosity_pa_s(1), 2, r, "viscosity(m)");
  expect_rel(c.pressure_pa(1) / a.pressure_pa(1), 1, r, "pressure(m)");
}

TEST(Units, ParticleMassIsMoleculesTimesMolarMassOverAvogadro) {
  // 3 water molecules at 18 g/mol: 3 * 18e-3 kg/mol / 6.02214076e23 /mol = 8.96691e-26 kg.
  expect_rel(particle_mass_kg(3, 18), 3 * 18e-3 / kAvogadroPerMol, 1e-15, "mass");
  expect_rel(particle_mass_kg(3, 18), 8.96691e-26, 1e-5, "mass (digits)");
  EXPECT_THROW(particle_mass_kg(0, 18), ConfigError);
  EXPECT_THROW(particle_mass_kg(3, -1), ConfigError);
}

TEST(Units, WaterModelMatchesPhysicsMd) {
  // docs/physics.md, "Unit conversion" (water model, Nm = 3): rc = (rho* Nm V)^(1/3) with V = 30
  // A^3 and rho* = 6.88: (6.88 * 3 * 30)^(1/3) = 619.2^(1/3) = 8.5233 A = 0.852 nm (as stated).
  const UnitSystem w = water_model();
  EXPECT_NEAR(w.length_per_rc_nm, 0.852, 0.0005);
  expect_rel(w.length_per_rc_nm, 0.85233, 1e-5, "rc digits");
  EXPECT_EQ(w.temperature_K, 298.15);
  // m = Nm M / NA = 3 * 18 g/mol / NA = 8.96691e-26 kg.
  expect_rel(w.mass_per_particle_kg, 8.96691e-26, 1e-5, "mass");
  // tau = rc sqrt(m / kBT) = 8.5233e-10 m * sqrt(8.96691e-26 kg / (1.380649e-23 * 298.15 J))
  //     = 8.5233e-10 * sqrt(2.17834e-5) = 8.5233e-10 * 4.66727e-3 = 3.978e-12 s (about 4 ps).
  expect_rel(w.tau_s(), 3.97807e-12, 1e-5, "tau");

  // Density (docs/physics.md: rho = rho* Nm M / (NA rc^3) = 994 kg/m^3). With rc^3 = rho* Nm V this
  // is M / (NA V) = 18e-3 / (6.02214076e23 * 30e-30) = 996.3 kg/m^3: the stated 994 to 0.25%.
  expect_rel(w.mass_density_kg_per_m3(6.88), 994, 0.005, "density vs docs/physics.md");
  expect_rel(w.mass_density_kg_per_m3(6.88), 996.32, 1e-4, "density digits");

  // Surface tension (docs/physics.md: gamma = gamma* kBT / rc^2 = 70.6 mN/m at T = 298 K for
  // gamma* = 12.4): 12.4 * 1.380649e-23 * 298 / (8.5233e-10)^2 = 12.4 * 5.66342e-3
  // = 70.23 mN/m, the stated 70.6 mN/m to 0.6%.
  WaterModel at298;
  at298.temperature_K = 298;
  const UnitSystem w298 = water_model(at298);
  expect_rel(w298.surface_tension_n_per_m(12.4), 0.0706, 0.01, "tension vs docs/physics.md");
  expect_rel(w298.surface_tension_n_per_m(12.4), 0.070226, 1e-4, "tension digits");
}

TEST(Units, DescribeListsEveryUnitWithItsValue) {
  const UnitSystem u = decimal_system();
  const auto d = u.describe();
  std::map<std::string, std::pair<double, std::string>> by_name;
  for (const auto& e : d) {
    EXPECT_TRUE(by_name.emplace(e.name, std::make_pair(e.value, e.unit)).second)
        << "duplicate " << e.name;
    EXPECT_FALSE(e.unit.empty()) << e.name;
    EXPECT_TRUE(std::isfinite(e.value) && e.value > 0) << e.name;
  }
  const std::map<std::string, std::pair<double, std::string>> want{
      {"length", {1e-9, "m"}},
      {"time", {1e-11, "s"}},
      {"mass", {1e-25, "kg"}},
      {"energy", {1e-21, "J"}},
      {"temperature", {1e-21 / kBoltzmannJPerK, "K"}},
      {"velocity", {100, "m/s"}},
      {"force", {1e-12, "N"}},
      {"acceleration", {1e13, "m/s^2"}},
      {"pressure", {1e6, "Pa"}},
      {"surface_tension", {1e-3, "N/m"}},
      {"viscosity", {1e-5, "Pa s"}},
      {"permeability", {1e-18, "m^2"}},
      {"number_density", {1e27, "1/m^3"}},
      {"mass_density", {100, "kg/m^3"}},
      {"diffusivity", {1e-7, "m^2/s"}},
  };
  ASSERT_EQ(by_name.size(), want.size());
  for (const auto& [name, vu] : want) {
    ASSERT_TRUE(by_name.count(name)) << name;
    expect_rel(by_name[name].first, vu.first, 1e-12, name.c_str());
    EXPECT_EQ(by_name[name].second, vu.second) << name;
  }
}

TEST(Units, InvalidInputsAreConfigErrors) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(make_unit_system(0, 298.15, 1e-25), ConfigError);
  EXPECT_THROW(make_unit_system(-1, 298.15, 1e-25), ConfigError);
  EXPECT_THROW(make_unit_system(1, 0, 1e-25), ConfigError);
  EXPECT_THROW(make_unit_system(1, 298.15, nan), ConfigError);
  EXPECT_THROW(make_unit_system(INFINITY, 298.15, 1e-25), ConfigError);
  WaterModel bad;
  bad.reduced_density = 0;
  EXPECT_THROW(water_model(bad), ConfigError);
  try {
    make_unit_system(1, 298.15, -2e-25);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mass per particle"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("-2e-25"), std::string::npos) << e.what();
  }
}
