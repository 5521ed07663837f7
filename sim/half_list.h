#pragma once
// The CPU backend's half neighbour list: every pair within the list's cutoff once, in the list of
// its lower-stored particle, for passes that add each pair's result to both particles (Newton's
// third law; the pass bodies are in sim/kernels.h and sim/stepper.h).
//
// Why no atomics and no per-thread copies, and why the thread count changes no bit: the cells
// are grouped in blocks of at least 2 reach cells along each axis (one block on an axis too short
// for two), coloured by the parity of their block coordinates (8 colours). A block's pairs touch
// only particles in its cells and in the cells within reach of them, so two blocks of one colour
// never touch the same particle: they run in parallel, the colours one after another, and each
// block's particles in storage order. Every particle thus receives its pair terms in one order,
// fixed by the cell sort, whatever the thread count or scheduling.
//
// The list is built right after a cell sort, from that sort. Its separations are taken as minimum
// images when used, so with a cutoff of rc + skin it stays valid while no particle has moved more
// than skin / 2 (the stepper's re-sort rule). Pairs of two frozen particles go last in each list
// (the density pass needs them, the force pass stops before them); pairs of two ghosts are left
// out. With a frozen part (StepView::frozen_part: the CPU engine on one rank) the blocks hold the
// mobile particles only, so no list holds a pair of two frozen particles: their terms are in the
// frozen particles' static sums (begin_sums in sim/kernels.h).
#include <omp.h>

#include <array>
#include <cstddef>
#include <vector>

#include "sim/kernels.h"

namespace mesorock::sim {

template <class Real>
class HalfList {
 public:
  // Rebuilds the list from the current cell sort (v.cell_start) with the given cutoff.
  void build(const StepView<Real>& v, Real cutoff) {
    make_blocks(v);
    const Real cut2 = cutoff * cutoff;
    const int count = static_cast<int>(blocks_.size());
#pragma omp parallel for schedule(dynamic, 1)
    for (int b = 0; b < count; ++b) fill(v, blocks_[static_cast<size_t>(b)], cut2);
  }

  // pass.pairs(v, i, first, force_end, last) for every particle i, colour by colour, the blocks of
  // one colour in parallel. between() is called after each colour (the interrupt check of a
  // set-up).
  template <class Pass, class Between>
  void for_each_particle(const StepView<Real>& v, const Pass& pass, Between&& between) const {
    for (const std::vector<int>& colour : colours_) {
      const int count = static_cast<int>(colour.size());
#pragma omp parallel for schedule(dynamic, 1)
      for (int k = 0; k < count; ++k) {
        const Block& b = blocks_[static_cast<size_t>(colour[static_cast<size_t>(k)])];
        const int* list = b.neighbours.data();
        size_t p = 0;
        for (size_t r = 0; r < b.ranges.size(); r += 2)
          for (int i = b.ranges[r]; i < b.ranges[r + 1]; ++i, ++p)
            pass.pairs(v, i, list + b.offsets[p], list + b.force_ends[p], list + b.offsets[p + 1]);
      }
      between();
    }
  }

  // Stored pairs (for the memory budget and the benchmarks).
  std::size_t pair_count() const {
    std::size_t n = 0;
    for (const Block& b : blocks_) n += b.neighbours.size();
    return n;
  }

 private:
  struct Block {
    int first_cell[3] = {0, 0, 0}, last_cell[3] = {0, 0, 0};  // cells [first, last) per axis
    std::vector<int> ranges;      // its particles: [begin, end) storage ranges, one per cell row
    std::vector<int> offsets;     // per particle: its list in neighbours; one past the last
    std::vector<int> force_ends;  // per particle: where its frozen-frozen pairs begin
    std::vector<int> neighbours;
    std::vector<int> frozen_pairs;  // scratch
  };

  // Blocks per axis: an even number (the colours alternate around a periodic axis) of blocks at
  // least 2 reach cells wide, or one.
  static int blocks_along(int cells, int reach) {
    const int m = 2 * (cells / (4 * reach));
    return m < 2 ? 1 : m;
  }

  void make_blocks(const StepView<Real>& v) {
    const CellGrid<Real>& g = v.grid;
    int m[3];
    for (int a = 0; a < 3; ++a) m[a] = blocks_along(g.dims[a], g.reach);
    const std::array<int, 6> layout = {m[0], m[1], m[2], g.dims[0], g.dims[1], g.dims[2]};
    if (layout != layout_) {
      layout_ = layout;
      blocks_.assign(static_cast<size_t>(m[0]) * m[1] * m[2], Block{});
      for (auto& c : colours_) c.clear();
      size_t b = 0;
      for (int bz = 0; bz < m[2]; ++bz)
        for (int by = 0; by < m[1]; ++by)
          for (int bx = 0; bx < m[0]; ++bx, ++b) {
            const int k[3] = {bx, by, bz};
            for (int a = 0; a < 3; ++a) {
              blocks_[b].first_cell[a] =
                  static_cast<int>(static_cast<long>(k[a]) * g.dims[a] / m[a]);
              blocks_[b].last_cell[a] =
                  static_cast<int>(static_cast<long>(k[a] + 1) * g.dims[a] / m[a]);
            }
            colours_[static_cast<size_t>((bx & 1) | ((by & 1) << 1) | ((bz & 1) << 2))].push_back(
                static_cast<int>(b));
          }
    }
    for (Block& b : blocks_) {
      b.ranges.clear();
      for (int cz = b.first_cell[2]; cz < b.last_cell[2]; ++cz)
        for (int cy = b.first_cell[1]; cy < b.last_cell[1]; ++cy) {
          const int row = g.index(0, cy, cz);
          const int begin = v.cell_start[row + b.first_cell[0]];
          const int end = v.cell_start[row + b.last_cell[0]];
          if (begin < end) b.ranges.insert(b.ranges.end(), {begin, end});
        }
    }
  }

  static void fill(const StepView<Real>& v, Block& b, Real cut2) {
    b.offsets.clear();
    b.force_ends.clear();
    b.neighbours.clear();
    for (size_t r = 0; r < b.ranges.size(); r += 2)
      for (int i = b.ranges[r]; i < b.ranges[r + 1]; ++i) {
        b.offsets.push_back(static_cast<int>(b.neighbours.size()));
        b.frozen_pairs.clear();
        const bool frozen_i = v.frozen(i), ghost_i = v.ghost(i);
        for_each_candidate(v, i, [&](int j, Real, Real, Real, Real r2) {
          if (j <= i || !(r2 < cut2) || (ghost_i && v.ghost(j))) return;
          if (frozen_i && v.frozen(j))
            b.frozen_pairs.push_back(j);
          else
            b.neighbours.push_back(j);
        });
        b.force_ends.push_back(static_cast<int>(b.neighbours.size()));
        b.neighbours.insert(b.neighbours.end(), b.frozen_pairs.begin(), b.frozen_pairs.end());
      }
    b.offsets.push_back(static_cast<int>(b.neighbours.size()));
  }

  std::vector<Block> blocks_;
  std::array<std::vector<int>, 8> colours_;
  std::array<int, 6> layout_ = {0, 0, 0, 0, 0, 0};  // blocks and cells per axis
};

}  // namespace mesorock::sim
