#pragma once
// A minimal XDMF checker for tests: is an .xmf sidecar consistent with the HDF5 data it names?
//
//   std::vector<std::string> problems = mesorock::test::xdmf_problems("out/snap.xmf");
//   EXPECT_TRUE(problems.empty()) << join(problems);
//
// It parses the XML (elements, attributes, text, comments, CDATA, the prolog and DOCTYPE), then
// for every DataItem checks:
//   Format="HDF": the text is FILE:/dataset/path (FILE relative to the .xmf's folder); the file
//     opens, the dataset exists, its shape equals Dimensions, and its type matches NumberType
//     (Float, Int, UInt, Char, UChar; default Float) and Precision (bytes; default 4).
//   Format="XML": the text holds exactly product(Dimensions) numbers.
// and for every Uniform Grid (Collection and Tree grids are walked):
//   one Topology and one Geometry; node and cell counts from the topology (3D/2D CoRectMesh,
//   RectMesh, SMesh: Dimensions are node counts, slowest first; Polyvertex and the unstructured
//   types: NumberOfElements, with or without a connectivity DataItem); the geometry's node count
//   agrees (XYZ, XY, X_Y_Z, VXVYVZ, ORIGIN_DXDYDZ, ORIGIN_DXDY, matched to the topology type);
//   every Attribute has one DataItem whose size is (nodes for Center="Node", the default; cells
//   for "Cell"; 1 for "Grid") x components (Scalar 1, Vector 3, Tensor6 6, Tensor 9), whose last
//   dimension is the component count when it has more than one, and whose leading dimensions are
//   the node or cell shape on a structured grid; attribute names are unique within a grid.
// Anything it does not understand (References, XInclude, HyperSlab/Function items, Binary
// format, Subset grids) is reported as a problem rather than passed silently.
//
// Header-only; needs the HDF5 C library (tests linking mesorock::sim have it).
#include <hdf5.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace mesorock::test {

namespace xdmf_detail {

struct XmlNode {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::string text;  // concatenated character data directly inside this element
  std::vector<std::unique_ptr<XmlNode>> children;

  const std::string* attr(const std::string& key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
  std::string attr_or(const std::string& key, const std::string& fallback) const {
    const std::string* v = attr(key);
    return v ? *v : fallback;
  }
  std::vector<const XmlNode*> children_named(const std::string& n) const {
    std::vector<const XmlNode*> out;
    for (const auto& c : children)
      if (c->name == n) out.push_back(c.get());
    return out;
  }
};

inline std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

inline std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Replaces the predefined entities and numeric character references (ASCII only).
inline bool decode_entities(const std::string& in, std::string& out, std::string& error) {
  out.clear();
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] != '&') {
      out += in[i];
      continue;
    }
    const size_t semi = in.find(';', i);
    if (semi == std::string::npos) {
      error = "unterminated entity reference";
      return false;
    }
    const std::string ent = in.substr(i + 1, semi - i - 1);
    if (ent == "amp") {
      out += '&';
    } else if (ent == "lt") {
      out += '<';
    } else if (ent == "gt") {
      out += '>';
    } else if (ent == "quot") {
      out += '"';
    } else if (ent == "apos") {
      out += '\'';
    } else if (ent.size() > 1 && ent[0] == '#') {
      const bool hex = ent[1] == 'x' || ent[1] == 'X';
      const std::string digits = ent.substr(hex ? 2 : 1);
      char* end = nullptr;
      const long code = std::strtol(digits.c_str(), &end, hex ? 16 : 10);
      if (digits.empty() || *end != '\0' || code <= 0 || code > 127) {
        error = "unsupported character reference &" + ent + ";";
        return false;
      }
      out += static_cast<char>(code);
    } else {
      error = "unknown entity &" + ent + ";";
      return false;
    }
    i = semi;
  }
  return true;
}

inline bool is_name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' ||
         c == '.';
}

// Parses a whole document; returns the root element, or nullptr with `error` set.
inline std::unique_ptr<XmlNode> parse_xml(const std::string& s, std::string& error) {
  std::vector<std::unique_ptr<XmlNode>> stack;
  std::unique_ptr<XmlNode> root;
  size_t i = 0;
  const size_t n = s.size();
  auto at = [&](const char* lit) {
    return s.compare(i, std::char_traits<char>::length(lit), lit) == 0;
  };
  auto line_of = [&](size_t pos) {
    return "line " +
           std::to_string(1 + std::count(s.begin(), s.begin() + static_cast<long>(pos), '\n'));
  };
  while (i < n) {
    if (at("<!--")) {
      const size_t e = s.find("-->", i + 4);
      if (e == std::string::npos) {
        error = "unterminated comment at " + line_of(i);
        return nullptr;
      }
      i = e + 3;
    } else if (at("<![CDATA[")) {
      const size_t e = s.find("]]>", i + 9);
      if (e == std::string::npos || stack.empty()) {
        error = "misplaced or unterminated CDATA at " + line_of(i);
        return nullptr;
      }
      stack.back()->text += s.substr(i + 9, e - i - 9);
      i = e + 3;
    } else if (at("<?")) {
      const size_t e = s.find("?>", i + 2);
      if (e == std::string::npos) {
        error = "unterminated processing instruction at " + line_of(i);
        return nullptr;
      }
      i = e + 2;
    } else if (at("<!")) {  // DOCTYPE, possibly with an internal subset [ ... ]
      int depth = 0;
      size_t j = i + 2;
      for (; j < n; ++j) {
        if (s[j] == '[') ++depth;
        if (s[j] == ']') --depth;
        if (s[j] == '>' && depth <= 0) break;
      }
      if (j >= n) {
        error = "unterminated declaration at " + line_of(i);
        return nullptr;
      }
      i = j + 1;
    } else if (at("</")) {
      size_t j = i + 2;
      while (j < n && is_name_char(s[j])) ++j;
      const std::string name = s.substr(i + 2, j - i - 2);
      while (j < n && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
      if (j >= n || s[j] != '>') {
        error = "malformed end tag at " + line_of(i);
        return nullptr;
      }
      if (stack.empty() || stack.back()->name != name) {
        error = "end tag </" + name + "> does not match " +
                (stack.empty() ? std::string("any open element") : "<" + stack.back()->name + ">") +
                " at " + line_of(i);
        return nullptr;
      }
      std::unique_ptr<XmlNode> done = std::move(stack.back());
      stack.pop_back();
      if (stack.empty()) {
        if (root) {
          error = "more than one root element";
          return nullptr;
        }
        root = std::move(done);
      } else {
        stack.back()->children.push_back(std::move(done));
      }
      i = j + 1;
    } else if (s[i] == '<') {
      size_t j = i + 1;
      while (j < n && is_name_char(s[j])) ++j;
      auto node = std::make_unique<XmlNode>();
      node->name = s.substr(i + 1, j - i - 1);
      if (node->name.empty()) {
        error = "malformed start tag at " + line_of(i);
        return nullptr;
      }
      bool self_closing = false;
      for (;;) {
        while (j < n && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        if (j >= n) {
          error = "unterminated start tag <" + node->name + "> at " + line_of(i);
          return nullptr;
        }
        if (s[j] == '>') {
          ++j;
          break;
        }
        if (s[j] == '/' && j + 1 < n && s[j + 1] == '>') {
          self_closing = true;
          j += 2;
          break;
        }
        const size_t k0 = j;
        while (j < n && is_name_char(s[j])) ++j;
        const std::string key = s.substr(k0, j - k0);
        while (j < n && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        if (key.empty() || j >= n || s[j] != '=') {
          error = "malformed attribute in <" + node->name + "> at " + line_of(i);
          return nullptr;
        }
        ++j;
        while (j < n && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        if (j >= n || (s[j] != '"' && s[j] != '\'')) {
          error = "unquoted attribute " + key + " in <" + node->name + "> at " + line_of(i);
          return nullptr;
        }
        const char q = s[j];
        const size_t e = s.find(q, j + 1);
        if (e == std::string::npos) {
          error = "unterminated attribute " + key + " at " + line_of(i);
          return nullptr;
        }
        std::string value;
        if (!decode_entities(s.substr(j + 1, e - j - 1), value, error)) return nullptr;
        if (node->attr(key)) {
          error = "duplicate attribute " + key + " in <" + node->name + "> at " + line_of(i);
          return nullptr;
        }
        node->attrs.emplace_back(key, value);
        j = e + 1;
      }
      if (self_closing) {
        if (stack.empty()) {
          if (root) {
            error = "more than one root element";
            return nullptr;
          }
          root = std::move(node);
        } else {
          stack.back()->children.push_back(std::move(node));
        }
      } else {
        stack.push_back(std::move(node));
      }
      i = j;
    } else {
      const size_t e = std::min(s.find('<', i), n);
      const std::string raw = s.substr(i, e - i);
      if (stack.empty()) {
        if (!trim(raw).empty()) {
          error = "text outside the root element at " + line_of(i);
          return nullptr;
        }
      } else {
        std::string text;
        if (!decode_entities(raw, text, error)) return nullptr;
        stack.back()->text += text;
      }
      i = e;
    }
  }
  if (!stack.empty()) {
    error = "element <" + stack.back()->name + "> is never closed";
    return nullptr;
  }
  if (!root) {
    error = "no root element";
    return nullptr;
  }
  return root;
}

inline std::string dims_text(const std::vector<unsigned long long>& d) {
  std::string s = "[";
  for (size_t i = 0; i < d.size(); ++i) s += (i ? " " : "") + std::to_string(d[i]);
  return s + "]";
}

inline unsigned long long product(const std::vector<unsigned long long>& d) {
  unsigned long long p = 1;
  for (auto v : d) p *= v;
  return p;
}

inline bool parse_uints(const std::string& s, std::vector<unsigned long long>& out) {
  out.clear();
  std::istringstream in(s);
  std::string tok;
  while (in >> tok) {
    if (tok.find_first_not_of("0123456789") != std::string::npos) return false;
    out.push_back(std::stoull(tok));
  }
  return !out.empty();
}

class Checker {
 public:
  explicit Checker(const std::filesystem::path& xmf) : xmf_(xmf) {}
  ~Checker() {
    for (auto& [path, id] : files_)
      if (id >= 0) H5Fclose(id);
  }
  Checker(const Checker&) = delete;
  Checker& operator=(const Checker&) = delete;

  std::vector<std::string> run() {
    std::ifstream in(xmf_, std::ios::binary);
    if (!in) return {xmf_.string() + ": cannot open"};
    std::ostringstream buf;
    buf << in.rdbuf();
    std::string error;
    const auto root = parse_xml(buf.str(), error);
    if (!root) return {xmf_.string() + ": not well-formed XML: " + error};
    if (root->name != "Xdmf") problem("", "root element is <" + root->name + ">, not <Xdmf>");
    walk_for_unsupported(*root, "");
    // Every DataItem, wherever it is, is checked once.
    collect_items(*root, "");
    int grids = 0;
    for (const XmlNode* d : root->children_named("Domain"))
      for (const XmlNode* g : d->children_named("Grid")) {
        ++grids;
        check_grid(*g, "");
      }
    if (grids == 0) problem("", "no Domain/Grid");
    return std::move(problems_);
  }

 private:
  struct Item {
    bool ok = false;  // checked without problems (dims valid)
    std::vector<unsigned long long> dims;
  };

  void problem(const std::string& where, const std::string& what) {
    problems_.push_back(xmf_.string() + ": " + (where.empty() ? "" : where + ": ") + what);
  }

  static std::string label(const XmlNode& n) {
    const std::string* name = n.attr("Name");
    return name ? n.name + " \"" + *name + "\"" : n.name;
  }
  static std::string join(const std::string& where, const std::string& more) {
    return where.empty() ? more : where + " / " + more;
  }

  void walk_for_unsupported(const XmlNode& n, const std::string& where) {
    const std::string here = join(where, label(n));
    if (n.name == "xi:include" || n.name == "include")
      problem(here, "XInclude is not supported by this checker");
    else if (n.attr("Reference"))
      problem(here, "Reference is not supported by this checker");
    for (const auto& c : n.children) walk_for_unsupported(*c, here);
  }

  void collect_items(const XmlNode& n, const std::string& where) {
    const std::string here = join(where, label(n));
    if (n.name == "DataItem") {
      // A Reference was reported by walk_for_unsupported; it counts as not checkable.
      items_[&n] = n.attr("Reference") ? Item{} : check_item(n, here);
      // A DataItem holding DataItems (e.g. HyperSlab) was already reported as unsupported.
      return;
    }
    for (const auto& c : n.children) collect_items(*c, here);
  }

  // Opens (once) and caches a data file; a file that cannot be opened is reported at first use.
  hid_t open_file(const std::filesystem::path& p, const std::string& where) {
    const std::string key = p.lexically_normal().string();
    auto it = files_.find(key);
    if (it != files_.end()) return it->second;
    hid_t f = -1;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) {
      problem(where, "HDF5 file " + p.string() + " does not exist");
    } else {
      H5E_BEGIN_TRY {
        f = H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
      }
      H5E_END_TRY;
      if (f < 0) problem(where, "cannot open " + p.string() + " as HDF5");
    }
    files_[key] = f;
    return f;
  }

  Item check_item(const XmlNode& n, const std::string& where) {
    Item item;
    const std::string item_type = n.attr_or("ItemType", "Uniform");
    if (lower(item_type) != "uniform") {
      problem(where, "ItemType=\"" + item_type + "\" is not supported by this checker");
      return item;
    }
    if (!n.children.empty()) {
      problem(where, "a Uniform DataItem holds child elements");
      return item;
    }
    const std::string* dims_attr = n.attr("Dimensions");
    if (!dims_attr) {
      problem(where, "no Dimensions");
      return item;
    }
    if (!parse_uints(*dims_attr, item.dims)) {
      problem(where, "Dimensions \"" + *dims_attr + "\" is not a list of non-negative integers");
      return item;
    }
    const std::string number_type = n.attr_or("NumberType", n.attr_or("DataType", "Float"));
    const std::string precision_text = n.attr_or("Precision", "4");
    const std::string nt = lower(number_type);
    if (nt != "float" && nt != "int" && nt != "uint" && nt != "char" && nt != "uchar") {
      problem(where, "unknown NumberType \"" + number_type + "\"");
      return item;
    }
    std::vector<unsigned long long> prec;
    if (!parse_uints(precision_text, prec) || prec.size() != 1 ||
        !(prec[0] == 1 || prec[0] == 2 || prec[0] == 4 || prec[0] == 8) ||
        (nt == "float" && prec[0] < 4)) {
      problem(where, "invalid Precision \"" + precision_text + "\" for " + number_type);
      return item;
    }
    const std::string format = n.attr_or("Format", "XML");
    const std::string text = trim(n.text);
    if (lower(format) == "xml") {
      std::istringstream in(text);
      std::string tok;
      unsigned long long count = 0;
      bool numeric = true;
      while (in >> tok) {
        ++count;
        char* end = nullptr;
        std::strtod(tok.c_str(), &end);
        if (*end != '\0') numeric = false;
      }
      if (!numeric) {
        problem(where, "XML data holds a value that is not a number");
        return item;
      }
      if (count != product(item.dims)) {
        problem(where, "XML data holds " + std::to_string(count) + " values, Dimensions " +
                           dims_text(item.dims) + " need " + std::to_string(product(item.dims)));
        return item;
      }
      item.ok = true;
      return item;
    }
    if (lower(format) != "hdf") {
      problem(where, "Format=\"" + format + "\" is not supported by this checker");
      return item;
    }
    const size_t sep = text.rfind(":/");
    if (sep == std::string::npos || sep == 0) {
      problem(where, "HDF data \"" + text + "\" is not FILE:/dataset");
      return item;
    }
    const std::string file_text = text.substr(0, sep), dataset = text.substr(sep + 1);
    std::filesystem::path file = file_text;
    if (file.is_relative()) file = xmf_.parent_path() / file;
    const std::string here = where + " (" + text + ")";
    const hid_t f = open_file(file, here);
    if (f < 0) return item;
    hid_t ds = -1;
    H5E_BEGIN_TRY {
      ds = H5Dopen2(f, dataset.c_str(), H5P_DEFAULT);
    }
    H5E_END_TRY;
    if (ds < 0) {
      problem(here, "dataset " + dataset + " does not exist in " + file.string());
      return item;
    }
    bool good = true;
    const hid_t space = H5Dget_space(ds);
    const int rank = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
    std::vector<hsize_t> hd(rank > 0 ? static_cast<size_t>(rank) : 0);
    if (rank < 0 || (rank > 0 && H5Sget_simple_extent_dims(space, hd.data(), nullptr) < 0)) {
      problem(here, "cannot read the dataspace");
      good = false;
    } else {
      std::vector<unsigned long long> shape(hd.begin(), hd.end());
      if (rank == 0) shape = {1};  // a scalar dataset: Dimensions="1"
      if (shape != item.dims) {
        problem(here, "dataset shape " + dims_text(shape) + " differs from Dimensions " +
                          dims_text(item.dims));
        good = false;
      }
    }
    if (space >= 0) H5Sclose(space);
    const hid_t type = H5Dget_type(ds);
    if (type < 0) {
      problem(here, "cannot read the datatype");
      good = false;
    } else {
      const H5T_class_t cls = H5Tget_class(type);
      const size_t size = H5Tget_size(type);
      std::string actual;
      bool match = false;
      if (cls == H5T_FLOAT) {
        actual = "float";
        match = nt == "float";
      } else if (cls == H5T_INTEGER) {
        const bool is_signed = H5Tget_sign(type) == H5T_SGN_2;
        actual = is_signed ? "signed integer" : "unsigned integer";
        match = is_signed ? (nt == "int" || (nt == "char" && size == 1))
                          : (nt == "uint" || (nt == "uchar" && size == 1));
      } else {
        actual = "non-numeric";
      }
      if (!match || size != prec[0]) {
        problem(here, "dataset type is " + std::to_string(size) + "-byte " + actual +
                          ", the DataItem says NumberType=\"" + number_type + "\" Precision=\"" +
                          precision_text + "\"");
        good = false;
      }
      H5Tclose(type);
    }
    H5Dclose(ds);
    item.ok = good;
    return item;
  }

  const Item* item_of(const XmlNode* n) const {
    auto it = items_.find(n);
    return it == items_.end() ? nullptr : &it->second;
  }

  void check_grid(const XmlNode& g, const std::string& where) {
    const std::string here = join(where, label(g));
    const std::string type = lower(g.attr_or("GridType", "Uniform"));
    if (type == "collection" || type == "tree") {
      const auto kids = g.children_named("Grid");
      if (kids.empty()) problem(here, "a " + g.attr_or("GridType", "") + " grid holds no Grid");
      for (const XmlNode* k : kids) check_grid(*k, here);
      return;
    }
    if (type != "uniform") {
      problem(here, "GridType=\"" + g.attr_or("GridType", "") + "\" is not supported");
      return;
    }
    for (const XmlNode* t : g.children_named("Time")) {
      const std::string* v = t->attr("Value");
      if (v) {
        char* end = nullptr;
        std::strtod(v->c_str(), &end);
        if (v->empty() || *end != '\0') problem(here, "Time Value \"" + *v + "\" is not a number");
      }
    }
    const auto topos = g.children_named("Topology");
    const auto geoms = g.children_named("Geometry");
    if (topos.size() != 1 || geoms.size() != 1) {
      problem(here, "needs exactly one Topology and one Geometry (has " +
                        std::to_string(topos.size()) + " and " + std::to_string(geoms.size()) +
                        ")");
      return;
    }
    Shape shape;
    if (!topology_shape(*topos[0], here, shape)) return;
    if (!geometry_matches(*geoms[0], here, shape)) return;
    std::set<std::string> names;
    for (const XmlNode* a : g.children_named("Attribute")) check_attribute(*a, here, shape, names);
  }

  struct Shape {
    std::string topology;                        // lower case
    bool structured = false;                     // SMesh, RectMesh, CoRectMesh
    std::vector<unsigned long long> node_shape;  // structured only, slowest first
    unsigned long long nodes = 0;  // unknown (0 with known_nodes false) until geometry
    bool known_nodes = false;
    unsigned long long cells = 0;
  };

  bool topology_shape(const XmlNode& t, const std::string& grid, Shape& shape) {
    const std::string here = join(grid, "Topology");
    const std::string type_attr = t.attr_or("TopologyType", t.attr_or("Type", ""));
    const std::string type = lower(type_attr);
    shape.topology = type;
    const bool d3 = type == "3dcorectmesh" || type == "3drectmesh" || type == "3dsmesh";
    const bool d2 = type == "2dcorectmesh" || type == "2drectmesh" || type == "2dsmesh";
    if (d3 || d2) {
      shape.structured = true;
      const std::string* dims = t.attr("Dimensions");
      if (!dims || !parse_uints(*dims, shape.node_shape) ||
          shape.node_shape.size() != (d3 ? 3u : 2u)) {
        problem(here, type_attr + " needs Dimensions with " + (d3 ? "3" : "2") +
                          " node counts (slowest first)");
        return false;
      }
      shape.nodes = product(shape.node_shape);
      shape.known_nodes = true;
      shape.cells = 1;
      for (auto d : shape.node_shape) {
        if (d < 1) {
          problem(here, "a node count of 0 in Dimensions");
          return false;
        }
        shape.cells *= d > 1 ? d - 1 : 0;
      }
      return true;
    }
    static const std::map<std::string, unsigned long long> per_element{
        {"polyvertex", 0},      {"polyline", 0},      {"triangle", 3},   {"quadrilateral", 4},
        {"tetrahedron", 4},     {"pyramid", 5},       {"wedge", 6},      {"hexahedron", 8},
        {"mixed", 0},           {"edge_3", 3},        {"triangle_6", 6}, {"quadrilateral_8", 8},
        {"tetrahedron_10", 10}, {"hexahedron_20", 20}};
    const auto pe = per_element.find(type);
    if (pe == per_element.end()) {
      problem(here, "unknown TopologyType \"" + type_attr + "\"");
      return false;
    }
    std::vector<unsigned long long> ne;
    const std::string* ne_attr = t.attr("NumberOfElements");
    if (!ne_attr) ne_attr = t.attr("Dimensions");
    if (!ne_attr || !parse_uints(*ne_attr, ne) || ne.size() != 1) {
      problem(here, type_attr + " needs NumberOfElements");
      return false;
    }
    shape.cells = ne[0];
    unsigned long long npe = pe->second;
    if (type == "polyvertex" || type == "polyline") {
      std::vector<unsigned long long> v;
      const std::string npe_text = t.attr_or("NodesPerElement", type == "polyvertex" ? "1" : "");
      if (!parse_uints(npe_text, v) || v.size() != 1) {
        problem(here, type_attr + " needs NodesPerElement");
        return false;
      }
      npe = v[0];
    }
    const auto conn = t.children_named("DataItem");
    if (conn.size() > 1) {
      problem(here, "more than one connectivity DataItem");
      return false;
    }
    if (conn.empty()) {
      if (type != "polyvertex") {
        problem(here, type_attr + " needs a connectivity DataItem");
        return false;
      }
      // Implicit connectivity: nodes 0 .. NumberOfElements * NodesPerElement - 1.
      shape.nodes = shape.cells * npe;
      shape.known_nodes = true;
    } else if (const Item* it = item_of(conn[0]);
               it && it->ok && type != "mixed" && product(it->dims) != shape.cells * npe) {
      problem(here, "connectivity holds " + std::to_string(product(it->dims)) +
                        " node indices, NumberOfElements x nodes per element = " +
                        std::to_string(shape.cells * npe));
      return false;
    }
    return true;
  }

  bool geometry_matches(const XmlNode& g, const std::string& grid, Shape& shape) {
    const std::string here = join(grid, "Geometry");
    const std::string type_attr = g.attr_or("GeometryType", g.attr_or("Type", "XYZ"));
    const std::string type = lower(type_attr);
    const auto items = g.children_named("DataItem");
    std::vector<const Item*> its;
    for (const XmlNode* d : items) {
      const Item* it = item_of(d);
      if (!it || !it->ok) return false;  // already reported
      its.push_back(it);
    }
    auto need_items = [&](size_t k) {
      if (items.size() == k) return true;
      problem(here, type_attr + " needs " + std::to_string(k) + " DataItem(s), has " +
                        std::to_string(items.size()));
      return false;
    };
    const bool corect = shape.topology == "3dcorectmesh" || shape.topology == "2dcorectmesh";
    const bool rect = shape.topology == "3drectmesh" || shape.topology == "2drectmesh";
    const size_t ndim = shape.node_shape.size();
    unsigned long long geom_nodes = 0;
    if (type == "origin_dxdydz" || type == "origin_dxdy") {
      const unsigned long long k = type == "origin_dxdydz" ? 3 : 2;
      if (!corect || ndim != k) {
        problem(here, type_attr + " does not fit TopologyType " + shape.topology);
        return false;
      }
      if (!need_items(2)) return false;
      for (size_t i = 0; i < 2; ++i)
        if (product(its[i]->dims) != k) {
          problem(here, std::string(i == 0 ? "origin" : "spacing") + " has " +
                            std::to_string(product(its[i]->dims)) + " values, needs " +
                            std::to_string(k));
          return false;
        }
      return true;
    }
    if (corect) {
      problem(here, "TopologyType " + shape.topology + " needs ORIGIN_DXDYDZ or ORIGIN_DXDY");
      return false;
    }
    if (type == "vxvyvz" || type == "vxvy") {
      const size_t k = type == "vxvyvz" ? 3 : 2;
      if (!rect || ndim != k) {
        problem(here, type_attr + " does not fit TopologyType " + shape.topology);
        return false;
      }
      if (!need_items(k)) return false;
      for (size_t i = 0; i < k; ++i) {
        // VX has the fastest axis's node count, the last entry of Dimensions.
        const unsigned long long want = shape.node_shape[ndim - 1 - i];
        if (product(its[i]->dims) != want) {
          problem(here, "coordinate array " + std::to_string(i) + " has " +
                            std::to_string(product(its[i]->dims)) + " values, Dimensions need " +
                            std::to_string(want));
          return false;
        }
      }
      return true;
    }
    if (rect) {
      problem(here, "TopologyType " + shape.topology + " needs VXVYVZ or VXVY");
      return false;
    }
    if (type == "xyz" || type == "xy") {
      const unsigned long long k = type == "xyz" ? 3 : 2;
      if (!need_items(1)) return false;
      const auto& d = its[0]->dims;
      if (product(d) % k != 0 || (d.size() > 1 && d.back() != k)) {
        problem(here, type_attr + " coordinates must be [N " + std::to_string(k) + "], got " +
                          dims_text(d));
        return false;
      }
      geom_nodes = product(d) / k;
    } else if (type == "x_y_z" || type == "x_y") {
      const size_t k = type == "x_y_z" ? 3 : 2;
      if (!need_items(k)) return false;
      geom_nodes = product(its[0]->dims);
      for (size_t i = 1; i < k; ++i)
        if (product(its[i]->dims) != geom_nodes) {
          problem(here, "coordinate arrays differ in length");
          return false;
        }
    } else {
      problem(here, "unknown GeometryType \"" + type_attr + "\"");
      return false;
    }
    if (shape.known_nodes && geom_nodes != shape.nodes) {
      problem(here, "geometry has " + std::to_string(geom_nodes) + " nodes, the topology " +
                        std::to_string(shape.nodes));
      return false;
    }
    shape.nodes = geom_nodes;
    shape.known_nodes = true;
    return true;
  }

  void check_attribute(const XmlNode& a, const std::string& grid, const Shape& shape,
                       std::set<std::string>& names) {
    const std::string here = join(grid, label(a));
    const std::string* name = a.attr("Name");
    if (!name || name->empty())
      problem(here, "Attribute without a Name");
    else if (!names.insert(*name).second)
      problem(here, "duplicate Attribute name");
    const std::string type_attr = a.attr_or("AttributeType", a.attr_or("Type", "Scalar"));
    const std::string center_attr = a.attr_or("Center", "Node");
    const std::string type = lower(type_attr), center = lower(center_attr);
    static const std::map<std::string, unsigned long long> comps_of{
        {"scalar", 1}, {"vector", 3}, {"tensor6", 6}, {"tensor", 9}, {"matrix", 0}};
    const auto ct = comps_of.find(type);
    if (ct == comps_of.end()) {
      problem(here, "unknown AttributeType \"" + type_attr + "\"");
      return;
    }
    const auto items = a.children_named("DataItem");
    if (items.size() != 1) {
      problem(here, "needs exactly one DataItem, has " + std::to_string(items.size()));
      return;
    }
    const Item* it = item_of(items[0]);
    if (!it || !it->ok) return;  // already reported
    unsigned long long count = 0;
    std::vector<unsigned long long> lead;  // structured shape the leading dims must equal
    if (center == "node") {
      count = shape.nodes;
      if (shape.structured) lead = shape.node_shape;
    } else if (center == "cell") {
      count = shape.cells;
      if (shape.structured)
        for (auto d : shape.node_shape) lead.push_back(d - 1);
    } else if (center == "grid") {
      count = 1;
    } else if (center == "face" || center == "edge" || center == "other") {
      return;  // sizes depend on the cell types; not checked
    } else {
      problem(here, "unknown Center \"" + center_attr + "\"");
      return;
    }
    const auto& d = it->dims;
    const unsigned long long comps = ct->second;
    if (comps == 0) {  // Matrix: any number of columns, rows = count
      if (d.empty() || d[0] != count)
        problem(here, "Matrix rows " + dims_text(d) + " differ from " + std::to_string(count) +
                          " (" + center_attr + " count)");
      return;
    }
    if (product(d) != count * comps) {
      problem(here, type_attr + " on Center=\"" + center_attr + "\" needs " +
                        std::to_string(count) + " x " + std::to_string(comps) +
                        " values, Dimensions " + dims_text(d) + " hold " +
                        std::to_string(product(d)));
      return;
    }
    if (comps > 1 && d.size() > 1 && d.back() != comps) {
      problem(here, type_attr + " needs a last dimension of " + std::to_string(comps) +
                        ", Dimensions are " + dims_text(d));
      return;
    }
    if (!lead.empty() && d.size() >= lead.size()) {
      const std::vector<unsigned long long> got(d.begin(),
                                                d.begin() + static_cast<long>(lead.size()));
      const bool trailing_ok =
          d.size() == lead.size() || (d.size() == lead.size() + 1 && d.back() == comps);
      if (got != lead || !trailing_ok)
        problem(here, "Dimensions " + dims_text(d) + " do not match the " + center_attr +
                          " shape " + dims_text(lead) +
                          (comps > 1 ? " x " + std::to_string(comps) : ""));
    }
  }

  std::filesystem::path xmf_;
  std::vector<std::string> problems_;
  std::map<std::string, hid_t> files_;
  std::map<const XmlNode*, Item> items_;
};

}  // namespace xdmf_detail

// Problems found in the XDMF file `xmf` and the HDF5 data it names; empty when consistent.
// Each problem is one line starting with the .xmf path.
inline std::vector<std::string> xdmf_problems(const std::filesystem::path& xmf) {
  xdmf_detail::Checker c(xmf);
  return c.run();
}

}  // namespace mesorock::test
