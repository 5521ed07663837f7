#pragma once
// Checkpoints: the solver state a run needs to continue bit for bit, and an HDF5 file that holds
// it together with whatever the caller needs to continue its own outputs (thermo rows so far,
// time series, accumulators), written atomically (temporary file + rename).
//
// Why the storage order: engines keep particles sorted by cell with a stable sort, and every
// force sum runs in storage order. A state saved in the caller's original order and re-sorted
// on resume would put particles of one cell in a different order, change the order of the force
// sums, and drift from the uninterrupted run at round-off. So the state is the engine's storage
// with the map back to the original order (`origin`), plus the forces of the last force pass
// (the next step's first kick needs them; recomputing them would also rerun the wall model's
// corrector). The pair random numbers are keyed by (seed, step, ids): no generator state.
//
// File layout (every entry is a 1-D dataset; texts are uint8 byte arrays):
//   /meta/format ("mesorock-checkpoint"), format_version ("1"), mesorock_version, git_commit,
//         created_by, scene_path, scene_text (the scene verbatim), parameters (JSON text),
//         input_files (the caller's record of the files the scene names, with their checksums),
//         checksums: "HEX PATH" a line for every other dataset (mesorock/checksum.h over the
//         dataset's bytes as read), then the table's own as "HEX /meta/checksums"; written last
//         and checked on read before any value is used: one flipped bit is named by its dataset
//   /checkpoint/x y z vx vy vz vex vey vez fx fy fz rho bvf   float64 [N] (vex.. and bvf may be
//         empty); a single-precision run's values widen to double exactly
//   /checkpoint/type int32 [N], origin int32 [N], id int64 [N]
//   /checkpoint/slabs float64 [7 per slab]: type, axis, applied_force, mass, velocity,
//         half_velocity, force
//   /checkpoint/step uint64 [1], dt float64 [1], wall_corrections uint64 [1], precision (text)
//   /run/text/NAME     the caller's texts (CSV rows so far, JSON)
//   /run/numbers/NAME  float64 [k], the caller's numbers (series, accumulators)
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/model.h"
#include "sim/rigid_slabs.h"

namespace mesorock::sim {

struct SimulationState {
  Precision precision = Precision::Double;
  std::uint64_t step = 0;
  double dt = 0.01;
  // Per particle, in storage order. vex/vey/vez are empty without a thermostat, bvf without the
  // wall model.
  std::vector<double> x, y, z, vx, vy, vz, vex, vey, vez, fx, fy, fz, rho, bvf;
  std::vector<std::int32_t> type;
  std::vector<std::int32_t> origin;  // where each stored particle stands in the original order
  std::vector<std::int64_t> id;
  std::vector<RigidSlabBody> slabs;
  std::uint64_t wall_corrections = 0;

  std::size_t size() const { return x.size(); }
  // The particles in the caller's original order (what Simulation::particles() returns).
  ParticleSet particles() const;
  // ConfigError naming the problem when arrays disagree in length or origin is not a
  // permutation.
  void check() const;
  // The stored rows `rows` (indices into this storage order) as a state of their own, in that
  // order, whose original order is that order too (origin = 0, 1, ...). Step, dt, slabs and wall
  // corrections are kept.
  SimulationState select(const std::vector<std::size_t>& rows) const;
  // This state re-stored in the original order (origin = 0, 1, ...): the order of particles().
  SimulationState in_original_order() const;
  // ConfigError when this state was not saved from a run of `model` (precision, thermostat, wall
  // model, rigid slabs): checked on the whole state, so every rank of a decomposed resume agrees.
  void check_fits(const Model& model) const;
};

struct CheckpointFile {
  SimulationState state;
  std::string created_by;       // e.g. "rockflow run"
  std::string scene_path;       // for messages
  std::string scene_text;       // the scene the run was started from, verbatim
  std::string parameters_json;  // backend, threads, options: provenance
  // The files the scene names and their checksums (the caller's text, compared on resume).
  std::string input_files;
  std::map<std::string, std::string> texts;
  std::map<std::string, std::vector<double>> numbers;
  // Filled by read_checkpoint only.
  std::string mesorock_version, git_commit;
};

// 2: /meta/checksums (every dataset's checksum) and /meta/input_files.
inline constexpr int kCheckpointFormatVersion = 2;

// Writes atomically: on failure `path` is untouched (an older checkpoint there survives).
void write_checkpoint(const std::filesystem::path& path, const CheckpointFile& checkpoint);
// Reads and checks a checkpoint; IoError naming the file and the object on any problem (a
// dataset whose checksum differs from the one written with it, too).
CheckpointFile read_checkpoint(const std::filesystem::path& path);

}  // namespace mesorock::sim
