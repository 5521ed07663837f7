#include "packing/sink.h"

#include <cstdio>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"

namespace mesorock::packing {

namespace fs = std::filesystem;

void MemorySink::append(const sim::ParticleSet& c) {
  sim::ParticleSet& p = particles;
  p.x.insert(p.x.end(), c.x.begin(), c.x.end());
  p.y.insert(p.y.end(), c.y.begin(), c.y.end());
  p.z.insert(p.z.end(), c.z.begin(), c.z.end());
  p.vx.insert(p.vx.end(), c.vx.begin(), c.vx.end());
  p.vy.insert(p.vy.end(), c.vy.begin(), c.vy.end());
  p.vz.insert(p.vz.end(), c.vz.begin(), c.vz.end());
  p.type.insert(p.type.end(), c.type.begin(), c.type.end());
  p.id.insert(p.id.end(), c.id.begin(), c.id.end());
}

LammpsDataSink::LammpsDataSink(const fs::path& path, std::vector<std::string> type_names,
                               const sim::BoxSpec& box, std::string title)
    : path_(path),
      atoms_path_(temporary_path_for(path).string() + ".atoms"),
      velocities_path_(temporary_path_for(path).string() + ".velocities"),
      type_names_(std::move(type_names)),
      box_(box),
      title_(std::move(title)) {
  atoms_.open(atoms_path_);
  velocities_.open(velocities_path_);
  if (!atoms_ || !velocities_) throw IoError(path_.string() + ": cannot open for writing");
}

LammpsDataSink::~LammpsDataSink() {
  if (committed_) return;
  atoms_.close();
  velocities_.close();
  std::error_code ignored;
  fs::remove(atoms_path_, ignored);
  fs::remove(velocities_path_, ignored);
}

void LammpsDataSink::append(const sim::ParticleSet& c) {
  char line[160];
  for (std::size_t i = 0; i < c.size(); ++i) {
    const long long id = static_cast<long long>(c.id[i]) + 1;
    std::snprintf(line, sizeof line, "%lld %d %.10g %.10g %.10g\n", id, c.type[i] + 1, c.x[i],
                  c.y[i], c.z[i]);
    atoms_ << line;
    std::snprintf(line, sizeof line, "%lld %.10g %.10g %.10g\n", id, c.vx[i], c.vy[i], c.vz[i]);
    velocities_ << line;
  }
  count_ += static_cast<std::int64_t>(c.size());
  if (!atoms_ || !velocities_) throw IoError(path_.string() + ": write failed");
}

void LammpsDataSink::commit() {
  atoms_.close();
  velocities_.close();
  if (!atoms_ || !velocities_) throw IoError(path_.string() + ": write failed");
  write_atomically(path_, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << "# " << title_ << "\n\n"
        << count_ << " atoms\n"
        << type_names_.size() << " atom types\n\n";
    char line[160];
    const char* axis[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      std::snprintf(line, sizeof line, "%.10g %.10g %slo %shi\n", box_.lo[static_cast<size_t>(a)],
                    box_.hi[static_cast<size_t>(a)], axis[a], axis[a]);
      out << line;
    }
    out << "\nMasses\n\n";
    for (std::size_t t = 0; t < type_names_.size(); ++t)
      out << t + 1 << " 1.0  # " << type_names_[t] << "\n";
    out << "\nAtoms  # atomic\n\n";
    for (const fs::path& part : {atoms_path_, velocities_path_}) {
      std::ifstream in(part, std::ios::binary);
      if (!in) throw IoError(path_.string() + ": cannot read back " + part.string());
      if (fs::file_size(part) > 0) out << in.rdbuf();
      if (part == atoms_path_) out << "\nVelocities\n\n";
    }
    out.close();
    if (!out) throw IoError(path_.string() + ": write failed");
  });
  std::error_code ignored;
  fs::remove(atoms_path_, ignored);
  fs::remove(velocities_path_, ignored);
  committed_ = true;
}

}  // namespace mesorock::packing
