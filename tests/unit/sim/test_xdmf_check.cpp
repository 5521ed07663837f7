// The XDMF checker (tests/support/xdmf_check.h) itself: it passes what our writers produce
// (particles, fields, profiles) and finds what is wrong in deliberately broken sidecars.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sim/field_io.h"
#include "sim/particle_io.h"
#include "support/test_support.h"
#include "support/xdmf_check.h"

namespace fs = std::filesystem;
using mesorock::sim::FieldData;
using mesorock::sim::FieldGrid;
using mesorock::sim::ParticleFileMeta;
using mesorock::sim::ParticleSet;
using mesorock::test::read_file;
using mesorock::test::TempDir;
using mesorock::test::xdmf_problems;

namespace {

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += x + "\n";
  return s;
}

bool any_contains(const std::vector<std::string>& v, const std::string& part) {
  for (const auto& s : v)
    if (s.find(part) != std::string::npos) return true;
  return false;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

// Replaces the first occurrence of `from` (which must exist) in the file.
void edit(const fs::path& p, const std::string& from, const std::string& to) {
  std::string s = read_file(p);
  const size_t at = s.find(from);
  ASSERT_NE(at, std::string::npos) << from << "\n" << s;
  s.replace(at, from.size(), to);
  write_text(p, s);
}

ParticleSet particles(size_t n) {
  ParticleSet p;
  for (size_t i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    p.add(0.1 * s, 0.2 * s, 0.3 * s, 1, 0, 0, static_cast<std::int32_t>(i % 2),
          static_cast<std::int64_t>(i));
  }
  return p;
}

ParticleFileMeta particle_meta() {
  ParticleFileMeta m;
  m.type_names = {"fluid", "wall"};
  m.box.lo = {0, 0, 0};
  m.box.hi = {10, 10, 10};
  return m;
}

// A particle file and sidecar in `dir`; returns the .xmf path.
fs::path particle_pair(const TempDir& dir, size_t n = 25) {
  mesorock::sim::write_particle_file(dir / "p.h5", particles(n), particle_meta());
  mesorock::sim::write_particle_xdmf(dir / "p.xmf", dir / "p.h5", n, 1.5);
  return dir / "p.xmf";
}

// A 5 x 4 x 3 field file (scalar + vector) and sidecar; returns the .xmf path.
fs::path field_pair(const TempDir& dir) {
  FieldGrid g;
  g.cells = {5, 4, 3};
  g.spacing = {0.5, 0.5, 0.5};
  std::vector<FieldData> f{{"density", 1, "1/rc^3", std::vector<double>(g.cell_count(), 6.5)},
                           {"velocity", 3, "rc/tau", std::vector<double>(3 * g.cell_count(), 0)}};
  mesorock::sim::write_field_file(dir / "f.h5", g, f, {});
  mesorock::sim::write_field_xdmf(dir / "f.xmf", dir / "f.h5", g, f);
  return dir / "f.xmf";
}

}  // namespace

TEST(XdmfCheck, ParticleSidecarsAreConsistent) {
  TempDir dir;
  EXPECT_EQ(xdmf_problems(particle_pair(dir)), std::vector<std::string>{});
  TempDir empty;
  EXPECT_EQ(xdmf_problems(particle_pair(empty, 0)), std::vector<std::string>{});
}

TEST(XdmfCheck, FieldAndProfileSidecarsAreConsistent) {
  TempDir dir;
  EXPECT_EQ(xdmf_problems(field_pair(dir)), std::vector<std::string>{});
  const std::vector<double> edges{-2, -1, 0, 1.5};
  const std::vector<mesorock::sim::ProfileField> prof{{"density", "1/rc^3", {1, 2, 3}, {0, 0, 0}}};
  mesorock::sim::write_profile_file(dir / "pr.h5", 0, edges, prof, {});
  mesorock::sim::write_profile_xdmf(dir / "pr.xmf", dir / "pr.h5", 0, edges, prof);
  EXPECT_EQ(xdmf_problems(dir / "pr.xmf"), std::vector<std::string>{});
}

TEST(XdmfCheck, WrongDatasetNameIsFound) {
  TempDir dir;
  const fs::path xmf = field_pair(dir);
  edit(xmf, ":/fields/velocity<", ":/fields/velocty<");
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "dataset /fields/velocty does not exist")) << joined(p);
  EXPECT_EQ(p.size(), 1u) << joined(p);
  EXPECT_EQ(p[0].rfind(xmf.string() + ": ", 0), 0u) << p[0];
}

TEST(XdmfCheck, WrongAttributeDimensionsAreFound) {
  TempDir dir;
  const fs::path xmf = field_pair(dir);
  edit(xmf, "Dimensions=\"3 4 5\" NumberType", "Dimensions=\"3 4 6\" NumberType");
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "dataset shape [3 4 5] differs from Dimensions [3 4 6]"))
      << joined(p);
}

TEST(XdmfCheck, TopologyThatDoesNotFitTheAttributesIsFound) {
  TempDir dir;
  const fs::path xmf = field_pair(dir);
  // One node more along x: the cell attributes (3 x 4 x 5) no longer fit 3 x 4 x 6 cells.
  edit(xmf, "Dimensions=\"4 5 6\"", "Dimensions=\"4 5 7\"");
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "Attribute \"density\": Scalar on Center=\"Cell\" needs 72 x 1"))
      << joined(p);
  EXPECT_TRUE(any_contains(p, "Attribute \"velocity\"")) << joined(p);
}

TEST(XdmfCheck, NodeCentredCellDataIsFound) {
  TempDir dir;
  const fs::path xmf = field_pair(dir);
  edit(xmf, "AttributeType=\"Scalar\" Center=\"Cell\"", "AttributeType=\"Scalar\" Center=\"Node\"");
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "needs 120 x 1 values")) << joined(p);  // 4 x 5 x 6 nodes
}

TEST(XdmfCheck, WrongNumberTypeOrPrecisionIsFound) {
  TempDir dir;
  const fs::path xmf = particle_pair(dir);
  edit(xmf, "NumberType=\"Int\" Precision=\"8\"", "NumberType=\"Int\" Precision=\"4\"");    // id
  edit(xmf, "NumberType=\"Int\" Precision=\"4\"", "NumberType=\"Float\" Precision=\"4\"");  // type
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p,
                           "dataset type is 4-byte signed integer, the DataItem says "
                           "NumberType=\"Float\" Precision=\"4\""))
      << joined(p);
  EXPECT_TRUE(any_contains(p,
                           "dataset type is 8-byte signed integer, the DataItem says "
                           "NumberType=\"Int\" Precision=\"4\""))
      << joined(p);
}

TEST(XdmfCheck, ParticleCountMismatchIsFound) {
  TempDir dir;
  const fs::path xmf = particle_pair(dir, 25);
  edit(xmf, "NumberOfElements=\"25\"", "NumberOfElements=\"24\"");
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "geometry has 25 nodes, the topology 24")) << joined(p);
}

TEST(XdmfCheck, MissingDataFileIsFound) {
  TempDir dir;
  const fs::path xmf = particle_pair(dir);
  fs::remove(dir / "p.h5");
  const auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "p.h5 does not exist")) << joined(p);
  EXPECT_EQ(p.size(), 1u) << joined(p);  // reported once, not once per DataItem
}

TEST(XdmfCheck, MalformedXmlAndWrongXmlDataAreFound) {
  TempDir dir;
  const fs::path xmf = field_pair(dir);
  const std::string good = read_file(xmf);
  edit(xmf, "</Geometry>", "");
  auto p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "not well-formed XML")) << joined(p);

  write_text(xmf, good);
  edit(xmf, "Format=\"XML\">0 0 0<", "Format=\"XML\">0 0<");  // origin with 2 of 3 values
  p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "XML data holds 2 values, Dimensions [3] need 3")) << joined(p);

  write_text(xmf, good);
  edit(xmf, "ORIGIN_DXDYDZ", "XYZ");
  p = xdmf_problems(xmf);
  EXPECT_TRUE(any_contains(p, "needs ORIGIN_DXDYDZ")) << joined(p);

  EXPECT_FALSE(xdmf_problems(dir / "missing.xmf").empty());
}

TEST(XdmfCheck, HandWrittenStructuredGridsPass) {
  // XML-only data on the less common grid kinds, with comments and CDATA.
  TempDir dir;
  write_text(dir / "s.xmf", R"(<?xml version="1.0" ?>
<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" [
  <!ENTITY n "3">
]>
<Xdmf Version="3.0">
  <!-- a temporal collection of two rectilinear grids -->
  <Domain>
    <Grid Name="series" GridType="Collection" CollectionType="Temporal">
      <Grid Name="a" GridType="Uniform">
        <Time Value="0"/>
        <Topology TopologyType="2DRectMesh" Dimensions="2 3"/>
        <Geometry GeometryType="VXVY">
          <DataItem Dimensions="3" Format="XML">0 1 2</DataItem>
          <DataItem Dimensions="2" Format="XML"><![CDATA[0 5]]></DataItem>
        </Geometry>
        <Attribute Name="c" Center="Cell">
          <DataItem Dimensions="1 2" NumberType="Int" Precision="4" Format="XML">7 8</DataItem>
        </Attribute>
        <Attribute Name="v" AttributeType="Vector" Center="Node">
          <DataItem Dimensions="2 3 3" Format="XML">
            0 0 0  0 0 0  0 0 0  0 0 0  0 0 0  0 0 0
          </DataItem>
        </Attribute>
      </Grid>
      <Grid Name="b" GridType="Uniform">
        <Time Value="1e-3"/>
        <Topology TopologyType="3DSMesh" Dimensions="1 1 2"/>
        <Geometry GeometryType="XYZ">
          <DataItem Dimensions="2 3" Format="XML">0 0 0 1 0 0</DataItem>
        </Geometry>
      </Grid>
    </Grid>
  </Domain>
</Xdmf>
)");
  EXPECT_EQ(xdmf_problems(dir / "s.xmf"), std::vector<std::string>{});
}
