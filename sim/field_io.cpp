#include "sim/field_io.h"

#include <hdf5.h>

#include <cmath>
#include <set>
#include <sstream>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/hdf5_util.h"

namespace mesorock::sim {

namespace fs = std::filesystem;
using namespace hdf5_util;

namespace {

constexpr const char* kAxisNames[3] = {"x", "y", "z"};

// Root attributes every file of this module carries; FieldFileMeta::attributes may not reuse them.
const std::set<std::string>& reserved_root_attributes() {
  static const std::set<std::string> names{
      "mesorock_version", "git_commit", "created_by", "provenance", "length_unit", "step", "time"};
  return names;
}

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '+' || c == '-';
    if (!ok) return false;
  }
  // "." and ".." are not usable as HDF5 link names.
  return s != "." && s != "..";
}

void require_name(const std::string& name, const std::string& what, const std::string& file) {
  if (!valid_name(name))
    fail(file, "",
         "cannot write: " + what + " \"" + name +
             "\" is not a valid name (1 to 64 characters from A-Z a-z 0-9 _ . + -)");
}

void validate_meta(const FieldFileMeta& meta, const std::string& file) {
  if (!std::isfinite(meta.time)) fail(file, "", "cannot write: time must be finite");
  std::set<std::string> seen;
  for (const auto& [key, value] : meta.attributes) {
    require_name(key, "attribute", file);
    if (reserved_root_attributes().count(key))
      fail(file, "", "cannot write: attribute \"" + key + "\" is reserved");
    if (!seen.insert(key).second)
      fail(file, "", "cannot write: duplicate attribute \"" + key + "\"");
  }
  seen.clear();
  for (const auto& u : meta.units) {
    require_name(u.name, "unit entry", file);
    if (!seen.insert(u.name).second)
      fail(file, "", "cannot write: duplicate unit entry \"" + u.name + "\"");
  }
}

void validate_grid(const FieldGrid& grid, const std::string& file) {
  for (int a = 0; a < 3; ++a) {
    const std::string axis = kAxisNames[a];
    if (grid.cells[a] < 1)
      fail(file, "",
           "cannot write: grid has " + std::to_string(grid.cells[a]) + " cells along " + axis +
               " (need at least 1)");
    if (!std::isfinite(grid.origin[a]))
      fail(file, "", "cannot write: grid origin along " + axis + " is not finite");
    if (!std::isfinite(grid.spacing[a]) || !(grid.spacing[a] > 0))
      fail(file, "",
           "cannot write: grid spacing along " + axis + " must be finite and positive (got " +
               shortest_text(grid.spacing[a]) + ")");
  }
}

const char* attribute_type(int components) {
  switch (components) {
    case 1:
      return "Scalar";
    case 3:
      return "Vector";
    case 6:
      return "Tensor6";
    case 9:
      return "Tensor";
    default:
      return nullptr;
  }
}

// check_values: also require values.size() == cell_count * components (the XDMF writer needs only
// names and components).
void validate_fields(const FieldGrid& grid, const std::vector<FieldData>& fields,
                     const std::string& file, bool check_values) {
  std::set<std::string> seen;
  for (const auto& f : fields) {
    require_name(f.name, "field", file);
    if (!seen.insert(f.name).second)
      fail(file, "", "cannot write: duplicate field \"" + f.name + "\"");
    if (!attribute_type(f.components))
      fail(file, "/fields/" + f.name,
           "cannot write: " + std::to_string(f.components) +
               " components (supported: 1 scalar, 3 vector, 6 symmetric tensor, 9 tensor)");
    if (check_values) {
      const std::size_t want = grid.cell_count() * static_cast<std::size_t>(f.components);
      if (f.values.size() != want)
        fail(file, "/fields/" + f.name,
             "cannot write: " + std::to_string(f.values.size()) + " values, expected " +
                 std::to_string(want) + " (" + std::to_string(grid.cells[0]) + " x " +
                 std::to_string(grid.cells[1]) + " x " + std::to_string(grid.cells[2]) +
                 " cells x " + std::to_string(f.components) + " components)");
    }
  }
}

void validate_profile(int axis, const std::vector<double>& edges,
                      const std::vector<ProfileField>& fields, const std::string& file) {
  if (axis < 0 || axis > 2)
    fail(file, "", "cannot write: profile axis " + std::to_string(axis) + " is not 0, 1 or 2");
  if (edges.size() < 2)
    fail(file, "",
         "cannot write: " + std::to_string(edges.size()) + " bin edges (need at least 2)");
  for (std::size_t b = 0; b < edges.size(); ++b) {
    if (!std::isfinite(edges[b]))
      fail(file, "", "cannot write: bin edge " + std::to_string(b) + " is not finite");
    if (b > 0 && !(edges[b] > edges[b - 1]))
      fail(file, "",
           "cannot write: bin edges must increase strictly (edge " + std::to_string(b) + " = " +
               shortest_text(edges[b]) + " <= " + shortest_text(edges[b - 1]) + ")");
  }
  const std::size_t nbins = edges.size() - 1;
  std::set<std::string> seen{"bin_edges", "bin_centre", "bin_lo", "bin_hi"};
  for (const auto& f : fields) {
    require_name(f.name, "profile field", file);
    if (!seen.insert(f.name).second)
      fail(file, "", "cannot write: duplicate or reserved profile name \"" + f.name + "\"");
    if (f.mean.size() != nbins)
      fail(file, "/profile/" + f.name,
           "cannot write: " + std::to_string(f.mean.size()) + " mean values, expected " +
               std::to_string(nbins) + " (one per bin)");
    if (!f.error.empty()) {
      if (!seen.insert(f.name + "_error").second)
        fail(file, "", "cannot write: duplicate or reserved profile name \"" + f.name + "_error\"");
      if (f.error.size() != nbins)
        fail(file, "/profile/" + f.name + "_error",
             "cannot write: " + std::to_string(f.error.size()) + " error values, expected " +
                 std::to_string(nbins) + " (one per bin, or none)");
    }
  }
}

// Root attributes and the /units group shared by field and profile files.
void write_common(hid_t f, const FieldFileMeta& meta, const std::string& file) {
  write_string_attribute(f, "mesorock_version", "/@mesorock_version", kVersion, file);
  write_string_attribute(f, "git_commit", "/@git_commit", kGitCommit, file);
  write_string_attribute(f, "created_by", "/@created_by", meta.created_by, file);
  write_string_attribute(f, "provenance", "/@provenance", meta.provenance_json, file);
  write_string_attribute(f, "length_unit", "/@length_unit", meta.length_unit, file);
  write_attribute(f, "step", "/@step", H5T_STD_U64LE, H5T_NATIVE_UINT64, {}, &meta.step, file);
  write_attribute(f, "time", "/@time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {}, &meta.time, file);
  for (const auto& [key, value] : meta.attributes)
    write_string_attribute(f, key.c_str(), "/@" + key, value, file);
  if (!meta.units.empty()) {
    Handle g = create_group(f, "units", "/units", file);
    for (const auto& u : meta.units) {
      const std::string where = "/units/" + u.name;
      Handle ds = create_dataset(g.get(), u.name.c_str(), where, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                                 {}, &u.value, file);
      write_string_attribute(ds.get(), "unit", where + "@unit", u.unit, file);
      if (!ds.close()) fail(file, where, "write failed");
    }
  }
}

// Writes `values` as dataset `name` in `g` with a string attribute unit.
void write_with_unit(hid_t g, const std::string& name, const std::string& where,
                     const std::vector<hsize_t>& dims, const double* values,
                     const std::string& unit, const std::string& file) {
  Handle ds =
      create_dataset(g, name.c_str(), where, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dims, values, file);
  write_string_attribute(ds.get(), "unit", where + "@unit", unit, file);
  if (!ds.close()) fail(file, where, "write failed");
}

std::string one_line(const std::string& s) {
  std::string out = s;
  for (char& c : out)
    if (c == '\n' || c == '\r') c = ' ';
  return out;
}

std::string csv_number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return shortest_text(v);
}

}  // namespace

void write_field_file(const fs::path& h5, const FieldGrid& grid,
                      const std::vector<FieldData>& fields, const FieldFileMeta& meta) {
  silence_hdf5_errors();
  const std::string file = h5.string();
  validate_grid(grid, file);
  validate_fields(grid, fields, file, true);
  validate_meta(meta, file);

  write_atomically(h5, [&](const fs::path& tmp) {
    Handle f = create_file(tmp, file);
    {
      Handle g = create_group(f.get(), "fields", "/fields", file);
      write_attribute(g.get(), "cells", "/fields@cells", H5T_STD_I32LE, H5T_NATIVE_INT, {3},
                      grid.cells.data(), file);
      write_attribute(g.get(), "origin", "/fields@origin", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3},
                      grid.origin.data(), file);
      write_attribute(g.get(), "spacing", "/fields@spacing", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3},
                      grid.spacing.data(), file);
      write_string_attribute(g.get(), "centering", "/fields@centering", "cell", file);
      write_string_attribute(g.get(), "axis_order", "/fields@axis_order", "z y x", file);
      for (const auto& fd : fields) {
        const std::string where = "/fields/" + fd.name;
        std::vector<hsize_t> dims{static_cast<hsize_t>(grid.cells[2]),
                                  static_cast<hsize_t>(grid.cells[1]),
                                  static_cast<hsize_t>(grid.cells[0])};
        if (fd.components > 1) dims.push_back(static_cast<hsize_t>(fd.components));
        Handle ds = create_dataset(g.get(), fd.name.c_str(), where, H5T_IEEE_F64LE,
                                   H5T_NATIVE_DOUBLE, dims, fd.values.data(), file);
        write_string_attribute(ds.get(), "unit", where + "@unit", fd.unit, file);
        const std::int32_t comps = fd.components;
        write_attribute(ds.get(), "components", where + "@components", H5T_STD_I32LE,
                        H5T_NATIVE_INT32, {}, &comps, file);
        if (!ds.close()) fail(file, where, "write failed");
      }
    }
    write_common(f.get(), meta, file);
    if (!f.close()) fail(file, "", "cannot close file (write failed)");
  });
}

void write_field_xdmf(const fs::path& xmf, const fs::path& h5, const FieldGrid& grid,
                      const std::vector<FieldData>& fields, std::optional<double> time) {
  const std::string file = xmf.string();
  validate_grid(grid, file);
  validate_fields(grid, fields, file, false);
  if (time && !std::isfinite(*time)) fail(file, "", "cannot write: time must be finite");

  const std::string data = xml_escape(xdmf_data_path(xmf, h5));
  const int nx = grid.cells[0], ny = grid.cells[1], nz = grid.cells[2];
  const std::string cell_dims =
      std::to_string(nz) + " " + std::to_string(ny) + " " + std::to_string(nx);

  // XDMF lists structured dimensions slowest first (Z Y X), and ParaView's XDMF readers take the
  // ORIGIN_DXDYDZ origin and spacing in that same Z Y X order (they reverse all three arrays).
  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n"
    << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
    << "  <Domain>\n"
    << "    <Grid Name=\"fields\" GridType=\"Uniform\">\n";
  if (time) x << "      <Time Value=\"" << shortest_text(*time) << "\"/>\n";
  x << "      <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << nz + 1 << " " << ny + 1
    << " " << nx + 1 << "\"/>\n"
    << "      <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
    << "        <DataItem Name=\"Origin\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" "
       "Format=\"XML\">"
    << shortest_text(grid.origin[2]) << " " << shortest_text(grid.origin[1]) << " "
    << shortest_text(grid.origin[0]) << "</DataItem>\n"
    << "        <DataItem Name=\"Spacing\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" "
       "Format=\"XML\">"
    << shortest_text(grid.spacing[2]) << " " << shortest_text(grid.spacing[1]) << " "
    << shortest_text(grid.spacing[0]) << "</DataItem>\n"
    << "      </Geometry>\n";
  for (const auto& fd : fields) {
    std::string dims = cell_dims;
    if (fd.components > 1) dims += " " + std::to_string(fd.components);
    x << "      <Attribute Name=\"" << fd.name << "\" AttributeType=\""
      << attribute_type(fd.components) << "\" Center=\"Cell\">\n"
      << "        <DataItem Dimensions=\"" << dims
      << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << data << ":/fields/" << fd.name
      << "</DataItem>\n"
      << "      </Attribute>\n";
  }
  x << "    </Grid>\n"
    << "  </Domain>\n"
    << "</Xdmf>\n";
  write_text_atomically(xmf, x.str());
}

void write_profile_file(const fs::path& h5, int axis, const std::vector<double>& bin_edges,
                        const std::vector<ProfileField>& fields, const FieldFileMeta& meta) {
  silence_hdf5_errors();
  const std::string file = h5.string();
  validate_profile(axis, bin_edges, fields, file);
  validate_meta(meta, file);
  const std::size_t nbins = bin_edges.size() - 1;
  std::vector<double> centre(nbins);
  for (std::size_t b = 0; b < nbins; ++b) centre[b] = 0.5 * (bin_edges[b] + bin_edges[b + 1]);

  write_atomically(h5, [&](const fs::path& tmp) {
    Handle f = create_file(tmp, file);
    {
      Handle g = create_group(f.get(), "profile", "/profile", file);
      const std::int32_t ax = axis;
      write_attribute(g.get(), "axis", "/profile@axis", H5T_STD_I32LE, H5T_NATIVE_INT32, {}, &ax,
                      file);
      write_string_attribute(g.get(), "axis_name", "/profile@axis_name", kAxisNames[axis], file);
      const hsize_t hn = static_cast<hsize_t>(nbins);
      write_with_unit(g.get(), "bin_edges", "/profile/bin_edges", {hn + 1}, bin_edges.data(),
                      meta.length_unit, file);
      write_with_unit(g.get(), "bin_centre", "/profile/bin_centre", {hn}, centre.data(),
                      meta.length_unit, file);
      for (const auto& pf : fields) {
        write_with_unit(g.get(), pf.name, "/profile/" + pf.name, {hn}, pf.mean.data(), pf.unit,
                        file);
        if (!pf.error.empty())
          write_with_unit(g.get(), pf.name + "_error", "/profile/" + pf.name + "_error", {hn},
                          pf.error.data(), pf.unit, file);
      }
    }
    write_common(f.get(), meta, file);
    if (!f.close()) fail(file, "", "cannot close file (write failed)");
  });
}

void write_profile_xdmf(const fs::path& xmf, const fs::path& h5, int axis,
                        const std::vector<double>& bin_edges,
                        const std::vector<ProfileField>& fields, std::optional<double> time) {
  const std::string file = xmf.string();
  validate_profile(axis, bin_edges, fields, file);
  if (time && !std::isfinite(*time)) fail(file, "", "cannot write: time must be finite");
  const std::string data = xml_escape(xdmf_data_path(xmf, h5));
  const std::string nb = std::to_string(bin_edges.size() - 1);
  const std::string ne = std::to_string(bin_edges.size());
  // Node counts, slowest (z) first: bin edges along `axis`, 2 along the others.
  std::string nodes[3] = {"2", "2", "2"};
  nodes[2 - axis] = ne;

  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n"
    << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
    << "  <Domain>\n"
    << "    <Grid Name=\"profile\" GridType=\"Uniform\">\n";
  if (time) x << "      <Time Value=\"" << shortest_text(*time) << "\"/>\n";
  x << "      <Topology TopologyType=\"3DRectMesh\" Dimensions=\"" << nodes[0] << " " << nodes[1]
    << " " << nodes[2] << "\"/>\n"
    << "      <Geometry GeometryType=\"VXVYVZ\">\n";
  for (int a = 0; a < 3; ++a) {  // x, y, z coordinates in this order
    if (a == axis)
      x << "        <DataItem Dimensions=\"" << ne
        << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << data
        << ":/profile/bin_edges</DataItem>\n";
    else
      x << "        <DataItem Dimensions=\"2\" NumberType=\"Float\" Precision=\"8\" "
           "Format=\"XML\">0 1</DataItem>\n";
  }
  x << "      </Geometry>\n";
  auto attribute = [&](const std::string& name) {
    x << "      <Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
      << "        <DataItem Dimensions=\"" << nb
      << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << data << ":/profile/" << name
      << "</DataItem>\n"
      << "      </Attribute>\n";
  };
  for (const auto& pf : fields) {
    attribute(pf.name);
    if (!pf.error.empty()) attribute(pf.name + "_error");
  }
  x << "    </Grid>\n"
    << "  </Domain>\n"
    << "</Xdmf>\n";
  write_text_atomically(xmf, x.str());
}

void write_profile_csv(const fs::path& csv, int axis, const std::vector<double>& bin_edges,
                       const std::vector<ProfileField>& fields, const FieldFileMeta& meta) {
  const std::string file = csv.string();
  validate_profile(axis, bin_edges, fields, file);
  validate_meta(meta, file);
  const std::size_t nbins = bin_edges.size() - 1;

  std::vector<std::string> comments;
  comments.push_back("mesorock_version: " + std::string(kVersion));
  comments.push_back("git_commit: " + std::string(kGitCommit));
  comments.push_back("created_by: " + one_line(meta.created_by));
  comments.push_back("step: " + std::to_string(meta.step));
  comments.push_back("time: " + shortest_text(meta.time));
  comments.push_back("axis: " + std::string(kAxisNames[axis]));
  comments.push_back("length_unit: " + one_line(meta.length_unit));
  comments.push_back("provenance: " + one_line(meta.provenance_json));
  for (const auto& [key, value] : meta.attributes)
    comments.push_back("attribute " + key + ": " + one_line(value));
  for (const auto& u : meta.units)
    comments.push_back("unit " + u.name + ": 1 reduced = " + shortest_text(u.value) + " " +
                       one_line(u.unit));
  const std::string lu = one_line(meta.length_unit);
  comments.push_back("column bin_lo: " + lu);
  comments.push_back("column bin_hi: " + lu);
  comments.push_back("column bin_centre: " + lu);
  for (const auto& pf : fields) {
    comments.push_back("column " + pf.name + ": " + one_line(pf.unit));
    if (!pf.error.empty())
      comments.push_back("column " + pf.name + "_error: " + one_line(pf.unit) + " (error of " +
                         pf.name + ")");
  }

  std::ostringstream out;
  // The first line says how many comment lines precede the header row (itself included), for
  // readers that cannot skip comments before a header (numpy.genfromtxt with names=True).
  const std::size_t n_comments = comments.size() + 1;
  out << "# mesorock profile; " << n_comments
      << " comment lines precede the header row: pandas.read_csv(path, comment='#') or "
         "numpy.genfromtxt(path, delimiter=',', names=True, skip_header="
      << n_comments << ")\n";
  for (const auto& c : comments) out << "# " << c << "\n";
  out << "bin_lo,bin_hi,bin_centre";
  for (const auto& pf : fields) {
    out << "," << pf.name;
    if (!pf.error.empty()) out << "," << pf.name << "_error";
  }
  out << "\n";
  for (std::size_t b = 0; b < nbins; ++b) {
    out << csv_number(bin_edges[b]) << "," << csv_number(bin_edges[b + 1]) << ","
        << csv_number(0.5 * (bin_edges[b] + bin_edges[b + 1]));
    for (const auto& pf : fields) {
      out << "," << csv_number(pf.mean[b]);
      if (!pf.error.empty()) out << "," << csv_number(pf.error[b]);
    }
    out << "\n";
  }
  write_text_atomically(csv, out.str());
}

}  // namespace mesorock::sim
