#pragma once
// Writers for the time-averaged binned observables of a run (profiles and 3-D fields) and the
// unit-conversion record of summary.json.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "mesorock/staged_outputs.h"
#include "pipeline/scene.h"
#include "sim/observables.h"
#include "sim/particle_io.h"
#include "sim/units.h"

namespace mesorock::pipeline {

struct ObservableOutputMeta {
  std::uint64_t step = 0;
  double time = 0;
  std::string provenance_json;
  std::optional<sim::UnitSystem> units;  // recorded when the scene gives a physical scale
};

// A profile (spec.axis >= 0) becomes NAME.h5 + NAME.xmf + NAME.csv; a field becomes fields.h5 +
// fields.xmf. Each holds density, velocity and temperature with their block-averaging error bars.
// The files are staged in `outputs` (they take their names in out_dir when the run commits).
void write_binned_outputs(StagedOutputs& outputs, const std::filesystem::path& out_dir,
                          const BinnedOutputSpec& spec, const sim::BinnedAverage& average,
                          const ObservableOutputMeta& meta);

// The unit system a scene's [units] table describes (water-model particle mass by default).
sim::UnitSystem unit_system_of(const UnitsSpec& spec);

// The units block of summary.json: reduced units always; SI conversion factors when given.
nlohmann::json units_json(const std::optional<sim::UnitSystem>& units);

// A particle state as DIR/STEM.h5 + DIR/STEM.xmf (ParaView opens the .xmf), staged in `outputs`;
// STEM may name a subfolder (states/...), which must exist.
void write_state_files(StagedOutputs& outputs, const std::filesystem::path& dir,
                       const std::string& stem, const sim::ParticleSet& particles,
                       const sim::ParticleFileMeta& meta);

}  // namespace mesorock::pipeline
