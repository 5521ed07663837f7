#include "pipeline/flow/observable_outputs.h"

#include "mesorock/version.h"
#include "sim/field_io.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

sim::UnitSystem unit_system_of(const UnitsSpec& spec) {
  const double mass = spec.particle_mass_kg > 0
                          ? spec.particle_mass_kg
                          : sim::particle_mass_kg(sim::WaterModel{}.molecules_per_particle,
                                                  sim::WaterModel{}.molar_mass_g_per_mol);
  return sim::make_unit_system(spec.nm_per_rc, spec.temperature_K, mass);
}

nlohmann::json units_json(const std::optional<sim::UnitSystem>& units) {
  nlohmann::json j = {{"reduced", "rc = m = kBT = 1; time unit tau = rc sqrt(m / kBT)"}};
  if (!units) {
    j["si"] = nullptr;
    j["note"] = "no [units] table in the scene: outputs are in reduced units only";
    return j;
  }
  j["nm_per_rc"] = units->length_per_rc_nm;
  j["temperature_K"] = units->temperature_K;
  j["particle_mass_kg"] = units->mass_per_particle_kg;
  nlohmann::json si = nlohmann::json::object();
  for (const auto& e : units->describe()) si[e.name] = {{"value", e.value}, {"unit", e.unit}};
  j["si"] = si;
  j["note"] = "si: the SI value of one reduced unit of each quantity";
  return j;
}

void write_binned_outputs(StagedOutputs& outputs, const fs::path& out_dir,
                          const BinnedOutputSpec& spec, const sim::BinnedAverage& average,
                          const ObservableOutputMeta& meta) {
  const sim::BinGrid& g = average.grid();
  sim::FieldFileMeta fm;
  fm.step = meta.step;
  fm.time = meta.time;
  fm.created_by = "rockflow run";
  fm.provenance_json = meta.provenance_json;
  fm.attributes = {{"samples", std::to_string(average.samples())},
                   {"every", std::to_string(spec.every)},
                   {"error_bars", "one standard error from " + std::to_string(average.blocks()) +
                                      " block averages"}};
  if (meta.units) fm.units = meta.units->describe();

  const auto rho = average.density();
  const auto T = average.temperature();
  std::array<sim::BinnedQuantity, 3> u = {average.velocity(0), average.velocity(1),
                                          average.velocity(2)};
  if (spec.axis >= 0) {
    const int a = spec.axis;
    const int n = g.cells[static_cast<size_t>(a)];
    std::vector<double> edges(static_cast<size_t>(n) + 1);
    for (int b = 0; b <= n; ++b)
      edges[static_cast<size_t>(b)] = g.lo[static_cast<size_t>(a)] + b * g.width(a);
    std::vector<sim::ProfileField> fields = {{"density", "1/rc^3", rho.mean, rho.error},
                                             {"vx", "rc/tau", u[0].mean, u[0].error},
                                             {"vy", "rc/tau", u[1].mean, u[1].error},
                                             {"vz", "rc/tau", u[2].mean, u[2].error},
                                             {"temperature", "kBT", T.mean, T.error}};
    const fs::path h5 = out_dir / (spec.name + ".h5");
    outputs.write(h5, [&](const fs::path& p) { sim::write_profile_file(p, a, edges, fields, fm); });
    outputs.write(out_dir / (spec.name + ".xmf"), [&](const fs::path& p) {
      sim::write_profile_xdmf(p, h5, a, edges, fields, meta.time);
    });
    outputs.write(out_dir / (spec.name + ".csv"),
                  [&](const fs::path& p) { sim::write_profile_csv(p, a, edges, fields, fm); });
    return;
  }
  sim::FieldGrid grid;
  grid.cells = g.cells;
  grid.origin = g.lo;
  for (int a = 0; a < 3; ++a) grid.spacing[static_cast<size_t>(a)] = g.width(a);
  const size_t cells = grid.cell_count();
  auto vector_of = [&](bool errors) {
    std::vector<double> v(3 * cells);
    for (size_t c = 0; c < cells; ++c)
      for (int a = 0; a < 3; ++a)
        v[3 * c + static_cast<size_t>(a)] =
            errors ? u[static_cast<size_t>(a)].error[c] : u[static_cast<size_t>(a)].mean[c];
    return v;
  };
  const std::vector<sim::FieldData> fields = {
      {"density", 1, "1/rc^3", rho.mean},          {"density_error", 1, "1/rc^3", rho.error},
      {"velocity", 3, "rc/tau", vector_of(false)}, {"velocity_error", 3, "rc/tau", vector_of(true)},
      {"temperature", 1, "kBT", T.mean},           {"temperature_error", 1, "kBT", T.error}};
  const fs::path h5 = out_dir / (spec.name + ".h5");
  outputs.write(h5, [&](const fs::path& p) { sim::write_field_file(p, grid, fields, fm); });
  outputs.write(out_dir / (spec.name + ".xmf"),
                [&](const fs::path& p) { sim::write_field_xdmf(p, h5, grid, fields, meta.time); });
}

void write_state_files(StagedOutputs& outputs, const std::filesystem::path& dir,
                       const std::string& stem, const sim::ParticleSet& particles,
                       const sim::ParticleFileMeta& meta) {
  const std::filesystem::path h5 = dir / (stem + ".h5");
  outputs.write(
      h5, [&](const std::filesystem::path& p) { sim::write_particle_file(p, particles, meta); });
  outputs.write(dir / (stem + ".xmf"), [&](const std::filesystem::path& p) {
    sim::write_particle_xdmf(p, h5, particles.size(), meta.time);
  });
}

}  // namespace mesorock::pipeline
