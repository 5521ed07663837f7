#pragma once
// Binned observables: per-bin sums over particles on a regular grid of bins (a profile along one
// axis is a grid with one bin across the other two), and their time averages with block-averaging
// error bars. Nothing here allocates until a caller asks for bins.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sim/hd.h"

namespace mesorock::sim {

// The leak invariant of a run with a solid grid (sim/solid_grid.h): the mobile particles inside
// solid voxels, i.e. past the no-slip surface into a grain (rigid slabs are not counted), and the
// deepest of them.
struct SolidIntrusion {
  bool available = false;    // false: the run has no solid grid
  std::uint64_t inside = 0;  // mobile particles inside a solid voxel
  double max_depth = 0;      // how deep the deepest of them is, rc (0 when none is inside)
  std::int64_t deepest_id = -1;
  std::array<double, 3> deepest_position{0, 0, 0};
};

// What one bin accumulates per sample: the particle count, sum v and sum v*v per component.
enum BinField : int { kBinCount = 0, kBinVx, kBinVy, kBinVz, kBinVxx, kBinVyy, kBinVzz };
constexpr int kBinFields = 7;

// A regular grid of bins over [lo, hi); particles outside are not counted. type_mask selects the
// particle types counted (bit t for type t).
struct BinGrid {
  std::array<int, 3> cells{1, 1, 1};
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};
  std::uint32_t type_mask = 0xffffffffu;

  std::size_t count() const {
    return static_cast<std::size_t>(cells[0]) * static_cast<std::size_t>(cells[1]) *
           static_cast<std::size_t>(cells[2]);
  }
  double width(int a) const {
    return (hi[static_cast<size_t>(a)] - lo[static_cast<size_t>(a)]) /
           cells[static_cast<size_t>(a)];
  }
  double bin_volume() const { return width(0) * width(1) * width(2); }
  // A profile along `axis` with `bins` bins spanning [lo, hi) of the box.
  static BinGrid profile(int axis, int bins, const std::array<double, 3>& lo,
                         const std::array<double, 3>& hi) {
    BinGrid g;
    g.lo = lo;
    g.hi = hi;
    g.cells[static_cast<size_t>(axis)] = bins;
    return g;
  }
};

// The device-friendly form of a BinGrid for the kernel body (bin_of_particle in kernels.h).
template <class Real>
struct BinView {
  Real lo[3];
  Real inv_width[3];
  int cells[3];
  std::uint32_t type_mask;

  static BinView make(const BinGrid& g) {
    BinView b{};
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = static_cast<Real>(g.lo[static_cast<size_t>(a)]);
      b.inv_width[a] = static_cast<Real>(1.0 / g.width(a));
      b.cells[a] = g.cells[static_cast<size_t>(a)];
    }
    b.type_mask = g.type_mask;
    return b;
  }
  // Bin of a position (x fastest), or -1 outside the grid.
  MESO_HD int bin_of(Real x, Real y, Real z) const {
    const Real p[3] = {x, y, z};
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const Real s = (p[a] - lo[a]) * inv_width[a];
      if (!(s >= Real(0))) return -1;
      c[a] = static_cast<int>(s);
      if (c[a] >= cells[a]) return -1;
    }
    return (c[2] * cells[1] + c[1]) * cells[0] + c[0];
  }
};

// A quantity per bin with its error bar (one standard error of the time average).
struct BinnedQuantity {
  std::vector<double> mean, error;
};

// Time averages of binned sums, with error bars from block averages. The number of samples need
// not be known in advance: samples fill blocks of equal length; when `max_blocks` blocks are full,
// neighbouring blocks merge and the block length doubles, so between max_blocks / 2 and
// max_blocks blocks always exist once enough samples have come. The error of a derived quantity
// (density, velocity, temperature) is the standard error of its block values; it is 0 while fewer
// than 2 blocks are complete (blocks() says how many).
class BinnedAverage {
 public:
  explicit BinnedAverage(const BinGrid& grid, std::size_t max_blocks = 32)
      : grid_(grid), max_blocks_(max_blocks < 4 ? 4 : max_blocks) {}

  const BinGrid& grid() const { return grid_; }
  std::size_t samples() const { return samples_; }
  std::size_t blocks() const { return blocks_.size(); }

  // One sample: kBinFields sums per bin, as Simulation::bin_sums returns them.
  void add(const std::vector<double>& sums) {
    if (total_.empty()) {
      total_.assign(sums.size(), 0.0);
      current_.assign(sums.size(), 0.0);
    }
    for (std::size_t k = 0; k < sums.size(); ++k) {
      total_[k] += sums[k];
      current_[k] += sums[k];
    }
    ++samples_;
    if (++in_current_ == block_length_) {
      blocks_.push_back(current_);
      current_.assign(current_.size(), 0.0);
      in_current_ = 0;
      if (blocks_.size() == max_blocks_) merge_pairs();
    }
  }

  // Number density of the counted types.
  BinnedQuantity density() const {
    return derive([this](const double* s, double n) { return s[kBinCount] / (n * volume()); });
  }
  // Mean velocity component `axis` of the particles in the bin (0 where none came).
  BinnedQuantity velocity(int axis) const {
    return derive([axis](const double* s, double) {
      return s[kBinCount] > 0 ? s[kBinVx + axis] / s[kBinCount] : 0.0;
    });
  }
  // Its accumulators and block bookkeeping, for checkpoints: restoring them into an average of
  // the same grid continues it exactly.
  struct Saved {
    std::size_t max_blocks = 0, block_length = 1, in_current = 0, samples = 0;
    std::vector<double> total, current;
    std::vector<std::vector<double>> blocks;
  };
  Saved save() const {
    return Saved{max_blocks_, block_length_, in_current_, samples_, total_, current_, blocks_};
  }
  void restore(const Saved& s) {
    max_blocks_ = s.max_blocks;
    block_length_ = s.block_length;
    in_current_ = s.in_current;
    samples_ = s.samples;
    total_ = s.total;
    current_ = s.current;
    blocks_ = s.blocks;
  }

  // Kinetic temperature relative to the bin's mean velocity (m = 1):
  // T = (1/3) sum_a (<v_a^2> - <v_a>^2).
  BinnedQuantity temperature() const {
    return derive([](const double* s, double) {
      const double n = s[kBinCount];
      if (n <= 1) return 0.0;
      double t = 0;
      for (int a = 0; a < 3; ++a) {
        const double m = s[kBinVx + a] / n;
        t += s[kBinVxx + a] / n - m * m;
      }
      return t / 3.0;
    });
  }

 private:
  double volume() const { return grid_.bin_volume(); }

  void merge_pairs() {
    std::vector<std::vector<double>> merged;
    for (std::size_t b = 0; b + 1 < blocks_.size(); b += 2) {
      std::vector<double> m = blocks_[b];
      for (std::size_t k = 0; k < m.size(); ++k) m[k] += blocks_[b + 1][k];
      merged.push_back(std::move(m));
    }
    blocks_ = std::move(merged);
    block_length_ *= 2;
    // The partly filled block keeps its samples: it now needs twice as many to complete.
  }

  template <class F>
  BinnedQuantity derive(F f) const {
    BinnedQuantity q;
    const std::size_t nbins = grid_.count();
    q.mean.assign(nbins, 0.0);
    q.error.assign(nbins, 0.0);
    if (samples_ == 0) return q;
    for (std::size_t b = 0; b < nbins; ++b)
      q.mean[b] = f(&total_[b * kBinFields], static_cast<double>(samples_));
    const std::size_t nb = blocks_.size();
    if (nb < 2) return q;
    for (std::size_t b = 0; b < nbins; ++b) {
      double sum = 0, sum2 = 0;
      for (const auto& blk : blocks_) {
        const double v = f(&blk[b * kBinFields], static_cast<double>(block_length_));
        sum += v;
        sum2 += v * v;
      }
      const double m = sum / nb;
      const double var = (sum2 / nb - m * m) * nb / (nb - 1.0);
      q.error[b] = var > 0 ? std::sqrt(var / nb) : 0.0;
    }
    return q;
  }

  BinGrid grid_;
  std::size_t max_blocks_;
  std::size_t block_length_ = 1;
  std::size_t in_current_ = 0;
  std::size_t samples_ = 0;
  std::vector<double> total_, current_;
  std::vector<std::vector<double>> blocks_;
};

}  // namespace mesorock::sim
