// Binned-field files (3-D grid, HDF5 + XDMF) and 1-D profiles (HDF5 + XDMF + CSV): the stored
// layout, units and provenance, validation, atomic writes, and that every XDMF sidecar passes
// the XDMF checker (tests/support/xdmf_check.h).
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/field_io.h"
#include "sim/units.h"
#include "support/test_support.h"
#include "support/xdmf_check.h"

namespace fs = std::filesystem;
using mesorock::IoError;
using mesorock::sim::FieldData;
using mesorock::sim::FieldFileMeta;
using mesorock::sim::FieldGrid;
using mesorock::sim::ProfileField;
using mesorock::sim::write_field_file;
using mesorock::sim::write_field_xdmf;
using mesorock::sim::write_profile_csv;
using mesorock::sim::write_profile_file;
using mesorock::sim::write_profile_xdmf;
using mesorock::test::read_file;
using mesorock::test::TempDir;
using mesorock::test::xdmf_problems;

namespace {

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += x + "\n";
  return s;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const IoError& e) {
    return e.what();
  }
  return "<no IoError thrown>";
}

size_t files_in(const fs::path& dir) {
  return static_cast<size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// 4 x 3 x 2 cells, non-cubic spacing, an origin off zero.
FieldGrid sample_grid() {
  FieldGrid g;
  g.cells = {4, 3, 2};
  g.origin = {-1.0, 0.5, 2.0};
  g.spacing = {0.5, 1.0, 2.0};
  return g;
}

// density(i,j,k) = 100 k + 10 j + i; velocity(i,j,k) = (i, j, k) + 0.1 c; stress: 6 components.
std::vector<FieldData> sample_fields(const FieldGrid& g) {
  FieldData rho{"density", 1, "1/rc^3", {}};
  FieldData vel{"velocity", 3, "rc/tau", {}};
  FieldData sig{"stress", 6, "kBT/rc^3", {}};
  rho.values.resize(g.cell_count());
  vel.values.resize(3 * g.cell_count());
  sig.values.resize(6 * g.cell_count());
  for (int k = 0; k < g.cells[2]; ++k)
    for (int j = 0; j < g.cells[1]; ++j)
      for (int i = 0; i < g.cells[0]; ++i) {
        const size_t c = g.index(i, j, k);
        rho.values[c] = 100.0 * k + 10.0 * j + i;
        const int ijk[3] = {i, j, k};
        for (int d = 0; d < 3; ++d) vel.values[3 * c + static_cast<size_t>(d)] = ijk[d] + 0.1 * d;
        for (int d = 0; d < 6; ++d) sig.values[6 * c + static_cast<size_t>(d)] = -1.0 * d;
      }
  rho.values[g.index(3, 2, 1)] = std::nan("");  // an empty bin
  return {rho, vel, sig};
}

FieldFileMeta sample_meta() {
  FieldFileMeta m;
  m.step = 4200;
  m.time = 42.0;
  m.created_by = "test_field_io";
  m.provenance_json = "{\"scene\":\"slab.toml\",\n \"seed\":7}";
  m.length_unit = "rc";
  m.attributes = {{"density_kernel", "warren"}, {"bin_note", "means over 100 samples"}};
  m.units = mesorock::sim::water_model().describe();
  return m;
}

// ---- small HDF5 readers for the checks ----

std::string read_string_attr(hid_t obj, const char* name) {
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  if (a < 0) return "<missing>";
  hid_t t = H5Aget_type(a);
  hid_t mem = H5Tcopy(H5T_C_S1);
  H5Tset_size(mem, H5T_VARIABLE);
  H5Tset_cset(mem, H5Tget_cset(t));
  char* s = nullptr;
  std::string out = "<unreadable>";
  if (H5Aread(a, mem, &s) >= 0 && s) {
    out = s;
    H5free_memory(s);
  }
  H5Tclose(mem);
  H5Tclose(t);
  H5Aclose(a);
  return out;
}

template <class T>
std::vector<T> read_numeric_attr(hid_t obj, const char* name, hid_t mem_type) {
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  if (a < 0) return {};
  hid_t sp = H5Aget_space(a);
  const hssize_t n = H5Sget_simple_extent_npoints(sp);
  std::vector<T> v(static_cast<size_t>(n));
  H5Aread(a, mem_type, v.data());
  H5Sclose(sp);
  H5Aclose(a);
  return v;
}

struct Dataset {
  std::vector<hsize_t> dims;
  std::vector<double> values;
  std::string unit;
  bool float64 = false;
};

Dataset read_dataset(hid_t f, const std::string& path) {
  Dataset d;
  hid_t ds = H5Dopen2(f, path.c_str(), H5P_DEFAULT);
  if (ds < 0) return d;
  hid_t sp = H5Dget_space(ds);
  d.dims.resize(static_cast<size_t>(H5Sget_simple_extent_ndims(sp)));
  H5Sget_simple_extent_dims(sp, d.dims.data(), nullptr);
  d.values.resize(static_cast<size_t>(H5Sget_simple_extent_npoints(sp)));
  H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, d.values.data());
  hid_t t = H5Dget_type(ds);
  d.float64 = H5Tequal(t, H5T_IEEE_F64LE) > 0;
  H5Tclose(t);
  d.unit = read_string_attr(ds, "unit");
  H5Sclose(sp);
  H5Dclose(ds);
  return d;
}

void expect_same(const std::vector<double>& got, const std::vector<double>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    if (std::isnan(want[i]))
      EXPECT_TRUE(std::isnan(got[i])) << i;
    else
      EXPECT_EQ(got[i], want[i]) << i;
  }
}

void expect_common_root(hid_t f, const FieldFileMeta& m) {
  EXPECT_EQ(read_string_attr(f, "mesorock_version"), mesorock::kVersion);
  EXPECT_EQ(read_string_attr(f, "git_commit"), mesorock::kGitCommit);
  EXPECT_EQ(read_string_attr(f, "created_by"), m.created_by);
  EXPECT_EQ(read_string_attr(f, "provenance"), m.provenance_json);
  EXPECT_EQ(read_string_attr(f, "length_unit"), m.length_unit);
  EXPECT_EQ(read_numeric_attr<std::uint64_t>(f, "step", H5T_NATIVE_UINT64),
            std::vector<std::uint64_t>{m.step});
  EXPECT_EQ(read_numeric_attr<double>(f, "time", H5T_NATIVE_DOUBLE), std::vector<double>{m.time});
  for (const auto& [k, v] : m.attributes) EXPECT_EQ(read_string_attr(f, k.c_str()), v) << k;
  for (const auto& u : m.units) {
    const Dataset d = read_dataset(f, "/units/" + u.name);
    EXPECT_TRUE(d.dims.empty()) << u.name;  // scalar
    EXPECT_EQ(d.values, std::vector<double>{u.value}) << u.name;
    EXPECT_EQ(d.unit, u.unit) << u.name;
  }
}

}  // namespace

TEST(FieldIo, StoredLayoutIsTheDocumentedOne) {
  TempDir dir;
  const fs::path h5 = dir / "fields.h5";
  const FieldGrid g = sample_grid();
  const auto fields = sample_fields(g);
  const FieldFileMeta meta = sample_meta();
  write_field_file(h5, g, fields, meta);
  EXPECT_EQ(files_in(dir.path()), 1u);  // no temporary left

  hid_t f = H5Fopen(h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  expect_common_root(f, meta);
  hid_t grp = H5Gopen2(f, "fields", H5P_DEFAULT);
  ASSERT_GE(grp, 0);
  EXPECT_EQ(read_numeric_attr<int>(grp, "cells", H5T_NATIVE_INT), (std::vector<int>{4, 3, 2}));
  EXPECT_EQ(read_numeric_attr<double>(grp, "origin", H5T_NATIVE_DOUBLE),
            (std::vector<double>{-1.0, 0.5, 2.0}));
  EXPECT_EQ(read_numeric_attr<double>(grp, "spacing", H5T_NATIVE_DOUBLE),
            (std::vector<double>{0.5, 1.0, 2.0}));
  EXPECT_EQ(read_string_attr(grp, "centering"), "cell");
  EXPECT_EQ(read_string_attr(grp, "axis_order"), "z y x");
  H5Gclose(grp);

  const Dataset rho = read_dataset(f, "/fields/density");
  EXPECT_EQ(rho.dims, (std::vector<hsize_t>{2, 3, 4}));  // (nz, ny, nx)
  EXPECT_TRUE(rho.float64);
  EXPECT_EQ(rho.unit, "1/rc^3");
  expect_same(rho.values, fields[0].values);
  // C order of (nz, ny, nx): element [k][j][i] is at (k*3 + j)*4 + i, value 100k + 10j + i.
  EXPECT_EQ(rho.values[(1 * 3 + 2) * 4 + 1], 121.0);
  EXPECT_EQ(rho.values[(0 * 3 + 1) * 4 + 3], 13.0);

  const Dataset vel = read_dataset(f, "/fields/velocity");
  EXPECT_EQ(vel.dims, (std::vector<hsize_t>{2, 3, 4, 3}));
  EXPECT_EQ(vel.unit, "rc/tau");
  expect_same(vel.values, fields[1].values);
  // [k=1][j=2][i=3][c]: (3, 2, 1) + 0.1 c.
  const size_t c = (1 * 3 + 2) * 4 + 3;
  EXPECT_EQ(vel.values[3 * c + 0], 3.0);
  EXPECT_EQ(vel.values[3 * c + 1], 2.1);
  EXPECT_EQ(vel.values[3 * c + 2], 1.2);
  const Dataset sig = read_dataset(f, "/fields/stress");
  EXPECT_EQ(sig.dims, (std::vector<hsize_t>{2, 3, 4, 6}));
  hid_t ds = H5Dopen2(f, "/fields/velocity", H5P_DEFAULT);
  EXPECT_EQ(read_numeric_attr<int>(ds, "components", H5T_NATIVE_INT), std::vector<int>{3});
  H5Dclose(ds);
  H5Fclose(f);
}

TEST(FieldIo, XdmfSidecarPassesTheCheckerAndUsesZyxOrder) {
  TempDir dir;
  fs::create_directories(dir / "data");
  fs::create_directories(dir / "view");
  const fs::path h5 = dir / "data" / "fields.h5";
  const fs::path xmf = dir / "view" / "fields.xmf";
  const FieldGrid g = sample_grid();
  const auto fields = sample_fields(g);
  write_field_file(h5, g, fields, sample_meta());
  write_field_xdmf(xmf, h5, g, fields, 42.0);
  EXPECT_EQ(xdmf_problems(xmf), std::vector<std::string>{});

  const std::string xml = read_file(xmf);
  // Node counts nz+1 ny+1 nx+1; origin and spacing also slowest (z) first.
  EXPECT_NE(xml.find("TopologyType=\"3DCoRectMesh\" Dimensions=\"3 4 5\""), std::string::npos)
      << xml;
  EXPECT_NE(xml.find("GeometryType=\"ORIGIN_DXDYDZ\""), std::string::npos);
  EXPECT_NE(xml.find("Format=\"XML\">2 0.5 -1</DataItem>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("Format=\"XML\">2 1 0.5</DataItem>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Cell\">"),
            std::string::npos);
  EXPECT_NE(xml.find("<Attribute Name=\"density\" AttributeType=\"Scalar\" Center=\"Cell\">"),
            std::string::npos);
  EXPECT_NE(xml.find("<Attribute Name=\"stress\" AttributeType=\"Tensor6\" Center=\"Cell\">"),
            std::string::npos);
  EXPECT_NE(xml.find(">../data/fields.h5:/fields/velocity<"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<Time Value=\"42\"/>"), std::string::npos);
}

TEST(FieldIo, SingleCellAndEmptyFieldListWork) {
  TempDir dir;
  FieldGrid g;  // 1 x 1 x 1
  write_field_file(dir / "one.h5", g, {{"phi", 1, "", {0.25}}}, {});
  write_field_xdmf(dir / "one.xmf", dir / "one.h5", g, {{"phi", 1, "", {}}});
  EXPECT_EQ(xdmf_problems(dir / "one.xmf"), std::vector<std::string>{});
  write_field_file(dir / "none.h5", g, {}, {});
  write_field_xdmf(dir / "none.xmf", dir / "none.h5", g, {});
  EXPECT_EQ(xdmf_problems(dir / "none.xmf"), std::vector<std::string>{});
}

TEST(FieldIo, InvalidInputsAreIoErrorsNamingTheFileAndWriteNothing) {
  TempDir dir;
  const fs::path h5 = dir / "f.h5";
  const std::string name = h5.string();
  const FieldGrid g = sample_grid();
  auto starts_with_file = [&](const std::string& msg) { return msg.rfind(name + ": ", 0) == 0; };

  auto fields = sample_fields(g);
  fields[1].values.pop_back();
  std::string msg = error_of([&] { write_field_file(h5, g, fields, {}); });
  EXPECT_TRUE(starts_with_file(msg)) << msg;
  EXPECT_NE(msg.find("/fields/velocity: cannot write: 71 values, expected 72"), std::string::npos)
      << msg;

  fields = sample_fields(g);
  fields[0].components = 2;
  msg = error_of([&] { write_field_file(h5, g, fields, {}); });
  EXPECT_NE(msg.find("2 components"), std::string::npos) << msg;

  for (const char* bad : {"", "a/b", "with space", ".", "x\"y"}) {
    fields = sample_fields(g);
    fields[0].name = bad;
    msg = error_of([&] { write_field_file(h5, g, fields, {}); });
    EXPECT_TRUE(starts_with_file(msg)) << bad << ": " << msg;
    EXPECT_NE(msg.find("not a valid name"), std::string::npos) << msg;
  }
  fields = sample_fields(g);
  fields[2].name = "density";
  EXPECT_NE(error_of([&] { write_field_file(h5, g, fields, {}); }).find("duplicate field"),
            std::string::npos);

  FieldGrid bad = g;
  bad.cells[1] = 0;
  msg = error_of([&] { write_field_file(h5, bad, {}, {}); });
  EXPECT_EQ(msg, name + ": cannot write: grid has 0 cells along y (need at least 1)");
  bad = g;
  bad.spacing[2] = 0;
  EXPECT_NE(error_of([&] { write_field_file(h5, bad, {}, {}); }).find("spacing along z"),
            std::string::npos);
  bad = g;
  bad.origin[0] = INFINITY;
  EXPECT_NE(error_of([&] { write_field_file(h5, bad, {}, {}); }).find("origin along x"),
            std::string::npos);

  FieldFileMeta meta;
  meta.attributes = {{"step", "7"}};
  EXPECT_NE(error_of([&] { write_field_file(h5, g, {}, meta); }).find("\"step\" is reserved"),
            std::string::npos);
  meta.attributes = {{"note", "a"}, {"note", "b"}};
  EXPECT_NE(error_of([&] { write_field_file(h5, g, {}, meta); }).find("duplicate attribute"),
            std::string::npos);

  // The XDMF writer validates too, naming the .xmf.
  fields = sample_fields(g);
  fields[0].components = 4;
  msg = error_of([&] { write_field_xdmf(dir / "f.xmf", h5, g, fields); });
  EXPECT_EQ(msg.rfind((dir / "f.xmf").string() + ": ", 0), 0u) << msg;

  EXPECT_EQ(files_in(dir.path()), 0u);
}

TEST(FieldIo, FailedWriteLeavesTargetUntouchedAndNoTemporary) {
  TempDir dir;
  const fs::path h5 = dir / "f.h5";
  const FieldGrid g = sample_grid();
  write_field_file(h5, g, sample_fields(g), sample_meta());
  const std::string before = read_file(h5);
  auto fields = sample_fields(g);
  fields[0].values.resize(3);
  EXPECT_NE(error_of([&] { write_field_file(h5, g, fields, sample_meta()); }),
            "<no IoError thrown>");
  EXPECT_EQ(read_file(h5), before);
  EXPECT_FALSE(fs::exists(mesorock::temporary_path_for(h5)));
  EXPECT_EQ(files_in(dir.path()), 1u);

  // A folder that does not exist: IoError naming the target, nothing created.
  for (const fs::path& nowhere : {dir / "no-such-dir" / "f.h5", dir / "no-such-dir" / "p.csv"}) {
    const std::string msg = error_of([&] {
      if (nowhere.extension() == ".h5")
        write_field_file(nowhere, g, sample_fields(g), sample_meta());
      else
        write_profile_csv(nowhere, 0, {0, 1}, {}, {});
    });
    EXPECT_EQ(msg.rfind(nowhere.string() + ": ", 0), 0u) << msg;
  }
  EXPECT_FALSE(fs::exists(dir / "no-such-dir"));
}

namespace {

const std::vector<double> kEdges{0.0, 1.0, 2.0, 4.0};

std::vector<ProfileField> sample_profile() {
  return {
      {"density", "1/rc^3", {6.5, 6.9, std::nan("")}, {0.01, 0.02, std::nan("")}},
      {"velocity_z", "rc/tau", {0.0, 0.125, -0.25}, {}},
  };
}

}  // namespace

TEST(ProfileIo, Hdf5LayoutUnitsAndXdmf) {
  TempDir dir;
  const fs::path h5 = dir / "profile.h5";
  const FieldFileMeta meta = sample_meta();
  write_profile_file(h5, 1, kEdges, sample_profile(), meta);
  hid_t f = H5Fopen(h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  expect_common_root(f, meta);
  hid_t grp = H5Gopen2(f, "profile", H5P_DEFAULT);
  EXPECT_EQ(read_numeric_attr<int>(grp, "axis", H5T_NATIVE_INT), std::vector<int>{1});
  EXPECT_EQ(read_string_attr(grp, "axis_name"), "y");
  H5Gclose(grp);
  const Dataset edges = read_dataset(f, "/profile/bin_edges");
  EXPECT_EQ(edges.values, kEdges);
  EXPECT_EQ(edges.unit, "rc");
  const Dataset centre = read_dataset(f, "/profile/bin_centre");
  EXPECT_EQ(centre.dims, std::vector<hsize_t>{3});
  EXPECT_EQ(centre.values, (std::vector<double>{0.5, 1.5, 3.0}));
  const Dataset rho = read_dataset(f, "/profile/density");
  expect_same(rho.values, sample_profile()[0].mean);
  EXPECT_EQ(rho.unit, "1/rc^3");
  const Dataset rho_err = read_dataset(f, "/profile/density_error");
  expect_same(rho_err.values, sample_profile()[0].error);
  EXPECT_EQ(rho_err.unit, "1/rc^3");
  const Dataset vz = read_dataset(f, "/profile/velocity_z");
  EXPECT_EQ(vz.values, sample_profile()[1].mean);
  EXPECT_EQ(H5Lexists(f, "/profile/velocity_z_error", H5P_DEFAULT), 0);  // no error given
  H5Fclose(f);

  write_profile_xdmf(dir / "profile.xmf", h5, 1, kEdges, sample_profile(), 42.0);
  EXPECT_EQ(xdmf_problems(dir / "profile.xmf"), std::vector<std::string>{});
  const std::string xml = read_file(dir / "profile.xmf");
  // Axis y: node counts (z y x) = 2 4 2, and the second coordinate array is the bin edges.
  EXPECT_NE(xml.find("TopologyType=\"3DRectMesh\" Dimensions=\"2 4 2\""), std::string::npos) << xml;
  for (int axis = 0; axis < 3; ++axis) {
    write_profile_file(h5, axis, kEdges, sample_profile(), {});
    write_profile_xdmf(dir / "profile.xmf", h5, axis, kEdges, sample_profile());
    EXPECT_EQ(xdmf_problems(dir / "profile.xmf"), std::vector<std::string>{}) << axis;
  }
}

TEST(ProfileIo, CsvTwinHasCommentedHeaderAndSameNumbers) {
  TempDir dir;
  const fs::path csv = dir / "profile.csv";
  FieldFileMeta meta = sample_meta();
  write_profile_csv(csv, 2, kEdges, sample_profile(), meta);
  std::istringstream in(read_file(csv));
  std::vector<std::string> comments, rows;
  for (std::string line; std::getline(in, line);)
    (line.rfind("#", 0) == 0 ? comments : rows).push_back(line);
  ASSERT_FALSE(comments.empty());
  // The first line states how many comment lines precede the header row.
  const std::string count = std::to_string(comments.size());
  EXPECT_NE(comments[0].find("; " + count + " comment lines precede the header row"),
            std::string::npos)
      << comments[0];
  EXPECT_NE(comments[0].find("skip_header=" + count + ")"), std::string::npos);
  const std::string all = read_file(csv);
  // Comments come first, then the header, then the data.
  EXPECT_EQ(all.find("\nbin_lo,"), all.find("\n# column velocity_z: rc/tau\n") + 28) << all;
  for (const std::string& want :
       {"# mesorock_version: " + std::string(mesorock::kVersion),
        "# git_commit: " + std::string(mesorock::kGitCommit),
        std::string("# created_by: test_field_io"), std::string("# step: 4200"),
        std::string("# time: 42"), std::string("# axis: z"), std::string("# length_unit: rc"),
        // The provenance's newline becomes a space: one comment line.
        std::string("# provenance: {\"scene\":\"slab.toml\",  \"seed\":7}"),
        std::string("# attribute density_kernel: warren"), std::string("# unit time: 1 reduced = "),
        std::string("# column density: 1/rc^3"), std::string("# column density_error: 1/rc^3"),
        std::string("# column velocity_z: rc/tau"), std::string("# column bin_lo: rc")})
    EXPECT_NE(all.find(want), std::string::npos) << want << "\n" << all;
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0], "bin_lo,bin_hi,bin_centre,density,density_error,velocity_z");
  EXPECT_EQ(rows[1], "0,1,0.5,6.5,0.01,0");
  EXPECT_EQ(rows[2], "1,2,1.5,6.9,0.02,0.125");
  EXPECT_EQ(rows[3], "2,4,3,nan,nan,-0.25");
}

TEST(ProfileIo, InvalidInputsAreIoErrorsNamingTheFile) {
  TempDir dir;
  for (const fs::path& out : {dir / "p.h5", dir / "p.csv", dir / "p.xmf"}) {
    SCOPED_TRACE(out.string());
    auto write = [&](int axis, const std::vector<double>& edges,
                     const std::vector<ProfileField>& fields) {
      return error_of([&] {
        if (out.extension() == ".h5")
          write_profile_file(out, axis, edges, fields, {});
        else if (out.extension() == ".csv")
          write_profile_csv(out, axis, edges, fields, {});
        else
          write_profile_xdmf(out, dir / "p.h5", axis, edges, fields);
      });
    };
    const std::string prefix = out.string() + ": ";
    EXPECT_EQ(write(3, kEdges, {}), prefix + "cannot write: profile axis 3 is not 0, 1 or 2");
    EXPECT_EQ(write(0, {1.0}, {}), prefix + "cannot write: 1 bin edges (need at least 2)");
    EXPECT_EQ(write(0, {0.0, 2.0, 2.0}, {}),
              prefix + "cannot write: bin edges must increase strictly (edge 2 = 2 <= 2)");
    EXPECT_EQ(write(0, {0.0, NAN}, {}), prefix + "cannot write: bin edge 1 is not finite");
    auto fields = sample_profile();
    fields[1].mean.push_back(1);
    EXPECT_EQ(
        write(0, kEdges, fields),
        prefix + "/profile/velocity_z: cannot write: 4 mean values, expected 3 (one per bin)");
    fields = sample_profile();
    fields[0].error.pop_back();
    EXPECT_NE(write(0, kEdges, fields).find("/profile/density_error: cannot write: 2 error"),
              std::string::npos);
    fields = sample_profile();
    fields[1].name = "density_error";  // collides with density's error dataset
    EXPECT_NE(write(0, kEdges, fields).find("duplicate or reserved profile name"),
              std::string::npos);
    fields[1].name = "bin_centre";
    EXPECT_NE(write(0, kEdges, fields).find("duplicate or reserved profile name \"bin_centre\""),
              std::string::npos);
  }
  EXPECT_EQ(files_in(dir.path()), 0u);
}
