#include "pipeline/scene.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include "mesorock/errors.h"
#include "mesorock/number_text.h"
#include "pipeline/flow/interrupt.h"
#include "sim/init.h"
#include "sim/memory_budget.h"
#include "sim/particle_io.h"
#include "sim/terms.h"
#include "sim/validate_inputs.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

namespace {

// The most particles one scene may create (the solver indexes particles with 32-bit integers).
constexpr double kMaxParticles = 2147483647.0;

// ---------------------------------------------------------------------------------------------
// Message helpers

// Shortest text that reads back as the same double ("-1", "0.1", "10", "1e+15", "nan", "inf").
std::string num(double v) {
  return shortest_number_text(v);
}

std::string in_quotes(const std::string& s) {
  return "\"" + s + "\"";
}

// "string \"abc\"", "floating-point 1.5", "integer 3", "boolean true", "array", "table", ...
std::string describe(const toml::node& n) {
  std::ostringstream s;
  s << n.type();
  if (auto v = n.as_string()) {
    std::string text = v->get();
    if (text.size() > 40) text = text.substr(0, 37) + "...";
    s << " " << in_quotes(text);
  } else if (auto i = n.as_integer()) {
    s << " " << i->get();
  } else if (auto f = n.as_floating_point()) {
    s << " " << num(f->get());
  } else if (auto b = n.as_boolean()) {
    s << (b->get() ? " true" : " false");
  }
  return s.str();
}

std::string join_names(const sim::Model& m) {
  std::string s;
  for (const auto& t : m.types) s += (s.empty() ? "" : ", ") + t.name;
  return s;
}

// File-order comparison of two nodes (toml::table is ordered by key, not by position).
bool before(const toml::source_region& a, const toml::source_region& b) {
  if (a.begin.line != b.begin.line) return a.begin.line < b.begin.line;
  return a.begin.column < b.begin.column;
}

struct Context {
  std::string file;  // the scene path as the user gave it (message prefix)
  fs::path dir;      // the scene file's folder (relative paths are resolved against it)
};

[[noreturn]] void fail(const Context& c, const std::string& key, const std::string& problem) {
  throw ConfigError(c.file + ": " + key + ": " + problem);
}

// ---------------------------------------------------------------------------------------------
// Typed reads of single nodes; `key` is the full key path used in messages.

double number_at(const Context& c, const toml::node& n, const std::string& key) {
  double v = 0;
  if (auto i = n.as_integer())
    v = static_cast<double>(i->get());
  else if (auto f = n.as_floating_point())
    v = f->get();
  else
    fail(c, key, "must be a number (got " + describe(n) + ")");
  if (!std::isfinite(v)) fail(c, key, "must be a finite number (got " + num(v) + ")");
  return v;
}

std::int64_t integer_at(const Context& c, const toml::node& n, const std::string& key) {
  if (auto i = n.as_integer()) return i->get();
  fail(c, key, "must be an integer (got " + describe(n) + ")");
}

std::string string_at(const Context& c, const toml::node& n, const std::string& key) {
  if (auto s = n.as_string()) return s->get();
  fail(c, key, "must be a string (got " + describe(n) + ")");
}

std::array<double, 3> vec3_at(const Context& c, const toml::node& n, const std::string& key) {
  const toml::array* a = n.as_array();
  if (!a) fail(c, key, "must be an array of 3 numbers (got " + describe(n) + ")");
  if (a->size() != 3)
    fail(c, key, "must be an array of 3 numbers (got " + std::to_string(a->size()) + " entries)");
  std::array<double, 3> v{};
  for (size_t i = 0; i < 3; ++i)
    v[i] = number_at(c, *a->get(i), key + "[" + std::to_string(i) + "]");
  return v;
}

int axis_at(const Context& c, const toml::node& n, const std::string& key);

template <class E>
E choice_at(const Context& c, const toml::node& n, const std::string& key,
            std::initializer_list<std::pair<const char*, E>> options) {
  const std::string s = string_at(c, n, key);
  std::string list;
  for (const auto& [text, value] : options) {
    if (s == text) return value;
    list += (list.empty() ? "" : ", ") + in_quotes(text);
  }
  fail(c, key, "must be one of " + list + " (got " + in_quotes(s) + ")");
}

int axis_at(const Context& c, const toml::node& n, const std::string& key) {
  return choice_at<int>(c, n, key, {{"x", 0}, {"y", 1}, {"z", 2}});
}

// ---------------------------------------------------------------------------------------------
// One TOML table being read: every key it holds must be declared (else "unknown key", reported
// at construction, first in file order, so a misspelt key is named before the "missing" error its
// correct spelling would give), and every key must have been read by finish() (Mirheo's
// checkAllRead pattern: a key the reader did not consume is reported as unknown, so no key can be
// silently ignored).
class Table {
 public:
  Table(const Context& c, const toml::table& t, std::string path,
        const std::set<std::string>& known)
      : c_(c), t_(t), path_(std::move(path)) {
    const auto first =
        first_in_file_order([&](const std::string& k) { return known.count(k) == 0; });
    if (first) fail(c_, key(*first), "unknown key");
  }

  std::string key(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  const std::string& path() const { return path_; }
  bool has(const std::string& k) const { return t_.contains(k); }

  // The node under k (marked as read), or nullptr.
  const toml::node* get(const std::string& k) {
    const toml::node* n = t_.get(k);
    if (n) read_.insert(k);
    return n;
  }
  const toml::node& require(const std::string& k) {
    const toml::node* n = get(k);
    if (!n) fail(c_, key(k), "missing");
    return *n;
  }
  // A key that must not appear in this context.
  void forbid(const std::string& k, const std::string& why) {
    if (get(k)) fail(c_, key(k), "not allowed " + why);
  }

  std::optional<double> number(const std::string& k) {
    const toml::node* n = get(k);
    return n ? std::optional<double>(number_at(c_, *n, key(k))) : std::nullopt;
  }
  std::optional<std::int64_t> integer(const std::string& k) {
    const toml::node* n = get(k);
    return n ? std::optional<std::int64_t>(integer_at(c_, *n, key(k))) : std::nullopt;
  }
  std::optional<std::string> string(const std::string& k) {
    const toml::node* n = get(k);
    return n ? std::optional<std::string>(string_at(c_, *n, key(k))) : std::nullopt;
  }
  std::optional<bool> boolean(const std::string& k) {
    const toml::node* n = get(k);
    if (!n) return std::nullopt;
    if (auto b = n->as_boolean()) return b->get();
    fail(c_, key(k), "must be a boolean (got " + describe(*n) + ")");
  }
  std::optional<std::array<double, 3>> vec3(const std::string& k) {
    const toml::node* n = get(k);
    return n ? std::optional<std::array<double, 3>>(vec3_at(c_, *n, key(k))) : std::nullopt;
  }
  double require_number(const std::string& k) { return number_at(c_, require(k), key(k)); }
  std::int64_t require_integer(const std::string& k) { return integer_at(c_, require(k), key(k)); }
  std::string require_string(const std::string& k) { return string_at(c_, require(k), key(k)); }
  std::array<double, 3> require_vec3(const std::string& k) {
    return vec3_at(c_, require(k), key(k));
  }

  // An optional sub-table ([name]).
  const toml::table* table(const std::string& k) {
    const toml::node* n = get(k);
    if (!n) return nullptr;
    if (auto t = n->as_table()) return t;
    fail(c_, key(k), "must be a table ([" + key(k) + "]) (got " + describe(*n) + ")");
  }
  const toml::table& require_table(const std::string& k) {
    const toml::table* t = table(k);
    if (!t) fail(c_, key(k), "missing (a [" + key(k) + "] table is required)");
    return *t;
  }
  // A required, non-empty array of tables ([[name]]).
  std::vector<const toml::table*> require_blocks(const std::string& k) {
    const toml::node* n = get(k);
    if (!n) fail(c_, key(k), "missing (at least one [[" + key(k) + "]] block is required)");
    const toml::array* a = n->as_array();
    if (a && a->empty()) fail(c_, key(k), "at least one [[" + key(k) + "]] block is required");
    if (!a || !a->is_array_of_tables())
      fail(c_, key(k),
           "must be an array of tables ([[" + key(k) + "]]) (got " + describe(*n) + ")");
    std::vector<const toml::table*> out;
    for (const auto& e : *a) out.push_back(e.as_table());
    return out;
  }

  // checkAllRead: the first key (in file order) nobody read is an error.
  void finish() const {
    const auto first =
        first_in_file_order([&](const std::string& k) { return read_.count(k) == 0; });
    if (first) fail(c_, key(*first), "unknown key");
  }

 private:
  // The key (first in the file) for which pred(key) holds, if any.
  template <class Pred>
  std::optional<std::string> first_in_file_order(Pred pred) const {
    std::optional<std::string> first;
    const toml::node* first_node = nullptr;
    for (auto&& [k, node] : t_) {
      const std::string name(k.str());
      if (pred(name) && (!first_node || before(node.source(), first_node->source()))) {
        first = name;
        first_node = &node;
      }
    }
    return first;
  }

  const Context& c_;
  const toml::table& t_;
  std::string path_;
  std::set<std::string> read_;
};

std::string indexed(const std::string& name, size_t i) {
  return name + "[" + std::to_string(i) + "]";
}

// ---------------------------------------------------------------------------------------------
// Sections

void read_box(const Context& c, Table& top, Scene& s) {
  Table t(c, top.require_table("box"), "box", {"lo", "hi", "boundary"});
  s.box.lo = t.require_vec3("lo");
  s.box.hi = t.require_vec3("hi");
  for (size_t a = 0; a < 3; ++a)
    if (!(s.box.hi[a] > s.box.lo[a]))
      fail(c, "box.hi",
           "must be > box.lo on every axis (hi[" + std::to_string(a) + "] = " + num(s.box.hi[a]) +
               " <= lo[" + std::to_string(a) + "] = " + num(s.box.lo[a]) + ")");
  if (const toml::node* n = t.get("boundary")) {
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3)
      fail(c, "box.boundary",
           "must be an array of 3 strings (got " +
               (a ? std::to_string(a->size()) + " entries" : describe(*n)) + ")");
    for (size_t i = 0; i < 3; ++i)
      s.box.periodic[i] = choice_at<bool>(c, *a->get(i), indexed("box.boundary", i),
                                          {{"periodic", true}, {"reflective", false}});
  }
  for (size_t a = 0; a < 3; ++a)
    if (s.box.periodic[a] && s.box.length(static_cast<int>(a)) < 2.0)
      fail(c, "box",
           "a periodic edge must be at least 2 rc long (axis " + std::to_string(a) + " is " +
               num(s.box.length(static_cast<int>(a))) + ")");
  t.finish();
}

void read_model(const Context& c, Table& top, Scene& s) {
  Table t(c, top.require_table("model"), "model",
          {"conservative", "density_kernel", "rd", "thermostat", "kBT", "lambda",
           "body_force_profile", "body_force_axis"});
  sim::Model& m = s.model;
  m.conservative = choice_at<sim::ConservativeKind>(
      c, t.require("conservative"), "model.conservative",
      {{"mdpd", sim::ConservativeKind::MDPD}, {"dpd", sim::ConservativeKind::DPD}});
  if (m.conservative == sim::ConservativeKind::MDPD) {
    if (const toml::node* n = t.get("density_kernel"))
      m.density_kernel = choice_at<sim::DensityKernelKind>(
          c, *n, "model.density_kernel",
          {{"warren", sim::DensityKernelKind::Warren}, {"lucy", sim::DensityKernelKind::Lucy}});
    if (auto rd = t.number("rd")) {
      if (!(*rd > 0 && *rd <= 1)) fail(c, "model.rd", "must be in (0, 1] (got " + num(*rd) + ")");
      m.rd = *rd;
    }
  } else {
    t.forbid("density_kernel", "when model.conservative = \"dpd\"");
    t.forbid("rd", "when model.conservative = \"dpd\"");
  }
  if (auto th = t.boolean("thermostat")) m.thermostat = *th;
  if (auto kbt = t.number("kBT")) {
    if (!(*kbt > 0)) fail(c, "model.kBT", "must be > 0 (got " + num(*kbt) + ")");
    m.kBT = *kbt;
  }
  if (auto lam = t.number("lambda")) {
    if (!(*lam >= 0 && *lam <= 1))
      fail(c, "model.lambda", "must be in [0, 1] (got " + num(*lam) + ")");
    m.lambda = *lam;
  }
  if (const toml::node* n = t.get("body_force_profile"))
    m.body_force_profile =
        choice_at<sim::BodyForceProfile>(c, *n, "model.body_force_profile",
                                         {{"uniform", sim::BodyForceProfile::Uniform},
                                          {"reversed", sim::BodyForceProfile::Reversed}});
  if (m.body_force_profile == sim::BodyForceProfile::Reversed) {
    if (const toml::node* n = t.get("body_force_axis"))
      m.body_force_axis = axis_at(c, *n, "model.body_force_axis");
  } else {
    t.forbid("body_force_axis", "unless model.body_force_profile = \"reversed\"");
  }
  t.finish();
}

void read_types(const Context& c, Table& top, Scene& s) {
  const auto blocks = top.require_blocks("types");
  if (blocks.size() > 32)
    fail(c, "types", "at most 32 types are supported (got " + std::to_string(blocks.size()) + ")");
  std::map<std::string, size_t> seen;
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("types", i), {"name", "frozen", "body_force"});
    sim::TypeSpec ts;
    ts.name = t.require_string("name");
    if (ts.name.empty()) fail(c, t.key("name"), "must not be empty");
    if (auto it = seen.find(ts.name); it != seen.end())
      fail(c, t.key("name"),
           "duplicate type name " + in_quotes(ts.name) + " (already used by types[" +
               std::to_string(it->second) + "])");
    seen[ts.name] = i;
    if (auto f = t.boolean("frozen")) ts.frozen = *f;
    if (auto bf = t.vec3("body_force")) ts.body_force = *bf;
    t.finish();
    s.model.add_type(ts);
  }
}

int type_at(const Context& c, const sim::Model& m, const toml::node& n, const std::string& key) {
  const std::string name = string_at(c, n, key);
  const int t = m.type_index(name);
  if (t < 0) fail(c, key, "unknown type " + in_quotes(name) + " (types: " + join_names(m) + ")");
  return t;
}

// A [[pairs]] entry as the pair terms read it (sim/terms.h): their errors are the scene's.
class ScenePairEntry final : public sim::PairEntry {
 public:
  ScenePairEntry(const Context& c, Table& t) : c_(c), t_(t) {}
  double require_number(const char* key) override { return t_.require_number(key); }
  void forbid(const char* key, const std::string& why) override { t_.forbid(key, why); }
  [[noreturn]] void reject(const char* key, const std::string& rule, double value) override {
    fail(c_, t_.key(key), rule + " (got " + num(value) + ")");
  }

 private:
  const Context& c_;
  Table& t_;
};

void read_pairs(const Context& c, Table& top, Scene& s) {
  sim::Model& m = s.model;
  const auto blocks = top.require_blocks("pairs");
  const int nt = m.ntypes();
  std::set<std::string> known = sim::pair_term_keys();
  known.insert("types");
  std::vector<long> given(static_cast<size_t>(nt * nt), -1);  // block index per unordered pair
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("pairs", i), known);
    const std::string tk = t.key("types");
    const toml::node& tn = t.require("types");
    const toml::array* arr = tn.as_array();
    if (!arr || arr->size() != 2)
      fail(c, tk,
           "must be an array of 2 type names (got " +
               (arr ? std::to_string(arr->size()) + " entries" : describe(tn)) + ")");
    const int a = type_at(c, m, *arr->get(0), tk + "[0]");
    const int b = type_at(c, m, *arr->get(1), tk + "[1]");
    const size_t slot = static_cast<size_t>(std::min(a, b) * nt + std::max(a, b));
    if (given[slot] >= 0)
      fail(c, tk,
           "duplicate pair (" + in_quotes(m.types[static_cast<size_t>(a)].name) + ", " +
               in_quotes(m.types[static_cast<size_t>(b)].name) + ") (already given in pairs[" +
               std::to_string(given[slot]) + "])");
    given[slot] = static_cast<long>(i);

    sim::PairSpec p;
    ScenePairEntry entry(c, t);
    sim::read_pair_terms(m, entry, p);
    t.finish();
    m.set_pair(a, b, p);
  }
  for (int a = 0; a < nt; ++a)
    for (int b = a; b < nt; ++b)
      if (given[static_cast<size_t>(a * nt + b)] < 0)
        fail(c, "pairs",
             "missing pair (" + in_quotes(m.types[static_cast<size_t>(a)].name) + ", " +
                 in_quotes(m.types[static_cast<size_t>(b)].name) +
                 ") (every pair of types needs one [[pairs]] block)");
}

void check_particle_estimate(const Context& c, const std::string& key, double n) {
  if (n > kMaxParticles)
    fail(c, key,
         "would create " + num(std::round(n)) + " particles, more than the limit of " +
             num(kMaxParticles));
}

void read_init(const Context& c, Table& top, Scene& s) {
  const auto blocks = top.require_blocks("init");
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("init", i),
            {"kind", "type", "density", "count", "lo", "hi", "file"});
    InitSpec in;
    in.kind = choice_at<InitSpec::Kind>(c, t.require("kind"), t.key("kind"),
                                        {{"random", InitSpec::Kind::Random},
                                         {"lattice", InitSpec::Kind::Lattice},
                                         {"file", InitSpec::Kind::File}});
    in.lo = s.box.lo;
    in.hi = s.box.hi;
    if (in.kind == InitSpec::Kind::File) {
      for (const char* k : {"type", "density", "count", "lo", "hi"})
        t.forbid(k, "when kind = \"file\"");
      const std::string f = t.require_string("file");
      if (f.empty()) fail(c, t.key("file"), "must not be empty");
      in.file = fs::path(f).is_absolute() ? fs::path(f) : c.dir / f;
      std::error_code ec;
      if (!fs::exists(in.file, ec)) fail(c, t.key("file"), "no such file: " + in.file.string());
      if (!fs::is_regular_file(in.file, ec))
        fail(c, t.key("file"), "not a regular file: " + in.file.string());
      s.named_files.push_back(in.file);
    } else {
      const bool random = in.kind == InitSpec::Kind::Random;
      const char* kind_text = random ? "when kind = \"random\"" : "when kind = \"lattice\"";
      t.forbid("file", kind_text);
      if (!random) t.forbid("count", kind_text);
      in.type = string_at(c, t.require("type"), t.key("type"));
      type_at(c, s.model, *t.get("type"), t.key("type"));
      if (auto lo = t.vec3("lo")) in.lo = *lo;
      if (auto hi = t.vec3("hi")) in.hi = *hi;
      for (size_t a = 0; a < 3; ++a) {
        const std::string ax = "[" + std::to_string(a) + "]";
        if (in.lo[a] < s.box.lo[a])
          fail(c, t.key("lo"),
               "region must lie inside the box (lo" + ax + " = " + num(in.lo[a]) + " < box.lo" +
                   ax + " = " + num(s.box.lo[a]) + ")");
        if (in.hi[a] > s.box.hi[a])
          fail(c, t.key("hi"),
               "region must lie inside the box (hi" + ax + " = " + num(in.hi[a]) + " > box.hi" +
                   ax + " = " + num(s.box.hi[a]) + ")");
        if (!(in.hi[a] > in.lo[a]))
          fail(c, t.key("hi"),
               "must be > lo on every axis (hi" + ax + " = " + num(in.hi[a]) + " <= lo" + ax +
                   " = " + num(in.lo[a]) + ")");
      }
      const double volume = (in.hi[0] - in.lo[0]) * (in.hi[1] - in.lo[1]) * (in.hi[2] - in.lo[2]);
      in.density = t.number("density");
      if (random) in.count = t.integer("count");
      if (in.density && in.count) fail(c, t.key("count"), "give either density or count, not both");
      if (!in.density && !in.count)
        fail(c, t.key("density"), random ? "missing (give density or count)" : "missing");
      if (in.density) {
        if (!(*in.density > 0))
          fail(c, t.key("density"), "must be > 0 (got " + num(*in.density) + ")");
        double n = *in.density * volume;
        if (!random) {  // the lattice fill_lattice will build
          const double spacing = std::cbrt(1.0 / *in.density);
          n = 1;
          for (size_t a = 0; a < 3; ++a)
            n *= std::max(1.0, std::round((in.hi[a] - in.lo[a]) / spacing));
        }
        check_particle_estimate(c, t.key("density"), n);
      } else {
        if (*in.count < 0)
          fail(c, t.key("count"), "must be >= 0 (got " + std::to_string(*in.count) + ")");
        check_particle_estimate(c, t.key("count"), static_cast<double>(*in.count));
      }
    }
    t.finish();
    s.init.push_back(std::move(in));
  }
}

void read_stages(const Context& c, Table& top, Scene& s) {
  const auto blocks = top.require_blocks("run");
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("run", i), {"name", "steps", "dt"});
    StageSpec st;
    st.name = t.string("name").value_or("stage" + std::to_string(i + 1));
    if (st.name.empty()) fail(c, t.key("name"), "must not be empty");
    const std::int64_t steps = t.require_integer("steps");
    if (steps < 0) fail(c, t.key("steps"), "must be >= 0 (got " + std::to_string(steps) + ")");
    st.steps = static_cast<std::uint64_t>(steps);
    st.dt = t.require_number("dt");
    if (!(st.dt > 0 && st.dt <= 0.1))
      fail(c, t.key("dt"), "must be > 0 and <= 0.1 (got " + num(st.dt) + ")");
    t.finish();
    s.stages.push_back(std::move(st));
  }
}

std::vector<std::string> string_list_at(const Context& c, const toml::node& n,
                                        const std::string& key) {
  const toml::array* a = n.as_array();
  if (!a) fail(c, key, "must be an array of strings (got " + describe(n) + ")");
  std::vector<std::string> out;
  for (size_t i = 0; i < a->size(); ++i) out.push_back(string_at(c, *a->get(i), indexed(key, i)));
  return out;
}

std::uint64_t positive_integer(const Context& c, Table& t, const std::string& k,
                               std::uint64_t fallback) {
  const auto v = t.integer(k);
  if (!v) return fallback;
  if (*v < 1) fail(c, t.key(k), "must be >= 1 (got " + std::to_string(*v) + ")");
  return static_cast<std::uint64_t>(*v);
}

std::vector<std::string> type_names_at(const Context& c, const Scene& s, Table& t) {
  const toml::node* n = t.get("types");
  if (!n) return {};
  std::vector<std::string> names = string_list_at(c, *n, t.key("types"));
  if (names.empty()) fail(c, t.key("types"), "must name at least one type (or be left out)");
  for (size_t i = 0; i < names.size(); ++i)
    if (s.model.type_index(names[i]) < 0)
      fail(c, indexed(t.key("types"), i), "unknown type " + in_quotes(names[i]));
  return names;
}

// [walls]: the boundary model of Li et al. 2018 for frozen wall particles (docs/walls.md).
void read_walls(const Context& c, Table& top, Scene& s) {
  const toml::table* tbl = top.table("walls");
  if (!tbl) return;
  Table t(c, *tbl, "walls",
          {"model", "types", "wall_density", "penetration_threshold", "reflection", "slip_factor",
           "max_dissipation_factor"});
  sim::WallModelSpec& w = s.model.wall_model;
  const std::string model = string_at(c, t.require("model"), "walls.model");
  if (model == "none") {
    t.finish();
    return;
  }
  if (model != "li2018")
    fail(c, "walls.model", "must be \"li2018\" or \"none\" (got " + in_quotes(model) + ")");
  w.enabled = true;
  for (const std::string& name : type_names_at(c, s, t))
    w.wall_types |= 1u << s.model.type_index(name);
  if (auto n = t.number("wall_density")) w.wall_density = *n;
  if (auto phi = t.number("penetration_threshold")) w.penetration_threshold = *phi;
  if (const toml::node* n = t.get("reflection"))
    w.reflection = choice_at<sim::WallReflection>(
        c, *n, "walls.reflection",
        {{"li2018", sim::WallReflection::Li2018}, {"specular", sim::WallReflection::Specular}});
  if (auto f = t.number("slip_factor")) w.slip_factor = *f;
  if (auto k = t.number("max_dissipation_factor")) w.max_dissipation_factor = *k;
  // The sim checks the values (every caller of make_simulation goes through the same check); its
  // message names the key, this file names the scene.
  try {
    sim::validate_wall_model(s.model);
  } catch (const ConfigError& e) {
    throw ConfigError(c.file + ": " + e.what());
  }
  t.finish();
}

// [solid]: the solid as voxels (sim/solid_grid.h; rockprep writes solid.h5 beside the
// particles). Mobile particles that drift into a solid voxel are sent back, the leak invariant
// counts those inside, and one deeper than stop_depth stops the run (docs/walls.md).
void read_solid(const Context& c, Table& top, Scene& s) {
  const toml::table* tbl = top.table("solid");
  if (!tbl) return;
  Table t(c, *tbl, "solid", {"file", "bounce", "stop_depth", "stop_count"});
  const std::string f = t.require_string("file");
  if (f.empty()) fail(c, "solid.file", "must not be empty");
  const fs::path path = fs::path(f).is_absolute() ? fs::path(f) : c.dir / f;
  sim::SolidSpec& spec = s.model.solid;
  if (auto b = t.boolean("bounce")) spec.bounce = *b;
  if (auto d = t.number("stop_depth")) {
    if (!(*d > 0 && *d <= 4))
      fail(c, "solid.stop_depth", "must be in (0, 4] rc (got " + num(*d) + ")");
    spec.stop_depth = *d;
  }
  if (auto n = t.integer("stop_count")) {
    if (*n < 0) fail(c, "solid.stop_count", "must be >= 0 (got " + std::to_string(*n) + ")");
    spec.stop_count = static_cast<std::uint64_t>(*n);
  }
  t.finish();
  try {
    spec.mask = std::make_shared<const sim::SolidMask>(sim::read_solid_file(path));
  } catch (const IoError& e) {
    throw IoError(c.file + ": solid.file: " + e.what());
  }
  s.named_files.push_back(path);
  const sim::SolidMask& m = *spec.mask;
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<size_t>(a);
    const double end = m.origin[k] + static_cast<double>(m.dims[k]) * m.voxel[k];
    const double tol = 1e-6 * s.box.length(a);
    if (m.origin[k] < s.box.lo[k] - tol || end > s.box.hi[k] + tol)
      fail(c, "solid.file",
           path.string() + ": the grid (" + num(m.origin[k]) + " to " + num(end) + " along " +
               "xyz"[a] + ") does not fit in the box (" + num(s.box.lo[k]) + " to " +
               num(s.box.hi[k]) + ")");
  }
}

// [[virtual_walls]]: planes that keep some types on one side until a step (the 2020 paper's
// virtual wall at the face of the pore block, removed when flooding starts).
void read_virtual_walls(const Context& c, Table& top, Scene& s) {
  if (!top.get("virtual_walls")) return;
  const auto blocks = top.require_blocks("virtual_walls");
  if (blocks.size() > static_cast<size_t>(sim::kMaxVirtualWalls))
    fail(c, "virtual_walls",
         "at most " + std::to_string(sim::kMaxVirtualWalls) + " blocks (got " +
             std::to_string(blocks.size()) + ")");
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("virtual_walls", i),
            {"axis", "position", "types", "keep", "until_step"});
    sim::VirtualWallSpec w;
    w.axis = axis_at(c, t.require("axis"), t.key("axis"));
    w.position = t.require_number("position");
    const double lo = s.box.lo[static_cast<size_t>(w.axis)];
    const double hi = s.box.hi[static_cast<size_t>(w.axis)];
    if (!(w.position > lo && w.position < hi))
      fail(c, t.key("position"),
           "must lie strictly inside the box (" + num(lo) + " to " + num(hi) + ", got " +
               num(w.position) + ")");
    const auto names = type_names_at(c, s, t);
    if (names.empty()) fail(c, t.key("types"), "missing: name the types the wall keeps back");
    for (const auto& n : names) w.types |= 1u << s.model.type_index(n);
    w.keep_below =
        choice_at<bool>(c, t.require("keep"), t.key("keep"), {{"below", true}, {"above", false}});
    const std::int64_t until = t.require_integer("until_step");
    if (until < 0) fail(c, t.key("until_step"), "must be >= 0 (got " + std::to_string(until) + ")");
    w.until_step = static_cast<std::uint64_t>(until);
    t.finish();
    s.model.virtual_walls.push_back(w);
  }
}

// [[slabs]]: rigid slabs (pistons) of one type each, moving along an axis under an applied
// pressure (the 2020 paper's pushing and back-pressure slabs).
void read_slabs(const Context& c, Table& top, Scene& s) {
  if (!top.get("slabs")) return;
  const auto blocks = top.require_blocks("slabs");
  if (blocks.size() > static_cast<size_t>(sim::kMaxRigidSlabs))
    fail(c, "slabs",
         "at most " + std::to_string(sim::kMaxRigidSlabs) + " blocks (got " +
             std::to_string(blocks.size()) + ")");
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("slabs", i), {"type", "axis", "pressure"});
    sim::RigidSlabSpec r;
    const std::string name = t.require_string("type");
    r.type = s.model.type_index(name);
    if (r.type < 0) fail(c, t.key("type"), "unknown type " + in_quotes(name));
    r.axis = axis_at(c, t.require("axis"), t.key("axis"));
    r.applied_pressure = t.require_number("pressure");
    s.model.rigid_slabs.push_back(r);
    try {  // the sim's check, as for [walls]
      sim::validate_rigid_slab(s.model, i);
    } catch (const ConfigError& e) {
      throw ConfigError(c.file + ": " + e.what());
    }
    t.finish();
  }
}

// [[injection]]: injection/ejection boundaries (the 2017 paper's flooding at a set rate; sim/
// injection.h): every `every` steps, `particles` particles of the eject types inside the outlet
// box are removed and as many of the injected type appear at random points of the inlet box.
void read_injection(const Context& c, Table& top, Scene& s) {
  if (!top.get("injection")) return;
  const auto blocks = top.require_blocks("injection");
  if (blocks.size() > static_cast<size_t>(sim::kMaxInjections))
    fail(c, "injection",
         "at most " + std::to_string(sim::kMaxInjections) + " blocks (got " +
             std::to_string(blocks.size()) + ")");
  for (size_t i = 0; i < blocks.size(); ++i) {
    Table t(c, *blocks[i], indexed("injection", i),
            {"type", "eject_types", "inlet_lo", "inlet_hi", "outlet_lo", "outlet_hi", "every",
             "particles", "start_step", "stop_step"});
    sim::InjectionSpec q;
    const std::string name = t.require_string("type");
    q.inject_type = s.model.type_index(name);
    if (q.inject_type < 0) fail(c, t.key("type"), "unknown type " + in_quotes(name));
    if (const toml::node* n = t.get("eject_types")) {
      const auto names = string_list_at(c, *n, t.key("eject_types"));
      for (size_t k = 0; k < names.size(); ++k) {
        const int ty = s.model.type_index(names[k]);
        if (ty < 0)
          fail(c, indexed(t.key("eject_types"), k), "unknown type " + in_quotes(names[k]));
        q.eject_types |= 1u << ty;
      }
    } else {
      for (int ty = 0; ty < s.model.ntypes(); ++ty)
        if (s.model.is_mobile(ty)) q.eject_types |= 1u << ty;
    }
    q.inlet_lo = t.require_vec3("inlet_lo");
    q.inlet_hi = t.require_vec3("inlet_hi");
    q.outlet_lo = t.require_vec3("outlet_lo");
    q.outlet_hi = t.require_vec3("outlet_hi");
    q.every = positive_integer(c, t, "every", 1);
    // Out-of-range values are the sim's to refuse; clamped only so that they survive the cast.
    const std::int64_t per = t.integer("particles").value_or(1);
    q.per_event = static_cast<int>(std::clamp<std::int64_t>(per, std::numeric_limits<int>::min(),
                                                            std::numeric_limits<int>::max()));
    const std::int64_t start = t.integer("start_step").value_or(0);
    if (start < 0) fail(c, t.key("start_step"), "must be >= 0 (got " + std::to_string(start) + ")");
    q.start_step = static_cast<std::uint64_t>(start);
    if (auto stop = t.integer("stop_step")) {
      if (*stop <= start)  // also the sim's rule, but a negative value would not survive the cast
        fail(c, t.key("stop_step"),
             "must be greater than start_step (got " + std::to_string(*stop) + ")");
      q.stop_step = static_cast<std::uint64_t>(*stop);
    }
    s.model.injections.push_back(q);
    // The sim checks the boundary (every caller of make_simulation goes through the same check);
    // its message names the key, this file names the scene.
    try {
      sim::validate_injection(s.model, s.box, i);
    } catch (const ConfigError& e) {
      throw ConfigError(c.file + ": " + e.what());
    }
    t.finish();
  }
}

// [decomposition]: how a run under mpirun splits the box over its ranks (sim/domain).
void read_decomposition(const Context& c, Table& top, Scene& s) {
  const toml::table* tbl = top.table("decomposition");
  if (!tbl) return;
  Table t(c, *tbl, "decomposition", {"method", "axes", "rebalance_every", "halo"});
  sim::DecompositionOptions& d = s.decomposition;
  if (const toml::node* n = t.get("method"))
    d.method = choice_at<sim::DecompositionMethod>(
        c, *n, "decomposition.method",
        {{"rcb", sim::DecompositionMethod::RCB}, {"slabs", sim::DecompositionMethod::Slabs}});
  if (const toml::node* n = t.get("axes")) {
    const auto names = string_list_at(c, *n, "decomposition.axes");
    if (names.empty()) fail(c, "decomposition.axes", "must name at least one axis");
    d.axes = 0;
    for (size_t i = 0; i < names.size(); ++i) {
      const toml::value<std::string> v(names[i]);
      d.axes |= 1u << axis_at(c, v, indexed("decomposition.axes", i));
    }
  }
  if (auto e = t.integer("rebalance_every")) {
    if (*e < 0)
      fail(c, "decomposition.rebalance_every", "must be >= 0 (got " + std::to_string(*e) + ")");
    d.rebalance_every = static_cast<std::uint64_t>(*e);
  }
  if (auto h = t.number("halo")) {
    if (!(*h >= 1 && *h <= 2))
      fail(c, "decomposition.halo", "must be in [1, 2] rc (got " + num(*h) + ")");
    d.halo = *h;
  }
  t.finish();
}

void read_output(const Context& c, Table& top, Scene& s) {
  const toml::table* tbl = top.table("output");
  if (!tbl) return;
  Table t(c, *tbl, "output",
          {"thermo_every", "snapshot_every", "final_snapshot", "average_stages", "profiles",
           "fields", "regions", "checkpoint_every"});
  for (auto [key, target] : {std::pair{"thermo_every", &s.output.thermo_every},
                             std::pair{"snapshot_every", &s.output.snapshot_every},
                             std::pair{"checkpoint_every", &s.output.checkpoint_every}}) {
    if (auto v = t.integer(key)) {
      if (*v < 0) fail(c, t.key(key), "must be >= 0 (got " + std::to_string(*v) + ")");
      *target = static_cast<std::uint64_t>(*v);
    }
  }
  if (auto f = t.boolean("final_snapshot")) s.output.final_snapshot = *f;
  if (const toml::node* n = t.get("average_stages")) {
    s.output.average_stages = string_list_at(c, *n, "output.average_stages");
    for (size_t i = 0; i < s.output.average_stages.size(); ++i) {
      const std::string& name = s.output.average_stages[i];
      bool found = false;
      for (const auto& st : s.stages) found = found || st.name == name;
      if (!found) fail(c, indexed("output.average_stages", i), "no stage named " + in_quotes(name));
    }
  }
  std::set<std::string> names;
  if (const toml::node* n = t.get("profiles")) {
    const toml::array* a = n->as_array();
    if (!a || !a->is_array_of_tables())
      fail(c, "output.profiles",
           "must be an array of tables ([[output.profiles]]) (got " + describe(*n) + ")");
    for (size_t i = 0; i < a->size(); ++i) {
      Table p(c, *a->get(i)->as_table(), indexed("output.profiles", i),
              {"name", "axis", "bins", "every", "types"});
      BinnedOutputSpec spec;
      spec.axis = axis_at(c, p.require("axis"), p.key("axis"));
      const std::int64_t bins = p.require_integer("bins");
      if (bins < 1 || bins > 100000)
        fail(c, p.key("bins"), "must be in 1..100000 (got " + std::to_string(bins) + ")");
      spec.cells[static_cast<size_t>(spec.axis)] = static_cast<int>(bins);
      spec.every = positive_integer(c, p, "every", 10);
      spec.types = type_names_at(c, s, p);
      spec.name = p.string("name").value_or(std::string("profile_") + "xyz"[spec.axis]);
      p.finish();
      s.output.profiles.push_back(std::move(spec));
    }
  }
  if (const toml::table* ft = t.table("fields")) {
    Table f(c, *ft, "output.fields", {"cells", "every", "types"});
    BinnedOutputSpec spec;
    spec.name = "fields";
    const auto cells = f.require_vec3("cells");
    double total = 1;
    for (size_t a = 0; a < 3; ++a) {
      if (!(cells[a] >= 1 && cells[a] <= 4096 && cells[a] == std::floor(cells[a])))
        fail(c, indexed("output.fields.cells", a),
             "must be a whole number in 1..4096 (got " + num(cells[a]) + ")");
      spec.cells[a] = static_cast<int>(cells[a]);
      total *= cells[a];
    }
    if (total > 64.0 * 1024 * 1024)
      fail(c, "output.fields.cells", "more than 64 Mi cells (got " + num(total) + ")");
    spec.every = positive_integer(c, f, "every", 100);
    spec.types = type_names_at(c, s, f);
    f.finish();
    s.output.fields = std::move(spec);
  }
  if (const toml::node* n = t.get("regions")) {
    const toml::array* a = n->as_array();
    if (!a || !a->is_array_of_tables())
      fail(c, "output.regions",
           "must be an array of tables ([[output.regions]]) (got " + describe(*n) + ")");
    std::set<std::string> region_names;
    for (size_t i = 0; i < a->size(); ++i) {
      const std::string at = indexed("output.regions", i);
      Table r(c, *a->get(i)->as_table(), at,
              {"name", "lo", "hi", "every", "types", "saturation_of", "pressure"});
      RegionOutputSpec spec;
      spec.name = r.string("name").value_or("region" + std::to_string(i + 1));
      if (spec.name.empty() || !region_names.insert(spec.name).second)
        fail(c, r.key("name"), "region names must be unique and non-empty");
      for (char ch : spec.name)
        if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-'))
          fail(c, r.key("name"), "may contain only letters, digits, '_' and '-'");
      spec.lo = r.require_vec3("lo");
      spec.hi = r.require_vec3("hi");
      for (size_t k = 0; k < 3; ++k)
        if (!(spec.hi[k] > spec.lo[k]))
          fail(c, indexed(at + ".hi", k), "must be greater than lo (got " + num(spec.hi[k]) + ")");
      spec.every = positive_integer(c, r, "every", 100);
      spec.types = type_names_at(c, s, r);
      if (spec.types.empty())
        for (int ty = 0; ty < s.model.ntypes(); ++ty) {
          bool slab = false;
          for (const auto& r : s.model.rigid_slabs) slab = slab || r.type == ty;
          if (!s.model.types[static_cast<size_t>(ty)].frozen && !slab)
            spec.types.push_back(s.model.types[static_cast<size_t>(ty)].name);
        }
      if (auto sat = r.string("saturation_of")) {
        if (std::find(spec.types.begin(), spec.types.end(), *sat) == spec.types.end())
          fail(c, r.key("saturation_of"),
               "must be one of the region's types (got " + in_quotes(*sat) + ")");
        spec.saturation_of = *sat;
      }
      spec.pressure = r.boolean("pressure").value_or(false);
      r.finish();
      s.output.regions.push_back(std::move(spec));
    }
  }
  for (const auto& p : s.output.profiles) {
    if (p.name.empty() || p.name == "fields" || !names.insert(p.name).second)
      fail(c, "output.profiles",
           "profile names must be unique and not \"fields\" (" + in_quotes(p.name) + " repeats)");
    for (char ch : p.name)
      if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-'))
        fail(c, "output.profiles",
             "name " + in_quotes(p.name) + " may contain only letters, digits, '_' and '-'");
  }
  t.finish();
}

void read_units(const Context& c, Table& top, Scene& s) {
  const toml::table* tbl = top.table("units");
  if (!tbl) return;
  Table t(c, *tbl, "units", {"nm_per_rc", "temperature_K", "particle_mass_kg"});
  s.units.nm_per_rc = t.require_number("nm_per_rc");
  if (!(s.units.nm_per_rc > 0))
    fail(c, "units.nm_per_rc", "must be > 0 (got " + num(s.units.nm_per_rc) + ")");
  if (auto T = t.number("temperature_K")) {
    if (!(*T > 0)) fail(c, "units.temperature_K", "must be > 0 (got " + num(*T) + ")");
    s.units.temperature_K = *T;
  }
  if (auto m = t.number("particle_mass_kg")) {
    if (!(*m > 0)) fail(c, "units.particle_mass_kg", "must be > 0 (got " + num(*m) + ")");
    s.units.particle_mass_kg = *m;
  }
  t.finish();
}

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

std::string box_text(const sim::BoxSpec& b) {
  std::string s;
  for (size_t a = 0; a < 3; ++a) s += (a ? " x [" : "[") + num(b.lo[a]) + ", " + num(b.hi[a]) + "]";
  return s;
}

}  // namespace

std::uint64_t init_block_seed(std::uint64_t seed, std::size_t block) {
  return splitmix64(seed ^ splitmix64(static_cast<std::uint64_t>(block) + 1));
}

std::uint64_t init_velocity_seed(std::uint64_t seed) {
  return splitmix64(seed ^ splitmix64(0));
}

Scene parse_scene(const std::string& text, const fs::path& path_for_messages) {
  const Context c{path_for_messages.string(), path_for_messages.parent_path()};
  toml::table root;
  try {
    root = toml::parse(text, path_for_messages.string());
  } catch (const toml::parse_error& e) {
    // toml++ messages may span lines; the contract is one line per error.
    std::string desc(e.description());
    for (char& ch : desc)
      if (ch == '\n' || ch == '\r' || ch == '\t') ch = ' ';
    desc.erase(
        std::unique(desc.begin(), desc.end(), [](char a, char b) { return a == ' ' && b == ' '; }),
        desc.end());
    while (!desc.empty() && desc.back() == ' ') desc.pop_back();
    throw ConfigError(c.file + ": line " + std::to_string(e.source().begin.line) + ": " + desc);
  }

  Scene s;
  s.path = path_for_messages;
  s.source_text = text;
  Table top(
      c, root, "",
      {"name", "seed", "precision", "box", "model", "types", "pairs", "walls", "solid",
       "virtual_walls", "slabs", "injection", "init", "run", "output", "units", "decomposition"});
  const std::string stem = path_for_messages.stem().string();
  s.name = top.string("name").value_or(stem.empty() ? "scene" : stem);
  if (s.name.empty()) fail(c, "name", "must not be empty");
  if (auto seed = top.integer("seed")) {
    if (*seed < 0) fail(c, "seed", "must be >= 0 (got " + std::to_string(*seed) + ")");
    s.model.seed = static_cast<std::uint64_t>(*seed);
  }
  if (const toml::node* n = top.get("precision"))
    s.model.precision = choice_at<sim::Precision>(
        c, *n, "precision",
        {{"single", sim::Precision::Single}, {"double", sim::Precision::Double}});
  read_box(c, top, s);
  read_model(c, top, s);
  read_types(c, top, s);
  read_pairs(c, top, s);
  read_walls(c, top, s);
  read_solid(c, top, s);
  read_virtual_walls(c, top, s);
  read_slabs(c, top, s);
  read_injection(c, top, s);
  read_init(c, top, s);
  read_stages(c, top, s);
  read_output(c, top, s);
  read_units(c, top, s);
  read_decomposition(c, top, s);
  if (s.model.body_force_profile == sim::BodyForceProfile::Reversed && !s.model.has_body_force())
    fail(c, "model.body_force_profile", "\"reversed\" needs a body_force on at least one type");
  if (s.model.body_force_profile == sim::BodyForceProfile::Reversed &&
      !s.box.periodic[static_cast<size_t>(s.model.body_force_axis)])
    fail(c, "model.body_force_axis", "reverse Poiseuille flow needs a periodic axis");
  top.finish();
  return s;
}

bool stage_is_averaged(const Scene& scene, const std::string& stage_name) {
  if (scene.output.average_stages.empty())
    return !scene.stages.empty() && scene.stages.back().name == stage_name;
  for (const auto& n : scene.output.average_stages)
    if (n == stage_name) return true;
  return false;
}

Scene load_scene(const fs::path& path) {
  std::error_code ec;
  // Regular files only: a FIFO blocked the open forever, and /dev/zero was read without end.
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec))
    throw IoError(path.string() + ": not a regular file (a folder, FIFO or device): cannot read " +
                  "it as a scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path.string() + ": cannot open scene file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw IoError(path.string() + ": cannot read scene file");
  return parse_scene(text.str(), path);
}

namespace {

// The particles block `in` will create: the count the fills make (fill_random rounds density x
// volume, fill_lattice rounds the cells per axis), or the count in the file's header.
double init_particle_count(const Scene& scene, size_t k, const InitSpec& in) {
  if (in.kind == InitSpec::Kind::File) {
    try {
      return static_cast<double>(sim::read_particle_file_count(in.file));
    } catch (const IoError& e) {
      throw IoError(scene.path.string() + ": " + indexed("init", k) + ".file: " + e.what());
    }
  }
  double volume = 1;
  for (size_t a = 0; a < 3; ++a) volume *= in.hi[a] - in.lo[a];
  if (in.kind == InitSpec::Kind::Random)
    return in.density ? std::round(*in.density * volume)
                      : static_cast<double>(in.count.value_or(0));
  if (!in.density) return 0;
  const double spacing = std::cbrt(1.0 / *in.density);
  double n = 1;
  for (size_t a = 0; a < 3; ++a) n *= std::max(1.0, std::round((in.hi[a] - in.lo[a]) / spacing));
  return n;
}

// A particle count as digits ("4000000000", not "4e+09").
std::string count_text(double n) {
  return n < 1e18 ? std::to_string(static_cast<long long>(n)) : num(n);
}

std::string init_key(const InitSpec& in, size_t k) {
  const char* key = in.kind == InitSpec::Kind::File ? "file" : in.count ? "count" : "density";
  return indexed("init", k) + "." + key;
}

}  // namespace

namespace {
// The half list's share of host_bytes_per_particle (sim/memory_budget.h), at rho = 7.
constexpr double kHalfListBytesAtRho7 = 128;
}  // namespace

void check_memory_for(const Scene& scene, const sim::SimulationOptions& options, int copies) {
  copies = std::max(1, copies);
  const std::string file = scene.path.string();
  std::vector<double> counts;
  double total = 0;
  for (size_t k = 0; k < scene.init.size(); ++k) {
    counts.push_back(init_particle_count(scene, k, scene.init[k]));
    total += counts.back();
  }
  const sim::Precision precision = scene.model.precision;
  // The CPU's half list holds the pairs within reach of each particle, which grow with the number
  // density: host_bytes_per_particle assumes rho = 7 (128 B of list). 200,000 particles in a 5^3
  // box (rho = 1600) passed the guard, the list grew past 10 GB and the process aborted on
  // std::bad_alloc. The densest [[init]] block (or the whole box, if denser) sizes the list here.
  double density =
      total / std::max(1e-300, scene.box.length(0) * scene.box.length(1) * scene.box.length(2));
  for (size_t k = 0; k < scene.init.size(); ++k) {
    const InitSpec& in = scene.init[k];
    double volume = 1;
    for (int a = 0; a < 3; ++a)
      volume *= in.kind == InitSpec::Kind::File
                    ? scene.box.length(a)
                    : in.hi[static_cast<size_t>(a)] - in.lo[static_cast<size_t>(a)];
    if (volume > 0) density = std::max(density, counts[k] / volume);
  }
  const double list_bytes = options.backend == sim::BackendKind::CUDA
                                ? 0.0
                                : kHalfListBytesAtRho7 * std::max(0.0, density / 7 - 1);
  if (total > kMaxParticles)
    throw LimitError(file + ": [[init]] blocks: total " + count_text(total) +
                     " particles, more than the limit of " + num(kMaxParticles) +
                     " for one run (they would need about " +
                     sim::bytes_text(total * sim::host_bytes_per_particle(precision)) +
                     " of host memory)");
  // Cells of the cell list (CellGrid::make): (rc + skin) / cells_per_cutoff wide.
  double cells = 1;
  for (size_t a = 0; a < 3; ++a)
    cells *= std::max(1.0, std::floor(scene.box.length(static_cast<int>(a)) *
                                      std::max(1, options.cells_per_cutoff) / (1 + options.skin)));
  const double voxels =
      scene.model.solid.mask ? static_cast<double>(scene.model.solid.mask->solid.size()) : 0.0;
  // Which key asked: the largest block when it alone does not fit, else the blocks together.
  auto refuse_if_short = [&](double per_particle, double fixed, const sim::MemoryAvailable& have,
                             const char* what) {
    const std::string why =
        sim::memory_shortfall(copies * (total * per_particle + fixed), have, what);
    if (why.empty()) return;
    if (copies > 1)
      throw LimitError(file + ": " + std::to_string(copies) + " runs side by side of " +
                       count_text(total) + " particles (" + num(per_particle) +
                       " bytes each): they " + why);
    const size_t k =
        static_cast<size_t>(std::max_element(counts.begin(), counts.end()) - counts.begin());
    const bool alone = k < counts.size() &&
                       !sim::memory_shortfall(counts[k] * per_particle + fixed, have, what).empty();
    const double n = alone ? counts[k] : total;
    throw LimitError(
        file + ": " +
        (alone ? init_key(scene.init[k], k) + ": " : std::string("[[init]] blocks: total ")) +
        count_text(n) + " particles (" + num(per_particle) + " bytes each): a run " +
        sim::memory_shortfall(n * per_particle + fixed, have, what));
  };
  refuse_if_short(sim::host_bytes_per_particle(precision) + list_bytes,
                  cells * sim::kHostBytesPerCell, sim::host_memory_available(), "host");
  if (options.backend == sim::BackendKind::CUDA)
    refuse_if_short(sim::device_bytes_per_particle(precision),
                    cells * sim::kDeviceBytesPerCell + voxels,
                    sim::device_memory_available(options.device), "device");
}

sim::ParticleSet build_initial_particles(const Scene& scene) {
  check_memory_for(scene, sim::SimulationOptions{});  // host memory, before any particle
  const std::string file = scene.path.string();
  const sim::Model& m = scene.model;
  sim::ParticleSet out;
  std::vector<char> generated;  // per particle: made here (gets Maxwell velocities)
  std::int64_t next_id = 0;     // one past the largest id so far

  for (size_t k = 0; k < scene.init.size(); ++k) {
    const InitSpec& in = scene.init[k];
    const std::string where = file + ": " + indexed("init", k);
    const size_t before_size = out.size();
    if (in.kind == InitSpec::Kind::File) {
      sim::ParticleFileMeta meta;
      sim::ParticleSet p;
      try {
        p = sim::read_particle_file(in.file, &meta);
      } catch (const IoError& e) {
        throw IoError(where + ".file: " + e.what());
      }
      std::vector<std::int32_t> map(meta.type_names.size());
      for (size_t t = 0; t < meta.type_names.size(); ++t) {
        const int idx = m.type_index(meta.type_names[t]);
        if (idx < 0)
          throw ConfigError(where + ".file: " + in.file.string() + ": type " +
                            in_quotes(meta.type_names[t]) +
                            " is not a type of this scene (types: " + join_names(m) + ")");
        map[t] = idx;
      }
      // Ids stay unique: a file whose ids would collide with earlier blocks is shifted past them
      // (its relative id order is kept); a file that comes first keeps its ids.
      std::int64_t lo_id = 0, hi_id = -1;
      if (p.size() > 0) {
        const auto [mn, mx] = std::minmax_element(p.id.begin(), p.id.end());
        lo_id = *mn;
        hi_id = *mx;
      }
      constexpr std::int64_t kIdLimit = std::int64_t{1} << 62;  // keeps the shift overflow-free
      if (lo_id < -kIdLimit || hi_id > kIdLimit)
        throw ConfigError(where + ".file: " + in.file.string() +
                          ": particle ids must lie in [-2^62, 2^62]");
      const std::int64_t shift = (p.size() > 0 && lo_id < next_id) ? next_id - lo_id : 0;
      for (size_t i = 0; i < p.size(); ++i) {
        const double pos[3] = {p.x[i], p.y[i], p.z[i]};
        for (size_t a = 0; a < 3; ++a)
          if (pos[a] < scene.box.lo[a] || pos[a] > scene.box.hi[a])
            throw ConfigError(where + ": particle " + std::to_string(p.id[i]) + " of " +
                              in.file.string() + " at (" + num(pos[0]) + ", " + num(pos[1]) + ", " +
                              num(pos[2]) + ") lies outside the box " + box_text(scene.box));
        out.add(p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i],
                map[static_cast<size_t>(p.type[i])], p.id[i] + shift);
      }
      if (p.size() > 0) next_id = std::max(next_id, hi_id + shift + 1);
      generated.resize(out.size(), 0);
    } else {
      const std::int32_t t = m.type_index(in.type);
      if (t < 0)
        throw ConfigError(where + ".type: unknown type " + in_quotes(in.type) +
                          " (types: " + join_names(m) + ")");
      for (size_t a = 0; a < 3; ++a)
        if (in.lo[a] < scene.box.lo[a] || in.hi[a] > scene.box.hi[a] || !(in.hi[a] > in.lo[a]))
          throw ConfigError(where + ": region must lie inside the box " + box_text(scene.box));
      if (in.kind == InitSpec::Kind::Random) {
        const double volume = (in.hi[0] - in.lo[0]) * (in.hi[1] - in.lo[1]) * (in.hi[2] - in.lo[2]);
        const std::int64_t count = in.density ? std::llround(*in.density * volume) : *in.count;
        sim::fill_random(out, t, in.lo, in.hi, count, init_block_seed(m.seed, k), next_id);
      } else {
        if (!in.density) throw ConfigError(where + ".density: missing");
        sim::fill_lattice(out, t, in.lo, in.hi, *in.density, next_id);
      }
      generated.resize(out.size(), 1);
      // Generated particles lie in their region, which lies in the box; checked all the same.
      for (size_t i = before_size; i < out.size(); ++i)
        for (double v :
             {out.x[i] - scene.box.lo[0], scene.box.hi[0] - out.x[i], out.y[i] - scene.box.lo[1],
              scene.box.hi[1] - out.y[i], out.z[i] - scene.box.lo[2], scene.box.hi[2] - out.z[i]})
          if (v < 0)
            throw ConfigError(where + ": particle " + std::to_string(out.id[i]) +
                              " lies outside the box " + box_text(scene.box));
    }
    if (static_cast<double>(out.size()) > kMaxParticles)
      throw ConfigError(where + ": the scene would hold more than " + num(kMaxParticles) +
                        " particles");
    throw_if_interrupted("during set-up (after " + indexed("init", k) +
                         "), before any step: nothing was written");
  }

  // Maxwell velocities for the generated particles only (file particles keep theirs); the
  // centre-of-mass velocity of the generated mobile particles is removed.
  sim::ParticleSet gen;
  for (size_t i = 0; i < out.size(); ++i)
    if (generated[i]) gen.add(out.x[i], out.y[i], out.z[i], 0, 0, 0, out.type[i], out.id[i]);
  if (gen.size() > 0) {
    sim::assign_maxwell_velocities(gen, m, m.kBT, init_velocity_seed(m.seed));
    size_t j = 0;
    for (size_t i = 0; i < out.size(); ++i)
      if (generated[i]) {
        out.vx[i] = gen.vx[j];
        out.vy[i] = gen.vy[j];
        out.vz[i] = gen.vz[j];
        ++j;
      }
  }
  return out;
}

}  // namespace mesorock::pipeline
