#pragma once
// A scene file (TOML, documented in docs/scene.md) as plain data. load_scene() is the only reader;
// every key it does not know, every missing required key and every NaN or out-of-range value is a
// ConfigError whose message names the file and the key: "scene.toml: pairs[2].gamma: must be >= 0".
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/domain/decomposition.h"
#include "sim/model.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

// One [[init]] block: how a set of initial particles is made.
struct InitSpec {
  enum class Kind { Random, Lattice, File };
  Kind kind = Kind::Random;
  std::string type;                   // particle type name (Random, Lattice)
  std::array<double, 3> lo{}, hi{};   // region (defaults to the box)
  std::optional<double> density;      // number density (Random: count = round(density * volume))
  std::optional<std::int64_t> count;  // Random only; exactly one of density/count
  std::filesystem::path file;  // File: HDF5 particle file (resolved against the scene folder)
};

// One [[run]] stage.
struct StageSpec {
  std::string name;  // defaults to "stage<i>" (1-based)
  std::uint64_t steps = 0;
  double dt = 0.01;
};

// A time-averaged binned observable: a profile along one axis ([[output.profiles]]) or a 3-D
// field on a grid of cells ([output.fields]).
struct BinnedOutputSpec {
  std::string name;                   // output file stem
  std::array<int, 3> cells{1, 1, 1};  // bins per axis (a profile has bins along one axis only)
  int axis = -1;                      // profiles: the axis; fields: -1
  std::uint64_t every = 10;           // sample every N steps
  std::vector<std::string> types;     // counted types; empty = every mobile type
};

// A box region whose particles are counted per type every `every` steps, with the flow rate
// through it (regions.csv), and optionally the saturation of one type (saturation.csv).
struct RegionOutputSpec {
  std::string name;
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  std::uint64_t every = 100;
  std::vector<std::string> types;  // counted types, each on its own; empty = every mobile type
  std::string saturation_of;       // empty, or the counted type whose share is the saturation
  bool pressure = false;  // also the stress of the counted types in the box (region_pressure.csv)
};

struct OutputSpec {
  std::uint64_t thermo_every = 100;    // rows of thermo.csv; 0 = off
  std::uint64_t snapshot_every = 0;    // HDF5 snapshots; 0 = only the final state
  std::uint64_t checkpoint_every = 0;  // OUT/checkpoint.h5 every N steps; 0 = none (Ctrl-C still)
  bool final_snapshot = true;
  // Stages whose samples enter time averages (summary, profiles, fields); empty = the last stage.
  std::vector<std::string> average_stages;
  std::vector<BinnedOutputSpec> profiles;
  std::optional<BinnedOutputSpec> fields;
  std::vector<RegionOutputSpec> regions;
};

// Physical scale of the reduced units, recorded with every output when given ([units]).
struct UnitsSpec {
  double nm_per_rc = 0;  // 0 = not given (outputs then carry reduced units only)
  double temperature_K = 298.15;
  // Mass of one particle; 0 = the papers' water model (3 molecules of 18 g/mol).
  double particle_mass_kg = 0;
};

struct Scene {
  std::filesystem::path path;  // the file it came from (for messages and provenance)
  std::string name;
  sim::Model model;
  sim::BoxSpec box;
  std::vector<InitSpec> init;
  std::vector<StageSpec> stages;
  OutputSpec output;
  UnitsSpec units;
  // How a run under mpirun splits the box over its ranks ([decomposition]; ignored by one rank).
  sim::DecompositionOptions decomposition;
  std::string source_text;  // the file's text, recorded in outputs
  // The files the scene names ([solid] file, [[init]] files), resolved: their contents are
  // hashed into a run's checkpoints and compared on resume.
  std::vector<std::filesystem::path> named_files;
};

// Reads and validates a scene. Throws ConfigError/IoError with a one-line "file: key: problem".
Scene load_scene(const std::filesystem::path& path);
Scene parse_scene(const std::string& text, const std::filesystem::path& path_for_messages);

// The stages whose samples enter time averages: output.average_stages, or the last stage.
bool stage_is_averaged(const Scene& scene, const std::string& stage_name);

// Refuses, before any particle is made, a scene whose [[init]] blocks would create more particles
// than one run holds (2^31 - 1) or need more memory than is available (sim/memory_budget.h: host
// memory for every backend, device memory too for CUDA): a LimitError (exit 2) naming the block
// ("init[1].count") or "[[init]] blocks: total", with the bytes needed and available. File blocks
// count the particles in the file's header without reading them. build_initial_particles checks
// the host memory itself; commands call this for the device too. copies: runs of the scene held
// at once (`rockflow sweep --side-by-side`).
void check_memory_for(const Scene& scene, const sim::SimulationOptions& options, int copies = 1);

// Builds the initial particles a scene describes (random/lattice fills, HDF5 files), with
// Maxwell velocities at model.kBT for mobile particles of generated blocks (particles read from
// files keep their velocities). Random streams are derived from model.seed (see
// init_block_seed / init_velocity_seed). Throws ConfigError/IoError naming the init block.
sim::ParticleSet build_initial_particles(const Scene& scene);

// The seed that positions of random [[init]] block `block` (0-based index among all [[init]]
// blocks) are drawn with: splitmix64(seed XOR splitmix64(block + 1)).
std::uint64_t init_block_seed(std::uint64_t seed, std::size_t block);
// The seed that initial Maxwell velocities are drawn with: splitmix64(seed XOR splitmix64(0)).
std::uint64_t init_velocity_seed(std::uint64_t seed);

}  // namespace mesorock::pipeline
