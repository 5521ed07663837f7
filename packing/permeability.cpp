#include "packing/permeability.h"

#include <cmath>
#include <string>

#include "mesorock/errors.h"
#include "voxel/phase_grids.h"
#include "voxel/pore_analysis.h"
#include "voxel/segment.h"
#include "voxel/walls.h"

namespace mesorock::packing {

PermeabilityLayout build_permeability_layout(voxel::Volume labels, const PermeabilityOptions& o) {
  check_layout_inputs(labels, o.flow_axis, o.voxel_rc, "permeability layout");
  const int a = o.flow_axis;  // solver axis
  const int v = 2 - a;        // volume axis (z, y, x)
  const std::array<double, 3> voxel_zyx{o.voxel_rc[2], o.voxel_rc[1], o.voxel_rc[0]};
  const std::array<int, 3> layers = voxel::wall_layers(o.wall_thickness_rc, voxel_zyx);
  const voxel::Shape bs = labels.shape();
  const std::array<std::int64_t, 3> block_zyx{bs.nz, bs.ny, bs.nx};
  std::array<std::int64_t, 3> box_zyx = block_zyx;
  if (o.mirror) box_zyx[static_cast<std::size_t>(v)] *= 2;
  for (int k = 0; k < 3; ++k) {
    const double edge = static_cast<double>(box_zyx[static_cast<std::size_t>(k)]) *
                        voxel_zyx[static_cast<std::size_t>(k)];
    if (edge < 2.0)
      throw ConfigError(std::string("permeability layout: the periodic box is ") +
                        std::to_string(edge) + " rc along " + "zyx"[k] +
                        "; the solver needs at least 2 rc on a periodic axis (crop a larger "
                        "block or use more rc per voxel)");
  }

  PermeabilityLayout L;
  L.flow_axis = a;
  L.voxel_rc = o.voxel_rc;
  L.wall_layers_zyx = layers;
  L.mirrored = o.mirror;
  L.block_voxels = bs.voxels();
  keep_spanning_pores_and_count(labels, a, o.connected_only, o.connectivity, "permeability layout",
                                "the block's faces", L);

  // The box padded on every side by the wall layers with its periodic images: a box voxel c
  // along axis k comes from block voxel c (or, mirrored, 2n - 1 - c for c >= n), and a padded
  // voxel p from box voxel (p - pad) mod box.
  const std::array<std::int64_t, 3> pad{layers[0], layers[1], layers[2]};
  std::array<std::vector<std::int64_t>, 3> source;  // padded index -> block index, per axis
  for (std::size_t k = 0; k < 3; ++k) {
    const std::int64_t n = block_zyx[k], m = box_zyx[k];
    source[k].resize(static_cast<std::size_t>(m + 2 * pad[k]));
    for (std::int64_t p = 0; p < m + 2 * pad[k]; ++p) {
      const std::int64_t c = ((p - pad[k]) % m + m) % m;
      source[k][static_cast<std::size_t>(p)] = c < n ? c : 2 * n - 1 - c;
    }
  }
  const voxel::Shape ps{box_zyx[0] + 2 * pad[0], box_zyx[1] + 2 * pad[1], box_zyx[2] + 2 * pad[2]};
  voxel::Volume padded(ps, voxel::DType::kUInt8, labels.spacing());
  {
    std::uint8_t* d = padded.data<std::uint8_t>();
    const std::uint8_t* b = labels.data<std::uint8_t>();
    for (std::int64_t z = 0; z < ps.nz; ++z)
      for (std::int64_t y = 0; y < ps.ny; ++y) {
        const std::uint8_t* row = b + (source[0][static_cast<std::size_t>(z)] * bs.ny +
                                       source[1][static_cast<std::size_t>(y)]) *
                                          bs.nx;
        std::uint8_t* out = d + (z * ps.ny + y) * ps.nx;
        for (std::int64_t x = 0; x < ps.nx; ++x)
          out[x] = row[source[2][static_cast<std::size_t>(x)]];
      }
  }
  labels = voxel::Volume();

  voxel::WallSweep sweep;
  {
    voxel::PhaseGridOptions go;
    go.label_grid = voxel::LabelGridType::kNone;
    const openvdb::GridPtrVec masks = voxel::build_phase_grids(padded, go);
    voxel::WallOptions wo;
    wo.layers = layers;
    sweep = voxel::sweep_walls(masks, wo);
  }

  // Roles over the box (the padded volume's centre): pores to fluid, solid to nothing, then the
  // walls from the sweep.
  const voxel::Shape es{box_zyx[0], box_zyx[1], box_zyx[2]};
  voxel::Volume codes(es, voxel::DType::kUInt8, padded.spacing());
  std::uint8_t* e = codes.data<std::uint8_t>();
  {
    const std::uint8_t* d = padded.data<std::uint8_t>();
    for (std::int64_t z = 0; z < es.nz; ++z)
      for (std::int64_t y = 0; y < es.ny; ++y) {
        const std::uint8_t* in = d + ((z + pad[0]) * ps.ny + (y + pad[1])) * ps.nx + pad[2];
        std::uint8_t* out = e + (z * es.ny + y) * es.nx;
        for (std::int64_t x = 0; x < es.nx; ++x)
          out[x] = voxel::is_pore_code(in[x]) ? kRoleBlockFluid : 0;
      }
  }
  padded = voxel::Volume();
  for (const auto& grid : sweep.walls) {
    const auto mask = openvdb::gridConstPtrCast<openvdb::MaskGrid>(grid);
    const std::uint8_t role = grid->getName() == "organic" ? kRoleOrganicWall : kRoleInorganicWall;
    for (auto it = mask->cbeginValueOn(); it; ++it) {
      const openvdb::CoordBBox box = it.getBoundingBox();
      for (int k = box.min().z(); k <= box.max().z(); ++k)
        for (int j = box.min().y(); j <= box.max().y(); ++j)
          for (int i = box.min().x(); i <= box.max().x(); ++i) {
            const std::int64_t x = i - pad[2], y = j - pad[1], z = k - pad[0];
            if (x < 0 || y < 0 || z < 0 || x >= es.nx || y >= es.ny || z >= es.nz) continue;
            e[(z * es.ny + y) * es.nx + x] = role;
          }
    }
  }
  for (std::int64_t i = 0; i < codes.voxels(); ++i) ++L.role_voxels[e[i]];

  const std::array<std::int64_t, 3> n_xyz{es.nx, es.ny, es.nz};
  for (std::size_t k = 0; k < 3; ++k) {
    L.origin[k] = 0.0;
    L.box.lo[k] = 0.0;
    L.box.hi[k] = static_cast<double>(n_xyz[k]) * o.voxel_rc[k];
    L.box.periodic[k] = true;
    L.block_extent[k] = static_cast<double>(block_zyx[2 - k]) * o.voxel_rc[k];
  }
  L.codes = std::move(codes);
  return L;
}

}  // namespace mesorock::packing
