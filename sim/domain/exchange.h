#pragma once
// What an engine offers a spatial domain decomposition (sim/domain/distributed.cpp), and what the
// decomposition offers back. A rank's engine holds its owned particles and, during a step,
// ghosts: copies of other ranks' particles within one cutoff of its region (origin < 0), which
// the step never moves and whose forces it never computes. Per step (the 2020 paper's Algorithm
// 1): kick-drift of the owned particles; exchange (migration to the new owners, then ghosts);
// density (and the wall model's phi) of the owned particles; their sync to the ghosts; [wall
// corrections, then fresh ghost positions and sums]; forces of the owned particles; kick.
//
// Engines implement DomainStore over their own storage (host vectors on the CPU, device buffers
// packed by kernels on the GPU); the decomposition implements StepHooks with MPI. A run without
// a decomposition has no hooks: the engines test one pointer per step, on the host.
#include <cstdint>
#include <vector>

#include "sim/hd.h"

namespace mesorock::sim {

// A particle that changes owner: the whole state the step carries from one step to the next.
template <class Real>
struct MigrantRecord {
  Real x[3], v[3], ve[3], f[3];
  std::int32_t type;
  std::int64_t id;
  std::uint8_t left_to_grid;  // StepView::left_to_grid (0 without it)
};

// A ghost: what the pair terms read of a particle (position, v~, type, id); its density and phi
// follow after the density pass (DomainStore::pack_sums).
template <class Real>
struct GhostRecord {
  Real x[3], ve[3];
  std::int32_t type;
  std::int64_t id;
};

// This rank's region [lo, hi) and the global box, for the migration test: a position is first
// wrapped across the global periodic faces, then kept when inside the region.
template <class Real>
struct LocalRegion {
  Real lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  Real global_lo[3] = {0, 0, 0}, global_length[3] = {0, 0, 0};
  bool periodic[3] = {true, true, true};

  MESO_HD MESO_INLINE void wrap(Real x[3]) const {
    for (int a = 0; a < 3; ++a) {
      if (!periodic[a]) continue;
      const Real hi_g = global_lo[a] + global_length[a];
      if (x[a] >= hi_g) x[a] -= global_length[a];
      if (x[a] < global_lo[a]) x[a] += global_length[a];
    }
  }
  MESO_HD MESO_INLINE bool contains(const Real x[3]) const {
    return x[0] >= lo[0] && x[0] < hi[0] && x[1] >= lo[1] && x[1] < hi[1] && x[2] >= lo[2] &&
           x[2] < hi[2];
  }
};

// Owned particles inside [lo, hi) become ghosts of another rank (or of a periodic image of this
// one) with their positions shifted by `shift`.
template <class Real>
struct HaloBox {
  Real lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  Real shift[3] = {0, 0, 0};

  MESO_HD MESO_INLINE bool contains(Real x, Real y, Real z) const {
    return x >= lo[0] && x < hi[0] && y >= lo[1] && y < hi[1] && z >= lo[2] && z < hi[2];
  }
};

template <class Real>
class DomainStore {
 public:
  virtual ~DomainStore() = default;
  virtual int owned_count() const = 0;
  // Drops the ghosts; takes the owned particles outside `region` (after wrapping them across the
  // global periodic faces) out of the storage into `leavers`. The remaining owned particles are
  // renumbered 0..n-1 in storage order (their slots).
  virtual void drop_ghosts_take_leavers(const LocalRegion<Real>& region,
                                        std::vector<MigrantRecord<Real>>& leavers) = 0;
  virtual void add_owned(const std::vector<MigrantRecord<Real>>& arrivals) = 0;
  // For each halo box in turn, the owned particles inside it as ghost records (shifted); counts
  // per box. Remembers the slots sent, in order: the send list of pack_sums and pack_refresh.
  virtual void pack_ghosts(const std::vector<HaloBox<Real>>& boxes,
                           std::vector<GhostRecord<Real>>& out, std::vector<int>& counts) = 0;
  // Appends ghosts; ghost k of `in` is found again by k (set_ghost_sums, set_ghost_refresh).
  virtual void add_ghosts(const std::vector<GhostRecord<Real>>& in) = 0;
  // Values per particle of pack_sums: rho, and phi with the wall model.
  virtual int sums_per_particle() const = 0;
  virtual void pack_sums(std::vector<Real>& out) = 0;
  virtual void set_ghost_sums(const std::vector<Real>& in) = 0;
  // After wall-model corrections moved owned particles: the send list again (position, v~).
  virtual void pack_refresh(std::vector<GhostRecord<Real>>& out) = 0;
  virtual void set_ghost_refresh(const std::vector<GhostRecord<Real>>& in) = 0;
};

// The decomposition's side of a step. Every call is collective: every rank makes it, in order.
template <class Real>
class StepHooks {
 public:
  virtual ~StepHooks() = default;
  virtual void exchange(DomainStore<Real>& store) = 0;        // migration, then ghosts
  virtual void sync_sums(DomainStore<Real>& store) = 0;       // ghosts' rho (and phi)
  virtual void refresh_ghosts(DomainStore<Real>& store) = 0;  // ghosts' positions and v~
  virtual bool any(bool local) = 0;                           // logical or over the ranks
  virtual void sum(double* values, int count) = 0;            // in place, over the ranks
  virtual std::uint64_t min(std::uint64_t value) = 0;         // over the ranks
  // False for a run on one rank (SerialHooks, sim/stepper.h), whose reductions are the identity:
  // a backend may then keep a reduction on the device instead of taking it to the host.
  virtual bool distributed() const = 0;
};

}  // namespace mesorock::sim
