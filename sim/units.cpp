#include "sim/units.h"

#include <cmath>
#include <sstream>

#include "mesorock/errors.h"

namespace mesorock::sim {

namespace {

void require_positive(double v, const char* what) {
  if (!std::isfinite(v) || !(v > 0)) {
    std::ostringstream s;
    s << "unit system: " << what << " must be finite and positive (got " << v << ")";
    throw ConfigError(s.str());
  }
}

}  // namespace

void UnitSystem::validate() const {
  require_positive(length_per_rc_nm, "length per rc (nm)");
  require_positive(temperature_K, "temperature (K)");
  require_positive(mass_per_particle_kg, "mass per particle (kg)");
}

// tau = rc sqrt(m / kBT) (docs/physics.md, "Unit conversion": the time unit follows from the mass
// and energy units).
double UnitSystem::tau_s() const {
  return rc_m() * std::sqrt(mass_per_particle_kg / kBT_J());
}

double UnitSystem::velocity_m_per_s(double reduced) const {
  return reduced * rc_m() / tau_s();
}
double UnitSystem::force_N(double reduced) const {
  return reduced * kBT_J() / rc_m();
}
double UnitSystem::acceleration_m_per_s2(double reduced) const {
  const double tau = tau_s();
  return reduced * rc_m() / (tau * tau);
}
double UnitSystem::pressure_pa(double reduced) const {
  const double rc = rc_m();
  return reduced * kBT_J() / (rc * rc * rc);
}
// docs/physics.md, "Unit conversion": surface tension = gamma* kBT / rc^2.
double UnitSystem::surface_tension_n_per_m(double reduced) const {
  const double rc = rc_m();
  return reduced * kBT_J() / (rc * rc);
}
double UnitSystem::viscosity_pa_s(double reduced) const {
  return reduced * mass_per_particle_kg / (rc_m() * tau_s());
}
double UnitSystem::permeability_m2(double reduced) const {
  const double rc = rc_m();
  return reduced * rc * rc;
}
double UnitSystem::number_density_per_m3(double reduced) const {
  const double rc = rc_m();
  return reduced / (rc * rc * rc);
}
// docs/physics.md, "Unit conversion": rho = rho* Nm M / (NA rc^3) = rho* m / rc^3.
double UnitSystem::mass_density_kg_per_m3(double reduced) const {
  const double rc = rc_m();
  return reduced * mass_per_particle_kg / (rc * rc * rc);
}
double UnitSystem::diffusivity_m2_per_s(double reduced) const {
  const double rc = rc_m();
  return reduced * rc * rc / tau_s();
}

std::vector<UnitEntry> UnitSystem::describe() const {
  return {
      {"length", length_m(1), "m"},
      {"time", time_s(1), "s"},
      {"mass", mass_kg(1), "kg"},
      {"energy", energy_J(1), "J"},
      {"temperature", temperature_K, "K"},
      {"velocity", velocity_m_per_s(1), "m/s"},
      {"force", force_N(1), "N"},
      {"acceleration", acceleration_m_per_s2(1), "m/s^2"},
      {"pressure", pressure_pa(1), "Pa"},
      {"surface_tension", surface_tension_n_per_m(1), "N/m"},
      {"viscosity", viscosity_pa_s(1), "Pa s"},
      {"permeability", permeability_m2(1), "m^2"},
      {"number_density", number_density_per_m3(1), "1/m^3"},
      {"mass_density", mass_density_kg_per_m3(1), "kg/m^3"},
      {"diffusivity", diffusivity_m2_per_s(1), "m^2/s"},
  };
}

UnitSystem make_unit_system(double length_per_rc_nm, double temperature_K,
                            double mass_per_particle_kg) {
  UnitSystem u;
  u.length_per_rc_nm = length_per_rc_nm;
  u.temperature_K = temperature_K;
  u.mass_per_particle_kg = mass_per_particle_kg;
  u.validate();
  return u;
}

double particle_mass_kg(double molecules_per_particle, double molar_mass_g_per_mol) {
  require_positive(molecules_per_particle, "molecules per particle");
  require_positive(molar_mass_g_per_mol, "molar mass (g/mol)");
  return molecules_per_particle * molar_mass_g_per_mol * 1e-3 / kAvogadroPerMol;
}

// docs/physics.md, "Unit conversion": rc = (rho* Nm V)^(1/3), V in A^3; 1 A = 0.1 nm.
double WaterModel::length_per_rc_nm() const {
  require_positive(reduced_density, "water model reduced density");
  require_positive(molecules_per_particle, "water model molecules per particle");
  require_positive(molecule_volume_A3, "water model molecule volume (A^3)");
  return 0.1 * std::cbrt(reduced_density * molecules_per_particle * molecule_volume_A3);
}

UnitSystem water_model(const WaterModel& w) {
  return make_unit_system(w.length_per_rc_nm(), w.temperature_K,
                          particle_mass_kg(w.molecules_per_particle, w.molar_mass_g_per_mol));
}

}  // namespace mesorock::sim
