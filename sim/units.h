#pragma once
// Reduced mDPD units (rc = m = kBT = 1) and their SI values.
//
// The solver works in reduced units: length rc (the cutoff), mass m (one DPD particle), energy
// kBT. Every other unit follows from those three (docs/physics.md, "Unit conversion"):
//
//   time            tau = rc sqrt(m / kBT)          velocity        rc / tau = sqrt(kBT / m)
//   force           kBT / rc                        acceleration    rc / tau^2 = kBT / (m rc)
//   pressure/stress kBT / rc^3                      surface tension kBT / rc^2
//   viscosity       m / (rc tau) = sqrt(m kBT)/rc^2 permeability    rc^2
//   number density  1 / rc^3                        mass density    m / rc^3
//   diffusivity     rc^2 / tau
//
// The length scale is an explicit input, never a hidden constant: docs/physics.md records three
// different nm-per-rc values in the papers (0.852, 1.077 and about 4.1 nm). Every output that
// carries physical units should record UnitSystem::describe().
#include <string>
#include <vector>

namespace mesorock::sim {

// Exact SI values (2019 redefinition).
inline constexpr double kBoltzmannJPerK = 1.380649e-23;
inline constexpr double kAvogadroPerMol = 6.02214076e23;

// One line of a unit description: one reduced unit of `name` is `value` `unit`.
struct UnitEntry {
  std::string name;
  double value = 0;
  std::string unit;
};

struct UnitSystem {
  double length_per_rc_nm = 0;    // rc in nanometres
  double temperature_K = 298.15;  // T of the thermostat: kBT = 1 is kB * temperature_K
  double mass_per_particle_kg = 0;

  // Throws ConfigError unless every input is finite and positive.
  void validate() const;

  // The base units in SI.
  double rc_m() const { return length_per_rc_nm * 1e-9; }
  double kBT_J() const { return kBoltzmannJPerK * temperature_K; }
  double tau_s() const;  // rc sqrt(m / kBT)

  // Reduced value -> SI value.
  double length_m(double reduced) const { return reduced * rc_m(); }
  double time_s(double reduced) const { return reduced * tau_s(); }
  double mass_kg(double reduced) const { return reduced * mass_per_particle_kg; }
  double energy_J(double reduced) const { return reduced * kBT_J(); }
  double velocity_m_per_s(double reduced) const;
  double force_N(double reduced) const;
  double acceleration_m_per_s2(double reduced) const;
  double pressure_pa(double reduced) const;  // also stress
  double surface_tension_n_per_m(double reduced) const;
  double viscosity_pa_s(double reduced) const;
  double permeability_m2(double reduced) const;  // a length squared
  double number_density_per_m3(double reduced) const;
  double mass_density_kg_per_m3(double reduced) const;
  double diffusivity_m2_per_s(double reduced) const;

  // Flat description for output files: the SI value of one reduced unit of each quantity
  // ({"time", 3.98e-12, "s"} means 1 tau = 3.98e-12 s). In order: length (m), time (s),
  // mass (kg), energy (J), temperature (K), velocity, force, acceleration, pressure,
  // surface_tension, viscosity, permeability, number_density, mass_density, diffusivity.
  std::vector<UnitEntry> describe() const;
};

// Builds and validates (ConfigError on a non-positive or non-finite input).
UnitSystem make_unit_system(double length_per_rc_nm, double temperature_K,
                            double mass_per_particle_kg);

// Mass of one DPD particle that stands for `molecules_per_particle` molecules of the given molar
// mass: Nm M / NA (docs/physics.md, "Unit conversion": rho = rho* Nm M / (NA rc^3), i.e. m = Nm M /
// NA).
double particle_mass_kg(double molecules_per_particle, double molar_mass_g_per_mol);

// The papers' coarse-grained water (docs/physics.md, "Unit conversion"; 2020 paper, section on the
// liquid-vacuum interface): Nm = 3 water molecules per particle, V = 30 A^3 per molecule,
// M = 18 g/mol (the value the paper states), liquid density rho* = 6.88 (A = -50, B = 25,
// rd = 0.75).
struct WaterModel {
  double molecules_per_particle = 3;  // Nm
  double molecule_volume_A3 = 30;     // V
  double molar_mass_g_per_mol = 18;   // M
  double reduced_density = 6.88;      // rho*
  double temperature_K = 298.15;

  // rc = (rho* Nm V)^(1/3): 0.852 nm for the defaults ((6.88 * 3 * 30)^(1/3) = 8.5233 A).
  double length_per_rc_nm() const;
};

// The unit system of the water model: rc from WaterModel::length_per_rc_nm(), m = Nm M / NA.
UnitSystem water_model(const WaterModel& w = {});

}  // namespace mesorock::sim
