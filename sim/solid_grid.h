#pragma once
// The solid of a porous sample as a plain grid: the voxels rockprep segmented (a SolidMask, one
// byte per voxel, written to solid.h5 beside the particles) and the signed distance to their
// surface (a SolidGrid), which the solver samples to keep fluid out of the grains.
//
// Why a distance field: frozen wall particles plus the wall model of Li et al. 2018 hold the
// fluid back only where the wall layer is thick and dense enough for phi to pass phi_c. Behind a
// one-voxel grain, at a corner or behind a layer that ends at a periodic face, phi never gets
// there, and real rock leaked 4% of its fluid deeper than 1 rc into the grains in 40,000 steps
// (docs/walls.md, "Fluid inside the grains"). The distance field marks the voxel surface itself,
// whatever the wall particles look like, so a particle that crosses it can be sent back
// (Mirheo's bounce-back on an SDF) and counted (the run-time leak invariant). sim/ stays free of
// OpenVDB: the grid is plain data.
//
// Conventions (the same as voxel::Volume and packing): voxel (i, j, k) along (x, y, z) covers
// [origin + (i, j, k) * voxel, origin + (i + 1, j + 1, k + 1) * voxel); storage is z-major,
// index (k * ny + j) * nx + i. The distance is in rc, positive inside the solid, negative in
// the pore, zero on the voxel faces between the two.
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/hd.h"

namespace mesorock::sim {

struct SolidMask {
  std::array<std::int64_t, 3> dims{0, 0, 0};  // voxels along x, y, z
  std::array<double, 3> voxel{1, 1, 1};       // voxel edges (x, y, z) in rc
  std::array<double, 3> origin{0, 0, 0};      // corner of voxel (0, 0, 0) in rc
  std::vector<std::uint8_t> solid;            // 1 = solid, 0 = pore; z-major
  double nm_per_rc = 0;                       // the length scale, 0 when the image has none

  std::int64_t voxels() const { return dims[0] * dims[1] * dims[2]; }
  std::size_t index(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return static_cast<std::size_t>((k * dims[1] + j) * dims[0] + i);
  }
  bool is_solid(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return solid[index(i, j, k)] != 0;
  }
  double porosity() const;
  // Throws ConfigError naming `what` when a dimension is not positive, a voxel edge is not
  // positive and finite, or the byte count does not match the dimensions.
  void check(const std::string& what) const;
};

// solid.h5: dataset /solid uint8 [nz, ny, nx] (1 = solid) with attributes voxel_rc (float64[3],
// x y z), origin_rc (float64[3]), nm_per_rc (float64; 0 = no physical scale), and on / the version,
// commit, created_by and provenance (JSON text). Written under a temporary name and renamed; every
// failure is an IoError naming the file and the dataset or attribute. The reader checks the
// declared sizes against the file before it allocates.
void write_solid_file(const std::filesystem::path& path, const SolidMask& mask,
                      const std::string& created_by, const std::string& provenance_json);
SolidMask read_solid_file(const std::filesystem::path& path);

// The kernels' view of a mask (device-copyable; the bytes in host or device memory). A point
// is in the solid when the voxel it lies in is solid: the staircase of the voxel faces itself,
// with no interpolation, so a one-voxel grain, a corner and the voxels at a periodic face or a
// mirror plane are solid exactly where the image says so. Along an axis where the grid spans a
// periodic box edge the indices wrap; elsewhere a point outside the grid is in the pore.
template <class Real>
struct SolidView {
  const std::uint8_t* solid = nullptr;  // null: no grid, nothing is checked
  int dims[3] = {0, 0, 0};
  Real origin[3] = {0, 0, 0};
  Real voxel[3] = {1, 1, 1};
  Real inv_voxel[3] = {1, 1, 1};
  bool periodic[3] = {false, false, false};
  bool bounce = true;           // mobile particles that drift into the solid are sent back
  Real stop_depth = Real(0.5);  // a mobile particle deeper than this stops the run (watchdog)
  int reach[3] = {2, 2, 2};     // voxels searched around a solid voxel for its depth

  MESO_HD MESO_INLINE bool enabled() const { return solid != nullptr; }

  // floor((p - origin) / voxel) along axis a: the raw index (not wrapped); false for a
  // coordinate so far out (or NaN) that it has no index.
  MESO_HD MESO_INLINE bool raw_index(Real p, int a, int& c) const {
    const Real u = (p - origin[a]) * inv_voxel[a];
    if (!(u > Real(-1e8) && u < Real(1e8))) return false;
    c = static_cast<int>(u);
    if (Real(c) > u) --c;
    return true;
  }
  // The stored index of raw index c along axis a: wrapped on a periodic axis; false outside a
  // non-periodic grid.
  MESO_HD MESO_INLINE bool stored_index(int c, int a, int& k) const {
    const int n = dims[a];
    if (periodic[a]) {
      c %= n;
      if (c < 0) c += n;
    } else if (c < 0 || c >= n) {
      return false;
    }
    k = c;
    return true;
  }
  MESO_HD MESO_INLINE bool solid_at(int i, int j, int k) const {
    int a, b, c;
    if (!stored_index(i, 0, a) || !stored_index(j, 1, b) || !stored_index(k, 2, c)) return false;
    return solid[(static_cast<std::size_t>(c) * dims[1] + b) * dims[0] + a] != 0;
  }
  MESO_HD MESO_INLINE bool in_solid(Real x, Real y, Real z) const {
    int i, j, k;
    if (!raw_index(x, 0, i) || !raw_index(y, 1, j) || !raw_index(z, 2, k)) return false;
    return solid_at(i, j, k);
  }

  // The squared distance from point p to voxel n (raw indices): 0 inside it.
  MESO_HD MESO_INLINE Real distance2_to_voxel(const Real p[3], const int n[3]) const {
    Real d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const Real lo = origin[a] + Real(n[a]) * voxel[a];
      const Real out = lo - p[a] > p[a] - lo - voxel[a] ? lo - p[a] : p[a] - lo - voxel[a];
      if (out > Real(0)) d2 += out * out;
    }
    return d2;
  }

  // How far the point lies inside the solid: the distance to the nearest pore voxel (0 in the
  // pore), exact up to `reach` voxels around it; a point deeper than the search can see gets
  // the search radius (a lower bound). Cheap in the pore (one byte), a small search only for a
  // point inside a solid voxel.
  MESO_HD Real depth(Real x, Real y, Real z) const {
    const Real p[3] = {x, y, z};
    int c[3];
    for (int a = 0; a < 3; ++a)
      if (!raw_index(p[a], a, c[a])) return Real(0);
    if (!solid_at(c[0], c[1], c[2])) return Real(0);
    Real limit = reach[0] * voxel[0];
    for (int a = 1; a < 3; ++a) limit = reach[a] * voxel[a] < limit ? reach[a] * voxel[a] : limit;
    Real best2 = limit * limit;
    for (int dk = -reach[2]; dk <= reach[2]; ++dk)
      for (int dj = -reach[1]; dj <= reach[1]; ++dj)
        for (int di = -reach[0]; di <= reach[0]; ++di) {
          const int n[3] = {c[0] + di, c[1] + dj, c[2] + dk};
          const Real d2 = distance2_to_voxel(p, n);
          if (d2 < best2 && !solid_at(n[0], n[1], n[2])) best2 = d2;
        }
    return real_sqrt(best2);
  }

  // Whether some pore voxel (or a point outside a non-periodic grid) lies closer than `distance`
  // to the point: false means the point is buried deeper than that in the solid. Searches the
  // voxels the sphere of that radius touches, and stops at the first pore one.
  MESO_HD bool pore_within(Real x, Real y, Real z, Real distance) const {
    const Real p[3] = {x, y, z};
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a)
      if (!raw_index(p[a] - distance, a, lo[a]) || !raw_index(p[a] + distance, a, hi[a]))
        return true;
    const Real limit2 = distance * distance;
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) {
          const int n[3] = {i, j, k};
          if (distance2_to_voxel(p, n) < limit2 && !solid_at(i, j, k)) return true;
        }
    return false;
  }
};

// What the model carries: the mask (shared, never copied per run) and the two choices.
struct SolidSpec {
  std::shared_ptr<const SolidMask> mask;  // null: no solid grid
  bool bounce = true;       // send mobile particles that drift into a solid voxel back
  double stop_depth = 0.5;  // rc; a mobile particle deeper than this stops the run (exit 3)
  // A run stops (exit 3) when more mobile particles than this are inside solid voxels at an
  // output row (the leak invariant, pipeline/flow/leak_invariant.h). With the bounce on none
  // ever is, so any count means a defect; a control run without the bounce raises it.
  std::uint64_t stop_count = 0;
};

struct BoxSpec;  // sim/model.h
// The kernels' view of the model's solid grid in this box (disabled without a grid): indices
// wrap along the periodic box edges the grid spans.
template <class Real>
SolidView<Real> solid_view_of(const SolidSpec& spec, const BoxSpec& box);

}  // namespace mesorock::sim
