#include "packing/flooding.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "mesorock/errors.h"
#include "voxel/phase_grids.h"
#include "voxel/pore_analysis.h"
#include "voxel/segment.h"
#include "voxel/walls.h"

namespace mesorock::packing {

const char* flooding_role_name(int role) {
  switch (role) {
    case kRoleBlockFluid:
      return "source fluid in the block";
    case kRoleInletFluid:
      return "working fluid (inlet reservoir)";
    case kRoleOutletFluid:
      return "source fluid (outlet reservoir)";
    case kRoleOrganicWall:
      return "organic wall";
    case kRoleInorganicWall:
      return "inorganic wall";
    case kRolePushSlab:
      return "pushing slab";
    case kRoleBackSlab:
      return "back-pressure slab";
    default:
      return "?";
  }
}

sim::SolidMask solid_mask_of(const VoxelLayout& L, double block_lo, double block_hi) {
  const voxel::Shape sh = L.codes.shape();
  sim::SolidMask m;
  m.dims = {sh.nx, sh.ny, sh.nz};
  m.voxel = L.voxel_rc;
  m.origin = L.origin;
  m.solid.resize(static_cast<std::size_t>(sh.voxels()));
  const auto* codes = L.codes.data<std::uint8_t>();
  const int a = L.flow_axis;
  const auto ka = static_cast<std::size_t>(a);
  for (std::int64_t z = 0; z < sh.nz; ++z)
    for (std::int64_t y = 0; y < sh.ny; ++y)
      for (std::int64_t x = 0; x < sh.nx; ++x) {
        const std::int64_t c[3] = {x, y, z};
        const std::size_t i = static_cast<std::size_t>((z * sh.ny + y) * sh.nx + x);
        const std::uint8_t code = codes[i];
        // The voxel's centre along the flow axis decides whether it lies in the block.
        const double along = L.origin[ka] + (static_cast<double>(c[a]) + 0.5) * L.voxel_rc[ka];
        const bool in_block = along >= block_lo && along < block_hi;
        m.solid[i] =
            code == kRoleOrganicWall || code == kRoleInorganicWall || (code == 0 && in_block);
      }
  return m;
}

std::int64_t drop_unconnected_pores(voxel::Volume& labels, int axis_zyx, int connectivity,
                                    std::int64_t* clusters_out, std::int64_t* spanning_out) {
  const voxel::PoreRuns runs = voxel::find_pore_runs(labels);
  voxel::ClusterOptions co;
  co.connectivity = connectivity;
  std::vector<voxel::Cluster> clusters;
  const std::vector<std::uint32_t> id = voxel::label_pore_runs(runs, co, &clusters);
  std::int64_t spanning = 0;
  for (const voxel::Cluster& c : clusters) spanning += c.spans(axis_zyx) ? 1 : 0;
  if (clusters_out) *clusters_out = static_cast<std::int64_t>(clusters.size());
  if (spanning_out) *spanning_out = spanning;
  const voxel::Shape s = labels.shape();
  std::uint8_t* v = labels.data<std::uint8_t>();
  std::int64_t dropped = 0;
  for (std::int64_t row = 0; row < s.nz * s.ny; ++row) {
    for (std::int64_t r = runs.row_begin[static_cast<std::size_t>(row)];
         r < runs.row_begin[static_cast<std::size_t>(row + 1)]; ++r) {
      const auto ur = static_cast<std::size_t>(r);
      if (clusters[id[ur]].spans(axis_zyx)) continue;
      for (std::int32_t x = runs.x_begin[ur]; x < runs.x_end[ur]; ++x) {
        std::uint8_t& c = v[row * s.nx + x];
        c = c == static_cast<std::uint8_t>(voxel::Phase::kOrganicPore)
                ? static_cast<std::uint8_t>(voxel::Phase::kOrganic)
                : static_cast<std::uint8_t>(voxel::Phase::kInorganic);
        ++dropped;
      }
    }
  }
  return dropped;
}

namespace {

int voxels_for(double length_rc, double h, const char* what) {
  if (!(length_rc >= 0) || !std::isfinite(length_rc))
    throw ConfigError(std::string("flooding: ") + what + " must be >= 0");
  return static_cast<int>(std::ceil(length_rc / h - 1e-9));
}

}  // namespace

void check_layout_inputs(const voxel::Volume& labels, int flow_axis,
                         const std::array<double, 3>& voxel_rc, const std::string& what) {
  if (labels.dtype() != voxel::DType::kUInt8)
    throw ConfigError(what + ": phase labels must be uint8");
  if (flow_axis < 0 || flow_axis > 2) throw ConfigError(what + ": flow axis must be x, y or z");
  for (double h : voxel_rc)
    if (!(h > 0) || !std::isfinite(h)) throw ConfigError(what + ": voxel edges must be positive");
  // Every phase code must be known before anything is counted.
  const std::uint8_t* p = labels.data<std::uint8_t>();
  for (std::int64_t i = 0; i < labels.voxels(); ++i)
    if (p[i] >= voxel::kPhaseCount)
      throw ConfigError(what + ": voxel " + std::to_string(i) + " holds " + std::to_string(p[i]) +
                        ", not a phase code");
}

void keep_spanning_pores_and_count(voxel::Volume& labels, int flow_axis, bool connected_only,
                                   int connectivity, const std::string& what,
                                   const std::string& faces, VoxelLayout& L) {
  if (connected_only) {
    L.pore_voxels_dropped = drop_unconnected_pores(labels, 2 - flow_axis, connectivity, &L.clusters,
                                                   &L.spanning_clusters);
    if (L.spanning_clusters == 0)
      throw ConfigError(what + ": no pore cluster joins " + faces + " along " + "xyz"[flow_axis] +
                        " (" + std::to_string(L.clusters) +
                        " clusters); choose another flow axis or crop, or keep every pore");
  }
  const voxel::PhaseCounts counts = voxel::count_phases(labels);
  L.pore_voxels = counts.voxels[1] + counts.voxels[4];
  L.solid_voxels = counts.voxels[2] + counts.voxels[3];
}

FloodingLayout build_flooding_layout(voxel::Volume labels, const FloodingOptions& o) {
  check_layout_inputs(labels, o.flow_axis, o.voxel_rc, "flooding");
  const int a = o.flow_axis;  // solver axis
  const int v = 2 - a;        // volume axis (z, y, x)
  const double h = o.voxel_rc[static_cast<std::size_t>(a)];
  const std::array<double, 3> voxel_zyx{o.voxel_rc[2], o.voxel_rc[1], o.voxel_rc[0]};
  const std::array<int, 3> layers = voxel::wall_layers(o.wall_thickness_rc, voxel_zyx);
  const int n_slab = std::max(1, voxels_for(o.slab_rc, h, "slab thickness"));
  const int n_in = std::max(layers[static_cast<std::size_t>(v)],
                            voxels_for(o.inlet_rc, h, "inlet reservoir length"));
  const int n_out = std::max(layers[static_cast<std::size_t>(v)],
                             voxels_for(o.outlet_rc, h, "outlet reservoir length"));

  FloodingLayout L;
  L.flow_axis = a;
  L.voxel_rc = o.voxel_rc;
  L.wall_layers_zyx = layers;
  const voxel::Shape bs = labels.shape();
  L.block_voxels = bs.voxels();
  keep_spanning_pores_and_count(labels, a, o.connected_only, o.connectivity, "flooding",
                                "the inlet and outlet faces", L);
  const std::int64_t extent[3] = {bs.nz, bs.ny, bs.nx};  // zyx
  double cross_rc2 = 1;  // the block's cross-section normal to the flow axis
  for (int k = 0; k < 3; ++k)
    if (k != v)
      cross_rc2 *= static_cast<double>(extent[k]) * voxel_zyx[static_cast<std::size_t>(k)];
  double room = o.room_rc;
  if (room < 0) {
    const double pore_rc3 =
        static_cast<double>(L.pore_voxels) * o.voxel_rc[0] * o.voxel_rc[1] * o.voxel_rc[2];
    room = pore_rc3 / cross_rc2 + 1.0;
  }
  const int n_room = voxels_for(room, h, "room behind the back slab");
  const std::int64_t before = n_slab + n_in, after = n_out + n_slab + n_room;

  // The extended volume: pore everywhere outside the block, so the block's solid faces against
  // the reservoirs become walls in the sweep.
  voxel::Shape es = bs;
  std::int64_t* ext_axis = v == 0 ? &es.nz : v == 1 ? &es.ny : &es.nx;
  *ext_axis += before + after;
  voxel::Volume ext(es, voxel::DType::kUInt8, labels.spacing());
  {
    std::uint8_t* e = ext.data<std::uint8_t>();
    std::memset(e, static_cast<int>(voxel::Phase::kPore), static_cast<std::size_t>(ext.voxels()));
    const std::uint8_t* b = labels.data<std::uint8_t>();
    const std::int64_t off[3] = {v == 0 ? before : 0, v == 1 ? before : 0, v == 2 ? before : 0};
    for (std::int64_t z = 0; z < bs.nz; ++z)
      for (std::int64_t y = 0; y < bs.ny; ++y)
        std::memcpy(e + ((z + off[0]) * es.ny + (y + off[1])) * es.nx + off[2],
                    b + (z * bs.ny + y) * bs.nx, static_cast<std::size_t>(bs.nx));
  }
  labels = voxel::Volume();

  voxel::WallSweep sweep;
  {
    voxel::PhaseGridOptions go;
    go.label_grid = voxel::LabelGridType::kNone;
    const openvdb::GridPtrVec masks = voxel::build_phase_grids(ext, go);
    voxel::WallOptions wo;
    wo.layers = layers;
    sweep = voxel::sweep_walls(masks, wo);
  }

  // Roles: fluid by position along the axis, solid to nothing, then the walls from the sweep.
  std::uint8_t* e = ext.data<std::uint8_t>();
  const std::int64_t block_begin = before, block_end = before + extent[v];
  auto role_at = [&](std::int64_t i) -> std::uint8_t {
    if (i < n_slab) return kRolePushSlab;
    if (i < block_begin) return kRoleInletFluid;
    if (i < block_end) return kRoleBlockFluid;
    if (i < block_end + n_out) return kRoleOutletFluid;
    if (i < block_end + n_out + n_slab) return kRoleBackSlab;
    return 0;
  };
  for (std::int64_t z = 0; z < es.nz; ++z)
    for (std::int64_t y = 0; y < es.ny; ++y) {
      std::uint8_t* row = e + (z * es.ny + y) * es.nx;
      for (std::int64_t x = 0; x < es.nx; ++x) {
        const std::int64_t i = v == 0 ? z : v == 1 ? y : x;
        const bool pore = voxel::is_pore_code(row[x]);
        row[x] = pore ? role_at(i) : 0;
      }
    }
  for (const auto& grid : sweep.walls) {
    const auto mask = openvdb::gridConstPtrCast<openvdb::MaskGrid>(grid);
    const std::uint8_t role = grid->getName() == "organic" ? kRoleOrganicWall : kRoleInorganicWall;
    for (auto it = mask->cbeginValueOn(); it; ++it) {
      const openvdb::CoordBBox box = it.getBoundingBox();
      for (int k = box.min().z(); k <= box.max().z(); ++k)
        for (int j = box.min().y(); j <= box.max().y(); ++j)
          for (int i = box.min().x(); i <= box.max().x(); ++i) {
            if (i < 0 || j < 0 || k < 0 || i >= es.nx || j >= es.ny || k >= es.nz) continue;
            e[(static_cast<std::int64_t>(k) * es.ny + j) * es.nx + i] = role;
          }
    }
  }
  for (std::int64_t i = 0; i < ext.voxels(); ++i) ++L.role_voxels[e[i]];

  // Geometry: the block's inlet face at 0 along the flow axis, its corner at 0 on the others.
  const std::array<std::int64_t, 3> n_xyz{es.nx, es.ny, es.nz};
  for (int k = 0; k < 3; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    L.origin[uk] = k == a ? -static_cast<double>(before) * h : 0.0;
    L.box.lo[uk] = L.origin[uk];
    L.box.hi[uk] = L.origin[uk] + static_cast<double>(n_xyz[uk]) * o.voxel_rc[uk];
    L.box.periodic[uk] = false;
    L.block_extent[uk] = static_cast<double>(extent[2 - k]) * o.voxel_rc[uk];
  }
  L.push_lo = L.box.lo[static_cast<std::size_t>(a)];
  L.push_hi = L.push_lo + n_slab * h;
  L.inlet_lo = L.push_hi;
  L.block_lo = 0;
  L.block_hi = static_cast<double>(extent[v]) * h;
  L.outlet_hi = L.block_hi + n_out * h;
  L.back_lo = L.outlet_hi;
  L.back_hi = L.back_lo + n_slab * h;
  L.codes = std::move(ext);
  return L;
}

}  // namespace mesorock::packing
