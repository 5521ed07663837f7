#pragma once
// The scene file of a flooding set-up (packing/flooding.h), in the format of docs/scene.md, so
// that `rockflow run DIR/scene.toml` runs it as written: the particle file as the only [[init]]
// block, a pushing and a back-pressure slab ([[slabs]]), virtual walls at the block's inlet face
// until flooding starts ([[virtual_walls]]), the wall model on the wall types ([walls]), and
// region observables whose saturation of the source fluid in the block gives the recovery curve
// ([[output.regions]]).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "packing/flooding.h"
#include "packing/permeability.h"
#include "sim/eos.h"

namespace mesorock::pipeline::prep {

struct FloodingSceneParams {
  std::string name = "flooding";
  std::uint64_t seed = 1;
  std::string particle_file = "particles.h5";  // relative to the scene's folder
  std::string solid_file = "solid.h5";         // the solid's voxels ([solid]); "" = none
  std::vector<std::string> type_names;         // as in the particle file
  // Pair sets (mDPD): fluid-fluid, fluid-organic wall, fluid-inorganic wall, and the wall set
  // (wall-wall, slab-slab, slab-wall pairs; frozen or rigid pairs never move each other).
  double a_fluid = -40, a_organic = -30, a_inorganic = -40, a_wall = -40;
  double B = 25, gamma = 4.5, rd = 0.75, kBT = 1.0;
  std::string density_kernel = "warren";
  double wall_density = 8.0;  // [walls] wall_density: the walls' particle density
  double back_pressure = 0;   // magnitude, pushes the outlet slab towards -axis
  double push_pressure = 0;   // magnitude, pushes the inlet slab towards +axis
  std::uint64_t relax_steps = 100, settle_steps = 200, flood_steps = 2000;
  double relax_dt = 0.002, dt = 0.01;
  std::uint64_t thermo_every = 50, region_every = 50, snapshot_every = 0;
  double nm_per_rc = 0;  // 0: no [units]
  std::string comment;   // lines at the top (each prefixed with "# ")
};

std::string flooding_scene_toml(const packing::FloodingLayout& layout,
                                const FloodingSceneParams& params);

// The scene of a permeability layout (packing/permeability.h): a periodic box, the particle file
// as the only [[init]] block, one fluid type driven by a body force along the flow axis (the type
// and axis `rockflow sweep` drives), the wall model on the wall types, a relax stage at a small
// time step and a flow stage, and a region over the block (one copy) for its flow rate. It uses
// the pair, wall, time-step, output and unit fields of FloodingSceneParams, not the slabs'
// pressures nor the settle and flood stages.
struct PermeabilitySceneParams : FloodingSceneParams {
  std::string fluid_type = "fluid";
  double body_force = 0.02;  // per fluid particle (m = 1) along the flow axis
  std::uint64_t flow_steps = 2000;
};

std::string permeability_scene_toml(const packing::PermeabilityLayout& layout,
                                    const PermeabilitySceneParams& params);

// The mDPD pressure from Warren's fit: sim/eos.h.
using sim::warren_pressure;

}  // namespace mesorock::pipeline::prep
