#include "pipeline/prep/flooding_scene.h"

#include <charconv>
#include <cstdio>
#include <sstream>

namespace mesorock::pipeline::prep {

namespace {

// The shortest text that reads back to the same double, always with a decimal point or an
// exponent so that TOML reads a float.
std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, r.ptr);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string vec(const std::array<double, 3>& v) {
  return "[" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + "]";
}

// A TOML basic string: a '"' or '\' in a name (the --out folder's) gave a scene that rockflow
// could not parse; control characters are written as \uXXXX.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20 || c == 0x7f) {
      char u[8];
      std::snprintf(u, sizeof u, "\\u%04x", c);
      out += u;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

std::string list(const std::vector<std::string>& names) {
  std::string s = "[";
  for (std::size_t i = 0; i < names.size(); ++i) s += (i ? ", " : "") + quoted(names[i]);
  return s + "]";
}

bool is_wall(const std::string& t) {
  return t == "organic_wall" || t == "inorganic_wall";
}
bool is_fluid(const std::string& t) {
  return t == "source" || t == "working";
}

}  // namespace

// The head of both scenes: comment lines, name, seed, box with one boundary kind on every face,
// the mDPD model with the thermostat.
template <class Params>
void write_scene_head(std::ostream& s, const Params& p, const sim::BoxSpec& box,
                      const std::string& boundary) {
  std::istringstream comment(p.comment);
  for (std::string line; std::getline(comment, line);) s << "# " << line << "\n";
  const std::string b = quoted(boundary);
  s << "name = " << quoted(p.name) << "\n"
    << "seed = " << p.seed << "\n\n"
    << "[box]\n"
    << "lo = " << vec(box.lo) << "\n"
    << "hi = " << vec(box.hi) << "\n"
    << "boundary = [" << b << ", " << b << ", " << b << "]\n\n"
    << "[model]\n"
    << "conservative = \"mdpd\"\n"
    << "density_kernel = " << quoted(p.density_kernel) << "\n"
    << "rd = " << num(p.rd) << "\n"
    << "thermostat = true\n"
    << "kBT = " << num(p.kBT) << "\n\n";
}

// Every unordered type pair once with A from a_of(t, u), and the wall model over `walls`.
template <class Params, class AOf>
void write_pairs_and_walls(std::ostream& s, const Params& p, AOf a_of,
                           const std::vector<std::string>& walls) {
  for (std::size_t i = 0; i < p.type_names.size(); ++i)
    for (std::size_t j = i; j < p.type_names.size(); ++j) {
      const std::string& t = p.type_names[i];
      const std::string& u = p.type_names[j];
      s << "[[pairs]]\ntypes = [" << quoted(t) << ", " << quoted(u) << "]\n"
        << "A = " << num(a_of(t, u)) << "\nB = " << num(p.B) << "\ngamma = " << num(p.gamma)
        << "\n\n";
    }
  if (!walls.empty()) {
    s << "[walls]  # the boundary model of Li et al. 2018 (docs/walls.md)\n"
      << "model = \"li2018\"\n"
      << "types = " << list(walls) << "\n"
      << "wall_density = " << num(p.wall_density) << "  # the packed walls' particle density\n\n";
  }
  if (!p.solid_file.empty())
    s << "[solid]  # the solid's voxels: fluid that drifts into them is sent back, and counted\n"
      << "file = " << quoted(p.solid_file) << "\n\n";
}

std::string flooding_scene_toml(const packing::FloodingLayout& L, const FloodingSceneParams& p) {
  std::ostringstream s;
  write_scene_head(s, p, L.box, "reflective");
  const char* axis = L.flow_axis == 0 ? "x" : L.flow_axis == 1 ? "y" : "z";
  std::vector<std::string> walls;
  for (const std::string& t : p.type_names) {
    s << "[[types]]\nname = " << quoted(t) << "\n";
    if (is_wall(t)) {
      s << "frozen = true\n";
      walls.push_back(t);
    }
    s << "\n";
  }
  // Pairs: every unordered pair once.
  auto a_of = [&](const std::string& t, const std::string& u) {
    if (is_fluid(t) && is_fluid(u)) return p.a_fluid;
    const std::string& other = is_fluid(t) ? u : t;
    if (is_fluid(t) || is_fluid(u)) {
      if (other == "organic_wall") return p.a_organic;
      if (other == "inorganic_wall") return p.a_inorganic;
      return p.a_fluid;  // fluid against a slab: the fluid's own attraction
    }
    return p.a_wall;
  };
  write_pairs_and_walls(s, p, a_of, walls);
  const std::uint64_t flood_from = p.relax_steps + p.settle_steps;
  s << "# The block's inlet face: working fluid stays before it and source fluid after it until\n"
    << "# flooding starts at step " << flood_from << ".\n"
    << "[[virtual_walls]]\naxis = " << quoted(axis) << "\nposition = " << num(L.block_lo)
    << "\ntypes = [\"working\"]\nkeep = \"below\"\nuntil_step = " << flood_from << "\n\n"
    << "[[virtual_walls]]\naxis = " << quoted(axis) << "\nposition = " << num(L.block_lo)
    << "\ntypes = [\"source\"]\nkeep = \"above\"\nuntil_step = " << flood_from << "\n\n";
  s << "[[slabs]]  # pushes the working fluid towards +" << axis
    << "\ntype = \"push_slab\"\naxis = " << quoted(axis) << "\npressure = " << num(p.push_pressure)
    << "\n\n"
    << "[[slabs]]  # holds the source fluid's pressure from the outlet side\ntype = "
       "\"back_slab\"\naxis = "
    << quoted(axis) << "\npressure = " << num(-p.back_pressure) << "\n\n";
  s << "[[init]]\nkind = \"file\"\nfile = " << quoted(p.particle_file) << "\n\n";
  s << "[[run]]\nname = \"relax\"\nsteps = " << p.relax_steps << "\ndt = " << num(p.relax_dt)
    << "\n\n"
    << "[[run]]\nname = \"settle\"\nsteps = " << p.settle_steps << "\ndt = " << num(p.dt) << "\n\n"
    << "[[run]]\nname = \"flood\"\nsteps = " << p.flood_steps << "\ndt = " << num(p.dt) << "\n\n";
  s << "[output]\nthermo_every = " << p.thermo_every << "\nsnapshot_every = " << p.snapshot_every
    << "\naverage_stages = [\"flood\"]\n\n";
  // Regions: the block (saturation and recovery of the source fluid), and one voxel layer at
  // each face of the block (the flow rate through the faces).
  const auto a = static_cast<std::size_t>(L.flow_axis);
  std::array<double, 3> lo{0, 0, 0}, hi = L.block_extent;
  const double layer = L.voxel_rc[a];
  auto region = [&](const std::string& name, double from, double to, bool saturation) {
    std::array<double, 3> rl = lo, rh = hi;
    rl[a] = from;
    rh[a] = to;
    s << "[[output.regions]]\nname = " << quoted(name) << "\nlo = " << vec(rl)
      << "\nhi = " << vec(rh) << "\nevery = " << p.region_every
      << "\ntypes = [\"source\", \"working\"]\n";
    if (saturation) s << "saturation_of = \"source\"\n";
    s << "\n";
  };
  region("block", L.block_lo, L.block_hi, true);
  region("inlet", L.block_lo, L.block_lo + layer, false);
  region("outlet", L.block_hi - layer, L.block_hi, false);
  if (p.nm_per_rc > 0) s << "[units]\nnm_per_rc = " << num(p.nm_per_rc) << "\n";
  return s.str();
}

std::string permeability_scene_toml(const packing::PermeabilityLayout& L,
                                    const PermeabilitySceneParams& p) {
  std::ostringstream s;
  write_scene_head(s, p, L.box, "periodic");
  const auto a = static_cast<std::size_t>(L.flow_axis);
  std::vector<std::string> walls;
  for (const std::string& t : p.type_names) {
    s << "[[types]]\nname = " << quoted(t) << "\n";
    if (t == p.fluid_type) {
      std::array<double, 3> force{0, 0, 0};
      force[a] = p.body_force;
      s << "body_force = " << vec(force) << "  # drives the flow; rockflow sweep sets its own\n";
    } else {
      s << "frozen = true\n";
      walls.push_back(t);
    }
    s << "\n";
  }
  auto a_of = [&](const std::string& t, const std::string& u) {
    if (t == p.fluid_type && u == p.fluid_type) return p.a_fluid;
    if (t != p.fluid_type && u != p.fluid_type) return p.a_wall;
    const std::string& wall = t == p.fluid_type ? u : t;
    return wall == "organic_wall" ? p.a_organic : p.a_inorganic;
  };
  write_pairs_and_walls(s, p, a_of, walls);
  s << "[[init]]\nkind = \"file\"\nfile = " << quoted(p.particle_file) << "\n\n";
  s << "[[run]]\nname = \"relax\"\nsteps = " << p.relax_steps << "\ndt = " << num(p.relax_dt)
    << "\n\n"
    << "[[run]]\nname = \"flow\"\nsteps = " << p.flow_steps << "\ndt = " << num(p.dt) << "\n\n";
  s << "[output]\nthermo_every = " << p.thermo_every << "\nsnapshot_every = " << p.snapshot_every
    << "\naverage_stages = [\"flow\"]\n\n";
  // The block (its first copy when mirrored): fluid count and flow rate.
  s << "[[output.regions]]\nname = \"block\"\nlo = " << vec({0, 0, 0})
    << "\nhi = " << vec(L.block_extent) << "\nevery = " << p.region_every << "\ntypes = ["
    << quoted(p.fluid_type) << "]\n\n";
  // Mirrored: also the whole box, whose flow rate is the flux rockflow sweep measures. At no
  // force the block and its mirror image carry slow opposite flows that the box's sum cancels
  // (docs/permeability.md, "The scene's own flow").
  if (L.mirrored)
    s << "[[output.regions]]\nname = \"box\"\nlo = " << vec(L.box.lo) << "\nhi = " << vec(L.box.hi)
      << "\nevery = " << p.region_every << "\ntypes = [" << quoted(p.fluid_type) << "]\n\n";
  if (p.nm_per_rc > 0) s << "[units]\nnm_per_rc = " << num(p.nm_per_rc) << "\n";
  return s.str();
}

}  // namespace mesorock::pipeline::prep
