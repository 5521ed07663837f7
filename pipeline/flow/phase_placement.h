#pragma once
// Where the two fluids of `rockflow relperm` start (docs/relperm.md, "Placing the fluids").
//
// Random: each fluid particle is non-wetting with the same chance, drawn from the seed; the
// phases then separate by themselves (an emulsion that coarsens), with no memory of how the rock
// was filled.
//
// Drainage (by pore size, the wetting phase in the small pores, as primary drainage leaves it):
// a non-wetting phase that invades a wetting-filled pore space at capillary pressure Pc = 2
// gamma / R (theta = 0) fills every place a ball of radius R reaches without crossing the solid:
// the morphological opening of the pore space by that ball (Hilpert and Miller 2001, the
// "maximal inscribed spheres" drainage of pore-morphology methods). The drainage radius of a
// voxel is the largest R whose opening holds it: half its local thickness (Hildebrand and
// Ruegsegger 1997). The non-wetting particles are the share 1 - S_w with the largest drainage
// radius (ties: the farthest from the solid, then the particle index), so the target saturation
// is reached to one particle. Accessibility from an inlet is not imposed (the sample is periodic:
// there is no inlet), so isolated large pores drain too; trapping is left to the flow.
//
// The radius is computed on the sample's solid grid at the radii R_k = k h / 2 (h the smallest
// voxel edge, k >= 2): the opening at R_k is the set of pore voxels within R_k of a voxel whose
// distance to the solid is at least R_k, two exact Euclidean distance transforms
// (mesorock/distance_transform.h) per radius, periodic along the axes where the grid spans a
// periodic box edge. Distances are between voxel centres, as in rockprep's pore sizes.
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sim/model.h"
#include "sim/solid_grid.h"
#include "sim/state.h"

namespace mesorock::pipeline {

enum class Placement { Random, Drainage };
Placement parse_placement(const std::string& text);  // "random" | "drainage"
std::string to_string(Placement p);

// Per voxel of a solid grid (z-major, as the grid): the drainage radius (rc; 0 in the solid)
// and the distance to the nearest solid voxel centre (rc; 0 in the solid).
struct DrainageMap {
  std::array<std::int64_t, 3> dims{0, 0, 0};
  std::vector<float> radius, distance;
  double largest_radius = 0;
};

// `periodic[a]`: the grid wraps along axis a (sim::solid_view_of's choice). `on_radius(k, K)`,
// when given, is told each radius done (progress). Throws ConfigError when the grid has no pore
// or no solid voxel.
DrainageMap drainage_map(const sim::SolidMask& mask, const std::array<bool, 3>& periodic,
                         const std::function<void(int, int)>& on_radius = {});

struct PlacementResult {
  std::size_t fluid = 0, nonwetting = 0;
  double saturation = 0;  // wetting share of the fluid particles reached
  // Drainage: the smallest drainage radius among the non-wetting particles (rc): the entry
  // radius the placement stands for (Pc = 2 gamma cos(theta) / R). 0 for random placement.
  double entry_radius = 0;
};

// Turns the share 1 - `wetting_saturation` of the particles of type `wetting` into type
// `nonwetting` by the rule (drainage needs `map`, built on the grid `mask` in `box`). Particles
// of other types stay as they are. Deterministic for a seed.
PlacementResult place_phases(sim::ParticleSet& particles, int wetting, int nonwetting,
                             double wetting_saturation, Placement rule, std::uint64_t seed,
                             const DrainageMap* map = nullptr, const sim::SolidMask* mask = nullptr,
                             const std::array<bool, 3>& periodic = {false, false, false});

}  // namespace mesorock::pipeline
