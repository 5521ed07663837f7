#pragma once
// The geometry of a spatial domain decomposition: one box region per rank, covering the global
// box without overlap. Regions come from equal slabs along one axis, or from recursive coordinate
// bisection (RCB) on a weight (the measured cost of each particle), so every rank gets about the
// same work rather than the same volume. Pure geometry: no MPI here, so it is tested directly.
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sim/model.h"

namespace mesorock::sim {

struct Region {
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  bool contains(const double x[3]) const {
    return x[0] >= lo[0] && x[0] < hi[0] && x[1] >= lo[1] && x[1] < hi[1] && x[2] >= lo[2] &&
           x[2] < hi[2];
  }
  double width(int a) const { return hi[static_cast<size_t>(a)] - lo[static_cast<size_t>(a)]; }
};

enum class DecompositionMethod { RCB, Slabs };
inline const char* to_string(DecompositionMethod m) {
  return m == DecompositionMethod::RCB ? "rcb" : "slabs";
}

struct DecompositionOptions {
  DecompositionMethod method = DecompositionMethod::RCB;
  std::uint32_t axes = 7;  // bit a: cuts across axis a allowed (RCB); slabs use the lowest bit
  // Steps between re-balancing (RCB on the measured cost); 0 = balance once, at the start.
  std::uint64_t rebalance_every = 1000;
  double halo = 1.1;  // ghost layer width: rc plus a skin for the wall model's small corrections
  // Build the decomposed solver even over one rank (benchmarks of its own cost).
  bool force = false;
};

class Decomposition {
 public:
  // The global weight along `axis` inside `region`, in `bins` equal bins (summed over every
  // rank's particles by the caller).
  using Histogram = std::function<std::vector<double>(const Region& region, int axis, int bins)>;

  // `ranks` equal slabs across the lowest axis of `axes`.
  static Decomposition slabs(const BoxSpec& box, int ranks, std::uint32_t axes);
  // Recursive coordinate bisection: each region is cut across its widest allowed axis so that
  // the two sides' weights are in the ratio of the ranks they get (floor(n/2) : ceil(n/2)).
  // Cuts stay at least `min_width` from a region's faces.
  static Decomposition rcb(const BoxSpec& box, int ranks, const Histogram& weight,
                           std::uint32_t axes, double min_width);

  int size() const { return static_cast<int>(regions_.size()); }
  const Region& region(int rank) const { return regions_[static_cast<size_t>(rank)]; }
  const std::vector<Region>& regions() const { return regions_; }
  // The rank whose region holds x (positions inside the global box); -1 if none.
  int owner(const double x[3]) const;
  std::string describe() const;

 private:
  std::vector<Region> regions_;
};

// A rank's ghost sends: for each destination rank, the boxes (in this rank's coordinates) whose
// owned particles become that rank's ghosts, and the shift (a periodic image) each one gets.
struct HaloTarget {
  int rank = 0;
  Region box;
  std::array<double, 3> shift{0, 0, 0};
};
// Every (rank, periodic image) whose region, widened by `halo`, reaches this rank's region.
// Images are taken along periodic axes only where the receiving region does not span the whole
// axis (a region that does keeps that axis periodic itself).
std::vector<HaloTarget> halo_targets(const Decomposition& d, const BoxSpec& box, int rank,
                                     double halo);

// Whether region r spans the whole box along axis a (then that axis stays as the box has it).
bool spans_axis(const Region& r, const BoxSpec& box, int a);

}  // namespace mesorock::sim
