#pragma once
// `rockflow pc FLOODING/scene.toml --pressures ...` (docs/relperm.md): the primary-drainage
// capillary pressure curve Pc(S_w) of a flooding set-up (rockprep run --layout flooding), by the
// engine of drainage.h.
//
// The scene's source fluid is the wetting phase W (in the block and the outlet reservoir), its
// working fluid the non-wetting phase N (in the inlet reservoir). The command makes them two
// liquids, as `rockflow relperm` does: N meets W with the cross repulsion A_WN (immiscible) and,
// when given, every wall type with A_SN (the contact angle: docs/calibration/
// contact_angle_WN_A_SN.csv); it adds the membrane at the block's outlet face and runs the
// scene's stages before its last once at Pc = 0 (the relax and settle stages, with the scene's
// own virtual walls), then the levels: primary drainage at rising Pc and, when asked, imbibition
// at falling Pc after it (the same state, the hysteresis loop's second branch). The pushing slab is
// the scene's first [[slabs]] entry, the back-pressure slab its second (rockprep's order); P_back
// is the back slab's pressure. The block is the scene's region named "block" ([[output.regions]],
// as rockprep writes it).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/flow/drainage.h"
#include "pipeline/flow/relperm.h"
#include "pipeline/scene.h"

namespace mesorock::pipeline {

struct PcCommand {
  std::filesystem::path out_dir = "out";
  std::string wetting = "source", nonwetting = "working";  // the scene's type names
  double cross_A = kDefaultCrossA;                         // A_WN (relperm.h)
  std::optional<double> nonwetting_wall_A;                 // A_SN; default: W's own (90 degrees)
  // Levels and steady-state settings (pressures, block_steps, window, tolerance, measure_blocks,
  // max_level_steps, sample_every, sim); back_pressure and dt come from the scene.
  DrainageOptions run;  // run.pressures: the primary drainage levels, rising
  // Levels after the drainage, falling (imbibition: W back in; empty = none).
  std::vector<double> imbibition;
  bool write_states = true;  // states/level_K.h5 + .xmf: the phases at the end of each level
  bool progress = true;
};

// Runs the drainage, writes OUT/pc.csv, pc_blocks.csv, pc.json, pc.png (and states/), and returns
// the summary (pc.json).
nlohmann::json run_pc_command(const Scene& scene, const PcCommand& command);

}  // namespace mesorock::pipeline
