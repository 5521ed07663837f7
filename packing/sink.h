#pragma once
// Where packed particles go, chunk by chunk: the packer never holds more than a few z-layers of
// particles, and a sink decides what to keep (everything, for tests and small systems; nothing
// but a file for large ones).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "sim/model.h"
#include "sim/particle_io.h"

namespace mesorock::packing {

class ParticleSink {
 public:
  virtual ~ParticleSink() = default;
  virtual void append(const sim::ParticleSet& chunk) = 0;
};

// Keeps every particle in memory.
class MemorySink : public ParticleSink {
 public:
  void append(const sim::ParticleSet& chunk) override;
  sim::ParticleSet particles;
};

// Streams into an HDF5 particle file (sim::ParticleFileWriter): visible only after commit().
class ParticleFileSink : public ParticleSink {
 public:
  ParticleFileSink(const std::filesystem::path& path, sim::ParticleFileMeta meta)
      : writer_(path, std::move(meta)) {}
  void append(const sim::ParticleSet& chunk) override { writer_.append(chunk); }
  void commit() { writer_.commit(); }
  std::size_t size() const { return writer_.size(); }

 private:
  sim::ParticleFileWriter writer_;
};

// Streams into a LAMMPS data file (atom_style atomic, with a Velocities section; ids and types
// 1-based; every type of mass 1). The Atoms and Velocities sections go to two temporary files
// that commit() joins under the header (whose atom count is known only at the end); a sink
// destroyed before commit() removes them.
class LammpsDataSink : public ParticleSink {
 public:
  LammpsDataSink(const std::filesystem::path& path, std::vector<std::string> type_names,
                 const sim::BoxSpec& box, std::string title);
  ~LammpsDataSink() override;
  void append(const sim::ParticleSet& chunk) override;
  void commit();

 private:
  std::filesystem::path path_, atoms_path_, velocities_path_;
  std::vector<std::string> type_names_;
  sim::BoxSpec box_;
  std::string title_;
  std::ofstream atoms_, velocities_;
  std::int64_t count_ = 0;
  bool committed_ = false;
};

// Passes every chunk to several sinks.
class TeeSink : public ParticleSink {
 public:
  explicit TeeSink(std::vector<ParticleSink*> sinks) : sinks_(std::move(sinks)) {}
  void append(const sim::ParticleSet& chunk) override {
    for (ParticleSink* s : sinks_) s->append(chunk);
  }

 private:
  std::vector<ParticleSink*> sinks_;
};

}  // namespace mesorock::packing
