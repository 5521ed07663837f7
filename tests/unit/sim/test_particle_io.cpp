// Particle files (HDF5) and their XDMF sidecars: round trip, validation of damaged files, atomic
// writes, and that every dataset the .xmf names opens with the stated dimensions.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/particle_io.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::IoError;
using mesorock::sim::ParticleFileMeta;
using mesorock::sim::ParticleSet;
using mesorock::sim::read_particle_file;
using mesorock::sim::write_particle_file;
using mesorock::sim::write_particle_xdmf;

using mesorock::test::read_file;
using mesorock::test::TempDir;

namespace {

ParticleSet sample_set(size_t n) {
  ParticleSet p;
  for (size_t i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    p.add(0.1 + 0.097 * s, 9.9 - 0.031 * s, std::fmod(1.0 / 3.0 + 0.77 * s, 10.0), std::sin(s),
          std::cos(s), -0.5 + 1e-3 * s, static_cast<std::int32_t>(i % 3),
          static_cast<std::int64_t>(1000 + 7 * i));
  }
  return p;
}

ParticleFileMeta sample_meta() {
  ParticleFileMeta m;
  m.type_names = {"fluid", "wall", "slab"};
  m.box.lo = {-1.5, 0, 2};
  m.box.hi = {12.5, 10, 22};
  m.box.periodic = {true, false, true};
  m.step = 123456789012ull;
  m.time = 1234.5678;
  m.created_by = "test_particle_io";
  m.provenance_json = R"({"scene":"bulk.toml","seed":42})";
  m.length_unit = "rc";
  return m;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const IoError& e) {
    return e.what();
  }
  return "<no IoError thrown>";
}

// Replaces /particles/<name> with a dataset of the given type, shape and raw data; without data,
// a chunked dataset that declares `dims` and stores nothing (a forged extent: the file stays
// small).
void replace_dataset(const fs::path& file, const char* name, hid_t type,
                     const std::vector<hsize_t>& dims, const void* data) {
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  hid_t g = H5Gopen2(f, "particles", H5P_DEFAULT);
  ASSERT_GE(g, 0);
  ASSERT_GE(H5Ldelete(g, name, H5P_DEFAULT), 0);
  hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  const std::vector<hsize_t> chunk(dims.size(), 1);
  if (!data) ASSERT_GE(H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data()), 0);
  hid_t ds = H5Dcreate2(g, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  if (data) ASSERT_GE(H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
  H5Dclose(ds);
  H5Pclose(dcpl);
  H5Sclose(space);
  H5Gclose(g);
  H5Fclose(f);
}

}  // namespace

// A forged row count is refused before any allocation, naming the file and the dataset (it was
// "out of memory" at 1e12 rows and an internal error at 2^62; issue 22, item 3).
TEST(ParticleIo, DeclaredRowsBeyondWhatTheFileHoldsAreRefusedBeforeAllocating) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  for (const hsize_t rows : {hsize_t{1000000000000ull}, hsize_t{1} << 62}) {
    write_particle_file(file, sample_set(100), sample_meta());
    replace_dataset(file, "position", H5T_NATIVE_DOUBLE, {rows, 3}, nullptr);
    const std::string e = error_of([&] { read_particle_file(file); });
    EXPECT_EQ(
        e.rfind(file.string() + ": /particles/position: declares [" + std::to_string(rows) + ",3]",
                0),
        0u)
        << e;
    EXPECT_NE(e.find("-byte file can hold"), std::string::npos) << e;
  }
}

TEST(ParticleIo, RoundTripKeepsEveryValueAndAttribute) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  const ParticleSet p = sample_set(100);
  ParticleFileMeta meta = sample_meta();
  // Larger than HDF5's 64 KiB compact-attribute limit: provenance may hold a whole scene.
  meta.provenance_json = "{\"scene\":\"" + std::string(200000, 'x') + "\"}";
  write_particle_file(file, p, meta);

  ParticleFileMeta back;
  const ParticleSet q = read_particle_file(file, &back);
  ASSERT_EQ(q.size(), p.size());
  EXPECT_EQ(q.x, p.x);
  EXPECT_EQ(q.y, p.y);
  EXPECT_EQ(q.z, p.z);
  EXPECT_EQ(q.vx, p.vx);
  EXPECT_EQ(q.vy, p.vy);
  EXPECT_EQ(q.vz, p.vz);
  EXPECT_EQ(q.type, p.type);
  EXPECT_EQ(q.id, p.id);
  EXPECT_EQ(back.type_names, meta.type_names);
  EXPECT_EQ(back.box.lo, meta.box.lo);
  EXPECT_EQ(back.box.hi, meta.box.hi);
  EXPECT_EQ(back.box.periodic, meta.box.periodic);
  EXPECT_EQ(back.step, meta.step);
  EXPECT_EQ(back.time, meta.time);
  EXPECT_EQ(back.created_by, meta.created_by);
  EXPECT_EQ(back.provenance_json, meta.provenance_json);
  EXPECT_EQ(back.length_unit, "rc");
  EXPECT_EQ(back.mesorock_version, mesorock::kVersion);
  EXPECT_EQ(back.git_commit, mesorock::kGitCommit);
  // No temporary left behind.
  EXPECT_FALSE(fs::exists(mesorock::temporary_path_for(file)));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

TEST(ParticleIo, EmptySetRoundTrips) {
  TempDir dir;
  const fs::path file = dir.path() / "empty.h5";
  write_particle_file(file, ParticleSet{}, sample_meta());
  ParticleFileMeta back;
  const ParticleSet q = read_particle_file(file, &back);
  EXPECT_EQ(q.size(), 0u);
  EXPECT_EQ(back.type_names.size(), 3u);
}

TEST(ParticleIo, StoredLayoutIsTheDocumentedOne) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(10), sample_meta());
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  struct Want {
    const char* path;
    std::vector<hsize_t> dims;
    hid_t type;
  };
  for (const Want& w :
       {Want{"/particles/position", {10, 3}, H5T_IEEE_F64LE},
        Want{"/particles/velocity", {10, 3}, H5T_IEEE_F64LE},
        Want{"/particles/type", {10}, H5T_STD_I32LE}, Want{"/particles/id", {10}, H5T_STD_I64LE}}) {
    SCOPED_TRACE(w.path);
    hid_t ds = H5Dopen2(f, w.path, H5P_DEFAULT);
    ASSERT_GE(ds, 0);
    hid_t space = H5Dget_space(ds);
    std::vector<hsize_t> dims(static_cast<size_t>(H5Sget_simple_extent_ndims(space)));
    H5Sget_simple_extent_dims(space, dims.data(), nullptr);
    EXPECT_EQ(dims, w.dims);
    hid_t t = H5Dget_type(ds);
    EXPECT_GT(H5Tequal(t, w.type), 0);
    H5Tclose(t);
    H5Sclose(space);
    H5Dclose(ds);
  }
  for (const char* a : {"type_names", "box_lo", "box_hi", "periodic", "step", "time"})
    EXPECT_GT(H5Aexists_by_name(f, "particles", a, H5P_DEFAULT), 0) << a;
  for (const char* a :
       {"mesorock_version", "git_commit", "created_by", "provenance", "length_unit"})
    EXPECT_GT(H5Aexists(f, a), 0) << a;
  H5Fclose(f);
}

TEST(ParticleIo, MissingFileIsAnIoErrorNamingIt) {
  TempDir dir;
  const fs::path file = dir.path() / "nope.h5";
  EXPECT_EQ(error_of([&] { read_particle_file(file); }), file.string() + ": no such file");
}

TEST(ParticleIo, GarbageBytesAreAnIoErrorNamingTheFile) {
  TempDir dir;
  const fs::path file = dir.path() / "garbage.h5";
  std::ofstream(file, std::ios::binary) << std::string(4096, '\x5a') << "not hdf5";
  const std::string msg = error_of([&] { read_particle_file(file); });
  EXPECT_EQ(msg.rfind(file.string() + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find("HDF5"), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

TEST(ParticleIo, WrongDatasetLengthNamesFileAndDataset) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(100), sample_meta());
  std::vector<std::int32_t> types(99, 0);
  replace_dataset(file, "type", H5T_NATIVE_INT32, {99}, types.data());
  EXPECT_EQ(error_of([&] { read_particle_file(file); }),
            file.string() + ": /particles/type: 99 entries, expected 100");
}

TEST(ParticleIo, WrongVelocityRowsNamesDataset) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(100), sample_meta());
  std::vector<double> v(3 * 101, 0.0);
  replace_dataset(file, "velocity", H5T_NATIVE_DOUBLE, {101, 3}, v.data());
  EXPECT_EQ(error_of([&] { read_particle_file(file); }),
            file.string() + ": /particles/velocity: 101 rows, expected 100");
}

TEST(ParticleIo, WrongPositionShapeNamesDataset) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(100), sample_meta());
  std::vector<double> v(2 * 100, 0.0);
  replace_dataset(file, "position", H5T_NATIVE_DOUBLE, {100, 2}, v.data());
  EXPECT_EQ(error_of([&] { read_particle_file(file); }),
            file.string() + ": /particles/position: expected shape [N,3], got [100,2]");
}

TEST(ParticleIo, NonFiniteStoredValueIsRejected) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  ParticleSet p = sample_set(10);
  write_particle_file(file, p, sample_meta());
  std::vector<double> pos;
  for (size_t i = 0; i < p.size(); ++i) pos.insert(pos.end(), {p.x[i], p.y[i], p.z[i]});
  pos[3 * 4 + 1] = std::nan("");
  replace_dataset(file, "position", H5T_NATIVE_DOUBLE, {10, 3}, pos.data());
  EXPECT_EQ(error_of([&] { read_particle_file(file); }),
            file.string() + ": /particles/position: entry 4 is not finite");
}

TEST(ParticleIo, TypeIndexBeyondTypeNamesIsRejected) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(10), sample_meta());
  std::vector<std::int32_t> types(10, 1);
  types[7] = 3;
  replace_dataset(file, "type", H5T_NATIVE_INT32, {10}, types.data());
  const std::string msg = error_of([&] { read_particle_file(file); });
  EXPECT_EQ(msg.rfind(file.string() + ": /particles/type: entry 7 is 3, outside 0..2", 0), 0u)
      << msg;
}

TEST(ParticleIo, DuplicateIdsAreRejected) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(10), sample_meta());
  std::vector<std::int64_t> ids{0, 1, 2, 3, 4, 5, 6, 7, 8, 3};
  replace_dataset(file, "id", H5T_NATIVE_INT64, {10}, ids.data());
  EXPECT_EQ(error_of([&] { read_particle_file(file); }),
            file.string() + ": /particles/id: duplicate id 3");
}

TEST(ParticleIo, MissingTypeNamesAttributeIsRejected) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(10), sample_meta());
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  ASSERT_GE(H5Adelete_by_name(f, "particles", "type_names", H5P_DEFAULT), 0);
  H5Fclose(f);
  EXPECT_EQ(error_of([&] { read_particle_file(file); }),
            file.string() + ": /particles@type_names: missing");
}

TEST(ParticleIo, FailedWriteLeavesTargetUntouchedAndNoTemporary) {
  TempDir dir;
  const fs::path file = dir.path() / "p.h5";
  write_particle_file(file, sample_set(10), sample_meta());
  const std::string before = read_file(file);

  ParticleSet bad = sample_set(20);
  bad.type[5] = 9;  // not a type name index
  const std::string msg = error_of([&] { write_particle_file(file, bad, sample_meta()); });
  EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
  ParticleSet nonfinite = sample_set(20);
  nonfinite.vz[3] = INFINITY;
  EXPECT_NE(error_of([&] { write_particle_file(file, nonfinite, sample_meta()); }),
            "<no IoError thrown>");
  EXPECT_EQ(read_file(file), before);
  EXPECT_EQ(read_particle_file(file).size(), 10u);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);

  // A folder that does not exist: IoError naming the target, nothing created.
  const fs::path nowhere = dir.path() / "no-such-dir" / "p.h5";
  const std::string msg2 =
      error_of([&] { write_particle_file(nowhere, sample_set(3), sample_meta()); });
  EXPECT_EQ(msg2.rfind(nowhere.string() + ": ", 0), 0u) << msg2;
  EXPECT_FALSE(fs::exists(dir.path() / "no-such-dir"));
}

namespace {

struct XmlElement {
  std::string name;
  std::map<std::string, std::string> attrs;
  std::string text;  // for DataItem: its character content
};

// A deliberately small parser for the flat XML write_particle_xdmf produces: start tags with
// attributes, and the text content of DataItem elements.
std::vector<XmlElement> parse_xml_elements(const std::string& xml) {
  std::vector<XmlElement> out;
  const std::regex tag(R"(<([A-Za-z]+)((?:\s+[A-Za-z:]+="[^"]*")*)\s*(/?)>)");
  const std::regex attr(R"(([A-Za-z:]+)="([^"]*)\")");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator();
       ++it) {
    XmlElement e;
    e.name = (*it)[1];
    const std::string attrs = (*it)[2];
    for (auto a = std::sregex_iterator(attrs.begin(), attrs.end(), attr);
         a != std::sregex_iterator(); ++a)
      e.attrs[(*a)[1]] = (*a)[2];
    if (e.name == "DataItem" && (*it)[3].length() == 0) {
      const size_t start = static_cast<size_t>(it->position() + it->length());
      const size_t end = xml.find("</DataItem>", start);
      e.text = xml.substr(start, end - start);
    }
    out.push_back(e);
  }
  return out;
}

std::vector<hsize_t> parse_dims(const std::string& s) {
  std::vector<hsize_t> d;
  std::istringstream in(s);
  for (hsize_t v; in >> v;) d.push_back(v);
  return d;
}

}  // namespace

TEST(ParticleIo, XdmfSidecarNamesDatasetsThatOpenWithStatedDimensions) {
  TempDir dir;
  fs::create_directories(dir.path() / "data");
  fs::create_directories(dir.path() / "view");
  const fs::path h5 = dir.path() / "data" / "snap.h5";
  const fs::path xmf = dir.path() / "view" / "snap.xmf";
  const size_t n = 37;
  write_particle_file(h5, sample_set(n), sample_meta());
  write_particle_xdmf(xmf, h5, n, 2.5);

  const std::string xml = read_file(xmf);
  ASSERT_NE(xml.find("<Xdmf Version=\"3.0\""), std::string::npos) << xml;
  const auto elements = parse_xml_elements(xml);
  std::map<std::string, XmlElement> attributes;
  int topologies = 0, geometries = 0, data_items = 0;
  for (const auto& e : elements) {
    if (e.name == "Topology") {
      ++topologies;
      EXPECT_EQ(e.attrs.at("TopologyType"), "Polyvertex");
      EXPECT_EQ(e.attrs.at("NumberOfElements"), std::to_string(n));
    } else if (e.name == "Geometry") {
      ++geometries;
      EXPECT_EQ(e.attrs.at("GeometryType"), "XYZ");
    } else if (e.name == "Attribute") {
      attributes[e.attrs.at("Name")] = e;
    } else if (e.name == "Time") {
      EXPECT_EQ(e.attrs.at("Value"), "2.5");
    } else if (e.name == "DataItem") {
      ++data_items;
      SCOPED_TRACE(e.text);
      EXPECT_EQ(e.attrs.at("Format"), "HDF");
      const size_t colon = e.text.find(":/");
      ASSERT_NE(colon, std::string::npos);
      const std::string rel = e.text.substr(0, colon), dataset = e.text.substr(colon + 1);
      EXPECT_EQ(rel, "../data/snap.h5");  // relative to the .xmf's folder
      const fs::path file = xmf.parent_path() / rel;
      hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
      ASSERT_GE(f, 0);
      hid_t ds = H5Dopen2(f, dataset.c_str(), H5P_DEFAULT);
      ASSERT_GE(ds, 0);
      hid_t space = H5Dget_space(ds);
      std::vector<hsize_t> dims(static_cast<size_t>(H5Sget_simple_extent_ndims(space)));
      H5Sget_simple_extent_dims(space, dims.data(), nullptr);
      EXPECT_EQ(dims, parse_dims(e.attrs.at("Dimensions")));
      hid_t t = H5Dget_type(ds);
      EXPECT_EQ(H5Tget_size(t), std::stoul(e.attrs.at("Precision")));
      EXPECT_EQ(H5Tget_class(t) == H5T_FLOAT, e.attrs.at("NumberType") == "Float");
      H5Tclose(t);
      H5Sclose(space);
      H5Dclose(ds);
      H5Fclose(f);
    }
  }
  EXPECT_EQ(topologies, 1);
  EXPECT_EQ(geometries, 1);
  EXPECT_EQ(data_items, 4);
  ASSERT_EQ(attributes.size(), 3u);
  EXPECT_EQ(attributes.at("velocity").attrs.at("AttributeType"), "Vector");
  EXPECT_EQ(attributes.at("type").attrs.at("AttributeType"), "Scalar");
  EXPECT_EQ(attributes.at("id").attrs.at("AttributeType"), "Scalar");
}

TEST(ParticleIo, XdmfBesideTheH5UsesTheBareFileName) {
  TempDir dir;
  const fs::path h5 = dir.path() / "p.h5";
  const fs::path xmf = dir.path() / "p.xmf";
  write_particle_file(h5, sample_set(4), sample_meta());
  write_particle_xdmf(xmf, h5, 4);
  const std::string xml = read_file(xmf);
  EXPECT_NE(xml.find(">p.h5:/particles/position<"), std::string::npos) << xml;
  EXPECT_EQ(xml.find("<Time"), std::string::npos);
}
