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

#include "sim/model.h"

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

struct OutputSpec {
  std::uint64_t thermo_every = 100;  // rows of thermo.csv; 0 = off
  std::uint64_t snapshot_every = 0;  // HDF5 snapshots; 0 = only the final state
  bool final_snapshot = true;
};

struct Scene {
  std::filesystem::path path;  // the file it came from (for messages and provenance)
  std::string name;
  sim::Model model;
  sim::BoxSpec box;
  std::vector<InitSpec> init;
  std::vector<StageSpec> stages;
  OutputSpec output;
  std::string source_text;  // the file's text, recorded in outputs
};

// Reads and validates a scene. Throws ConfigError/IoError with a one-line "file: key: problem".
Scene load_scene(const std::filesystem::path& path);
Scene parse_scene(const std::string& text, const std::filesystem::path& path_for_messages);

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
