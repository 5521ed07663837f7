#include "sim/checkpoint.h"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <type_traits>

#include "mesorock/atomic_file.h"
#include "mesorock/checksum.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/hdf5_util.h"

namespace mesorock::sim {

namespace fs = std::filesystem;
using namespace hdf5_util;

ParticleSet SimulationState::particles() const {
  const size_t n = size();
  ParticleSet p;
  for (auto* a : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz}) a->resize(n);
  p.type.resize(n);
  p.id.resize(n);
  for (size_t k = 0; k < n; ++k) {
    const size_t o = static_cast<size_t>(origin[k]);
    p.x[o] = x[k], p.y[o] = y[k], p.z[o] = z[k];
    p.vx[o] = vx[k], p.vy[o] = vy[k], p.vz[o] = vz[k];
    p.type[o] = type[k];
    p.id[o] = id[k];
  }
  return p;
}

SimulationState SimulationState::select(const std::vector<std::size_t>& rows) const {
  SimulationState out;
  out.precision = precision;
  out.step = step;
  out.dt = dt;
  out.slabs = slabs;
  out.wall_corrections = wall_corrections;
  auto pick = [&](const auto& in, auto& to) {
    to.clear();
    if (in.empty()) return;  // an optional array stays absent
    to.reserve(rows.size());
    for (std::size_t r : rows) to.push_back(in.at(r));
  };
  const std::vector<double>* in[14] = {&x,   &y,   &z,  &vx, &vy, &vz,  &vex,
                                       &vey, &vez, &fx, &fy, &fz, &rho, &bvf};
  std::vector<double>* to[14] = {&out.x,   &out.y,   &out.z,  &out.vx, &out.vy, &out.vz,  &out.vex,
                                 &out.vey, &out.vez, &out.fx, &out.fy, &out.fz, &out.rho, &out.bvf};
  for (int a = 0; a < 14; ++a) pick(*in[a], *to[a]);
  pick(type, out.type);
  pick(id, out.id);
  out.origin.resize(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) out.origin[k] = static_cast<std::int32_t>(k);
  return out;
}

SimulationState SimulationState::in_original_order() const {
  check();
  std::vector<std::size_t> rows(size());
  for (std::size_t k = 0; k < rows.size(); ++k) rows[static_cast<std::size_t>(origin[k])] = k;
  return select(rows);
}

void SimulationState::check_fits(const Model& model) const {
  if (precision != model.precision)
    throw ConfigError(std::string("state: saved in ") + to_string(precision) +
                      " precision, the model runs in " + to_string(model.precision));
  if (size() > 0 && vex.empty() == model.thermostat)
    throw ConfigError("state: the thermostat setting differs from the saved run's");
  if (size() > 0 && bvf.empty() == model.wall_model.enabled)
    throw ConfigError("state: the wall model setting differs from the saved run's");
  if (slabs.size() != model.rigid_slabs.size())
    throw ConfigError("state: the number of rigid slabs differs from the saved run's");
  for (std::size_t k = 0; k < slabs.size(); ++k)
    if (slabs[k].type != model.rigid_slabs[k].type || slabs[k].axis != model.rigid_slabs[k].axis)
      throw ConfigError("state: rigid slab " + std::to_string(k + 1) + " differs from the model's");
}

void SimulationState::check() const {
  const size_t n = size();
  for (const auto* a : {&y, &z, &vx, &vy, &vz, &fx, &fy, &fz, &rho})
    if (a->size() != n) throw ConfigError("state: per-particle arrays differ in length");
  for (const auto* a : {&vex, &vey, &vez, &bvf})
    if (!a->empty() && a->size() != n)
      throw ConfigError("state: per-particle arrays differ in length");
  if (type.size() != n || origin.size() != n || id.size() != n)
    throw ConfigError("state: per-particle arrays differ in length");
  std::vector<char> seen(n, 0);
  for (std::int32_t o : origin) {
    if (o < 0 || static_cast<size_t>(o) >= n || seen[static_cast<size_t>(o)])
      throw ConfigError("state: the original-order map is not a permutation");
    seen[static_cast<size_t>(o)] = 1;
  }
  if (!(dt > 0)) throw ConfigError("state: dt must be positive");
}

namespace {

void check_name(const std::string& name, const std::string& file) {
  if (name.empty() || name.find('/') != std::string::npos || name == ".")
    throw IoError(file + ": checkpoint entry name '" + name + "' is not a valid HDF5 name");
}

template <class T>
void write_array(hid_t group, const std::string& name, const std::string& where, hid_t type,
                 const std::vector<T>& data, const std::string& file) {
  write_dataset(group, name.c_str(), where, type, type, {static_cast<hsize_t>(data.size())},
                data.data(), file);
}

void write_text(hid_t group, const std::string& name, const std::string& where,
                const std::string& text, const std::string& file) {
  write_dataset(group, name.c_str(), where, H5T_NATIVE_UINT8, H5T_NATIVE_UINT8,
                {static_cast<hsize_t>(text.size())}, text.data(), file);
}

Handle open_group(hid_t parent, const char* name, const std::string& where,
                  const std::string& file) {
  if (H5Lexists(parent, name, H5P_DEFAULT) <= 0) fail(file, where, "missing");
  return checked(H5Gopen2(parent, name, H5P_DEFAULT), H5Gclose, file, where, "cannot open group");
}

// A 1-D dataset of `want` class read into memory type `mem` (any length).
template <class T>
std::vector<T> read_array(hid_t group, const std::string& name, const std::string& where, hid_t mem,
                          H5T_class_t want, const std::string& file) {
  if (H5Lexists(group, name.c_str(), H5P_DEFAULT) <= 0) fail(file, where, "missing");
  Handle ds = checked(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose, file, where,
                      "cannot open dataset");
  Handle type = checked(H5Dget_type(ds.get()), H5Tclose, file, where, "cannot read datatype");
  if (H5Tget_class(type.get()) != want)
    fail(file, where, std::string("must be ") + class_name(want));
  Handle space = checked(H5Dget_space(ds.get()), H5Sclose, file, where, "cannot read dataspace");
  const auto dims = extent(space.get(), file, where);
  if (dims.size() != 1) fail(file, where, "expected a 1-D dataset, got " + dims_text(dims));
  check_declared_size(ds.get(), dims, sizeof(T), file, where);
  std::vector<T> out(static_cast<size_t>(dims[0]));
  if (!out.empty())
    check(H5Dread(ds.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), file, where,
          "read failed");
  return out;
}

std::string read_text(hid_t group, const std::string& name, const std::string& where,
                      const std::string& file) {
  const auto bytes =
      read_array<std::uint8_t>(group, name, where, H5T_NATIVE_UINT8, H5T_INTEGER, file);
  return std::string(bytes.begin(), bytes.end());
}

std::vector<std::string> member_names(hid_t group, const std::string& where,
                                      const std::string& file) {
  H5G_info_t info;
  check(H5Gget_info(group, &info), file, where, "cannot list group");
  std::vector<std::string> names;
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    const ssize_t len =
        H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, k, nullptr, 0, H5P_DEFAULT);
    if (len < 0) fail(file, where, "cannot list group");
    std::string name(static_cast<size_t>(len) + 1, '\0');
    H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, k, name.data(), name.size(),
                       H5P_DEFAULT);
    name.resize(static_cast<size_t>(len));
    names.push_back(name);
  }
  return names;
}

const char* const kRealNames[14] = {"x",   "y",   "z",  "vx", "vy", "vz",  "vex",
                                    "vey", "vez", "fx", "fy", "fz", "rho", "bvf"};

std::vector<double> SimulationState::*const kRealArrays[14] = {
    &SimulationState::x,   &SimulationState::y,  &SimulationState::z,   &SimulationState::vx,
    &SimulationState::vy,  &SimulationState::vz, &SimulationState::vex, &SimulationState::vey,
    &SimulationState::vez, &SimulationState::fx, &SimulationState::fy,  &SimulationState::fz,
    &SimulationState::rho, &SimulationState::bvf};

constexpr int kSlabFields = 7;

// Checksums of a checkpoint's datasets (mesorock/checksum.h): "HEX PATH" a line, in path order,
// then the table's own sum as "HEX /meta/checksums", so a damaged table is named as such.
class Checksums {
 public:
  void add(const std::string& where, const std::string& text) {
    sums_[where] = checksum_hex(text.data(), text.size());
  }
  template <class T>
  void add(const std::string& where, const std::vector<T>& v) {
    sums_[where] = checksum_hex(v);
  }
  std::string table() const {
    std::string t;
    for (const auto& [where, hex] : sums_) t += hex + " " + where + "\n";
    return t + checksum_hex(t.data(), t.size()) + " /meta/checksums\n";
  }
  // IoError naming the first dataset whose bytes differ from the sum written with it.
  void verify(const std::string& table, const std::string& file) const {
    const std::string own = " /meta/checksums\n";
    const std::size_t last = table.size() >= own.size() + 16 ? table.size() - own.size() - 16 : 0;
    if (table.size() < own.size() + 16 || table.compare(last + 16, own.size(), own) != 0 ||
        (last > 0 && table[last - 1] != '\n') ||
        checksum_hex(table.data(), last) != table.substr(last, 16))
      fail(file, "/meta/checksums", "damaged (its own checksum does not match): " + kCannot);
    std::map<std::string, std::string> written;
    std::size_t at = 0;
    while (at < last) {
      const std::size_t end = table.find('\n', at);
      if (end == std::string::npos || end - at < 18 || table[at + 16] != ' ')
        fail(file, "/meta/checksums", "damaged: " + kCannot);
      written[table.substr(at + 17, end - at - 17)] = table.substr(at, 16);
      at = end + 1;
    }
    for (const auto& [where, hex] : sums_) {
      const auto it = written.find(where);
      if (it == written.end())
        fail(file, where,
             "not listed in /meta/checksums (added after the checkpoint was written): " + kCannot);
      if (it->second != hex)
        fail(file, where, "checksum mismatch: the checkpoint is damaged: " + kCannot);
    }
    for (const auto& [where, hex] : written)
      if (!sums_.count(where)) fail(file, where, "missing (listed in /meta/checksums): " + kCannot);
  }

 private:
  inline static const std::string kCannot =
      "this checkpoint cannot be resumed (remove it to start the run afresh)";
  std::map<std::string, std::string> sums_;
};

// The state's checks once its checksums hold: slabs, precision, lengths, finite values.
void check_state(SimulationState& s, const std::vector<double>& slabs, const std::string& precision,
                 const std::string& file) {
  if (slabs.size() % kSlabFields != 0) fail(file, "/checkpoint/slabs", "wrong length");
  for (size_t k = 0; k + kSlabFields <= slabs.size(); k += kSlabFields) {
    RigidSlabBody b;
    b.type = static_cast<int>(slabs[k]);
    b.axis = static_cast<int>(slabs[k + 1]);
    b.applied_force = slabs[k + 2];
    b.mass = slabs[k + 3];
    b.velocity = slabs[k + 4];
    b.half_velocity = slabs[k + 5];
    b.force = slabs[k + 6];
    s.slabs.push_back(b);
  }
  if (precision != "single" && precision != "double")
    fail(file, "/checkpoint/precision", "must be single or double (got " + precision + ")");
  s.precision = precision == "single" ? Precision::Single : Precision::Double;
  try {
    s.check();
  } catch (const ConfigError& e) {
    fail(file, "/checkpoint", e.what());
  }
  // A NaN here reached the solver's input check as "particle N has a non-finite position or
  // velocity", naming no file.
  for (int a = 0; a < 14; ++a) {
    const std::vector<double>& v = s.*kRealArrays[a];
    const auto bad = std::find_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); });
    if (bad == v.end()) continue;
    const auto i = static_cast<size_t>(bad - v.begin());
    fail(file, std::string("/checkpoint/") + kRealNames[a],
         "entry " + std::to_string(i) + " (particle id " + std::to_string(s.id[i]) + ") is " +
             (std::isnan(*bad) ? "NaN" : "infinite") +
             ": this checkpoint cannot be resumed (remove it to start the run afresh)");
  }
}

}  // namespace

void write_checkpoint(const fs::path& path, const CheckpointFile& c) {
  const std::string file = path.string();
  c.state.check();
  for (const auto& [name, text] : c.texts) check_name(name, file);
  for (const auto& [name, v] : c.numbers) check_name(name, file);
  silence_hdf5_errors();
  write_atomically(path, [&](const fs::path& tmp) {
    Handle f = create_file(tmp, file);
    Checksums sums;  // of every dataset, written last (/meta/checksums)
    const auto text = [&](hid_t g, const std::string& name, const std::string& where,
                          const std::string& t) {
      write_text(g, name, where, t, file);
      sums.add(where, t);
    };
    const auto array = [&](hid_t g, const std::string& name, const std::string& where, hid_t type,
                           const auto& data) {
      write_array(g, name, where, type, data, file);
      sums.add(where, data);
    };
    Handle meta = create_group(f.get(), "meta", "/meta", file);
    {
      const std::pair<const char*, std::string> texts[] = {
          {"format", "mesorock-checkpoint"},
          {"format_version", std::to_string(kCheckpointFormatVersion)},
          {"mesorock_version", kVersion},
          {"git_commit", kGitCommit},
          {"created_by", c.created_by},
          {"scene_path", c.scene_path},
          {"scene_text", c.scene_text},
          {"parameters", c.parameters_json},
          {"input_files", c.input_files}};
      for (const auto& [name, t] : texts) text(meta.get(), name, std::string("/meta/") + name, t);
    }
    {
      const SimulationState& s = c.state;
      Handle g = create_group(f.get(), "checkpoint", "/checkpoint", file);
      for (int a = 0; a < 14; ++a)
        array(g.get(), kRealNames[a], std::string("/checkpoint/") + kRealNames[a],
              H5T_NATIVE_DOUBLE, s.*kRealArrays[a]);
      array(g.get(), "type", "/checkpoint/type", H5T_NATIVE_INT32, s.type);
      array(g.get(), "origin", "/checkpoint/origin", H5T_NATIVE_INT32, s.origin);
      array(g.get(), "id", "/checkpoint/id", H5T_NATIVE_INT64, s.id);
      std::vector<double> slabs;
      for (const RigidSlabBody& b : s.slabs)
        for (double v : {double(b.type), double(b.axis), b.applied_force, b.mass, b.velocity,
                         b.half_velocity, b.force})
          slabs.push_back(v);
      array(g.get(), "slabs", "/checkpoint/slabs", H5T_NATIVE_DOUBLE, slabs);
      array(g.get(), "step", "/checkpoint/step", H5T_NATIVE_UINT64,
            std::vector<std::uint64_t>{s.step});
      array(g.get(), "dt", "/checkpoint/dt", H5T_NATIVE_DOUBLE, std::vector<double>{s.dt});
      array(g.get(), "wall_corrections", "/checkpoint/wall_corrections", H5T_NATIVE_UINT64,
            std::vector<std::uint64_t>{s.wall_corrections});
      text(g.get(), "precision", "/checkpoint/precision", to_string(s.precision));
    }
    {
      Handle run = create_group(f.get(), "run", "/run", file);
      Handle texts = create_group(run.get(), "text", "/run/text", file);
      for (const auto& [name, t] : c.texts) text(texts.get(), name, "/run/text/" + name, t);
      Handle numbers = create_group(run.get(), "numbers", "/run/numbers", file);
      for (const auto& [name, v] : c.numbers)
        array(numbers.get(), name, "/run/numbers/" + name, H5T_NATIVE_DOUBLE, v);
    }
    write_text(meta.get(), "checksums", "/meta/checksums", sums.table(), file);
    if (!meta.close()) fail(file, "/meta", "write failed");
    if (!f.close()) fail(file, "", "write failed");
  });
}

CheckpointFile read_checkpoint(const fs::path& path) {
  const std::string file = path.string();
  silence_hdf5_errors();
  if (!fs::exists(path)) throw IoError(file + ": no checkpoint here");
  if (!fs::is_regular_file(path)) throw IoError(file + ": not a regular file");
  Handle f = checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, file, "",
                     "cannot open as HDF5");
  CheckpointFile c;
  Checksums sums;  // of what was read, compared with /meta/checksums before anything is used
  const auto text = [&](hid_t g, const std::string& name, const std::string& where) {
    std::string t = read_text(g, name, where, file);
    sums.add(where, t);
    return t;
  };
  std::string table;
  {
    Handle meta = open_group(f.get(), "meta", "/meta", file);
    if (text(meta.get(), "format", "/meta/format") != "mesorock-checkpoint")
      fail(file, "/meta/format", "not a mesorock checkpoint");
    const std::string version = text(meta.get(), "format_version", "/meta/format_version");
    if (version != std::to_string(kCheckpointFormatVersion))
      fail(file, "/meta/format_version",
           "format version " + version + ", this build reads " +
               std::to_string(kCheckpointFormatVersion));
    c.mesorock_version = text(meta.get(), "mesorock_version", "/meta/mesorock_version");
    c.git_commit = text(meta.get(), "git_commit", "/meta/git_commit");
    c.created_by = text(meta.get(), "created_by", "/meta/created_by");
    c.scene_path = text(meta.get(), "scene_path", "/meta/scene_path");
    c.scene_text = text(meta.get(), "scene_text", "/meta/scene_text");
    c.parameters_json = text(meta.get(), "parameters", "/meta/parameters");
    c.input_files = text(meta.get(), "input_files", "/meta/input_files");
    table = read_text(meta.get(), "checksums", "/meta/checksums", file);
  }
  std::vector<double> slabs;
  std::string precision;
  {
    SimulationState& s = c.state;
    Handle g = open_group(f.get(), "checkpoint", "/checkpoint", file);
    const auto array = [&](const char* name, auto& to, hid_t mem, H5T_class_t want) {
      const std::string where = std::string("/checkpoint/") + name;
      using T = typename std::decay_t<decltype(to)>::value_type;
      to = read_array<T>(g.get(), name, where, mem, want, file);
      sums.add(where, to);
    };
    for (int a = 0; a < 14; ++a)
      array(kRealNames[a], s.*kRealArrays[a], H5T_NATIVE_DOUBLE, H5T_FLOAT);
    array("type", s.type, H5T_NATIVE_INT32, H5T_INTEGER);
    array("origin", s.origin, H5T_NATIVE_INT32, H5T_INTEGER);
    array("id", s.id, H5T_NATIVE_INT64, H5T_INTEGER);
    array("slabs", slabs, H5T_NATIVE_DOUBLE, H5T_FLOAT);
    std::vector<std::uint64_t> step, wall_corrections;
    std::vector<double> dt;
    array("step", step, H5T_NATIVE_UINT64, H5T_INTEGER);
    array("dt", dt, H5T_NATIVE_DOUBLE, H5T_FLOAT);
    array("wall_corrections", wall_corrections, H5T_NATIVE_UINT64, H5T_INTEGER);
    if (step.size() != 1) fail(file, "/checkpoint/step", "expected one value");
    if (dt.size() != 1) fail(file, "/checkpoint/dt", "expected one value");
    if (wall_corrections.size() != 1)
      fail(file, "/checkpoint/wall_corrections", "expected one value");
    s.step = step[0];
    s.dt = dt[0];
    s.wall_corrections = wall_corrections[0];
    precision = text(g.get(), "precision", "/checkpoint/precision");
  }
  {
    Handle run = open_group(f.get(), "run", "/run", file);
    Handle texts = open_group(run.get(), "text", "/run/text", file);
    for (const std::string& name : member_names(texts.get(), "/run/text", file))
      c.texts[name] = text(texts.get(), name, "/run/text/" + name);
    Handle numbers = open_group(run.get(), "numbers", "/run/numbers", file);
    for (const std::string& name : member_names(numbers.get(), "/run/numbers", file)) {
      const std::string where = "/run/numbers/" + name;
      c.numbers[name] =
          read_array<double>(numbers.get(), name, where, H5T_NATIVE_DOUBLE, H5T_FLOAT, file);
      sums.add(where, c.numbers[name]);
    }
  }
  sums.verify(table, file);
  check_state(c.state, slabs, precision, file);
  return c;
}

}  // namespace mesorock::sim
