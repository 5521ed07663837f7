#pragma once
// Particle sets in HDF5 (the hand-off format between rockprep, rockflow and ParaView), plus an
// XDMF 3 sidecar so ParaView opens them. The layout is documented in docs/scene.md:
//
//   /particles/position  float64 [N,3]        /particles/type  int32 [N] (index into type_names)
//   /particles/velocity  float64 [N,3]        /particles/id    int64 [N]
//   /particles attributes: type_names (variable-length strings [ntypes]), box_lo, box_hi
//                          (float64[3]), periodic (int32[3]), step (uint64), time (float64)
//   / attributes: mesorock_version, git_commit, created_by, provenance (JSON text), length_unit
//
// Every failure is an IoError whose message names the file (and the dataset or attribute).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/model.h"

namespace mesorock::sim {

struct ParticleFileMeta {
  std::vector<std::string> type_names;  // type index -> name
  BoxSpec box;
  std::uint64_t step = 0;
  double time = 0;
  std::string created_by;       // e.g. "rockflow run"
  std::string provenance_json;  // JSON text: scene, parameters (stored as given)
  std::string length_unit = "rc";
  // Filled by read_particle_file only (written from mesorock/version.h).
  std::string mesorock_version;
  std::string git_commit;
};

// Call at the start of main() in every tool that writes HDF5. HDF5's exit-time cleanup closes the
// files still open; after a failed close (a full disk) it flushes the broken file again and
// crashes (SIGSEGV after our one-line error; found by the write-failure tests). Skipping it is
// safe: the operating system reclaims the rest, and our outputs are renamed only when complete.
void skip_hdf5_exit_cleanup();

// Writes `p` to `path` atomically (temporary file + rename): on failure `path` is untouched and
// no temporary is left behind. Every p.type must index meta.type_names; positions and velocities
// must be finite (else IoError before anything is written).
void write_particle_file(const std::filesystem::path& path, const ParticleSet& p,
                         const ParticleFileMeta& meta);

// Writes a particle file chunk by chunk (the same layout, in chunked datasets that grow with each
// append), so that a packing of 10^8 particles never holds them all in memory. Each chunk is
// checked as write_particle_file checks a whole set (type indices, finite values); ids are the
// caller's to keep unique. The file appears at `path` only when commit() succeeds; a writer
// destroyed before that removes its temporary file, so a failed run leaves nothing behind.
class ParticleFileWriter {
 public:
  ParticleFileWriter(const std::filesystem::path& path, ParticleFileMeta meta);
  ~ParticleFileWriter();
  ParticleFileWriter(const ParticleFileWriter&) = delete;
  ParticleFileWriter& operator=(const ParticleFileWriter&) = delete;

  void append(const ParticleSet& chunk);
  std::size_t size() const;  // particles appended so far
  // Writes the attributes, closes the file and renames it into place.
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reads and validates a particle file: dataset shapes and lengths, finite positions and
// velocities, type indices within type_names, finite box with hi > lo. Fills *meta_out when given.
ParticleSet read_particle_file(const std::filesystem::path& path,
                               ParticleFileMeta* meta_out = nullptr);

// The attributes of a particle file alone (type names, box, provenance...), checked as
// read_particle_file checks them, reading no particle.
ParticleFileMeta read_particle_file_meta(const std::filesystem::path& path);

// The particle count of a particle file, from the shape of /particles/position, reading no
// particle (for memory estimates before a scene's particles are built). IoError as above.
std::size_t read_particle_file_count(const std::filesystem::path& path);

// Writes an XDMF 3 sidecar for a particle file holding n particles: Polyvertex topology, XYZ
// geometry from /particles/position, attributes velocity (Vector), type and id (Scalar). The h5
// path is written relative to the .xmf file's folder. `time`, when given, becomes the grid's Time.
void write_particle_xdmf(const std::filesystem::path& xmf, const std::filesystem::path& h5,
                         std::size_t n, std::optional<double> time = std::nullopt);

}  // namespace mesorock::sim
