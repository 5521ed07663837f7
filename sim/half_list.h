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
//
// The fill was half of a CPU step, so it is lean: a cell's stencil is found once as runs of
// storage (stencil_runs), each particle of the cell walks them from the first candidate stored
// after it (half a full scan), and keeps candidates without a branch (KeptList).
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

  // A run of a cell's stencil: the particles [first, end) of consecutive cells of one row along
  // x in one part, and the shift of their periodic image.
  struct Run {
    int first = 0, end = 0;
    Real shift[3] = {0, 0, 0};
  };
  // The runs for_each_candidate scans for a particle of cell (cx, cy, cz) over Parts::All, in
  // its order (HalfList.CellRunsAreTheCandidateScan pins the two together); image[a]: the
  // minimum image per pair along axis a. The fill finds them once per cell, not per particle.
  // (It repeats for_each_candidate's loops instead of sharing a stencil struct with it: sharing
  // one changed the PTX of 27 GPU kernels, 2026-12-05, with no device to measure what it does.)
  static void stencil_runs(const StepView<Real>& v, const int c[3], std::vector<Run>& runs,
                           bool image[3]) {
    const CellGrid<Real>& g = v.grid;
    typename CellGrid<Real>::AxisRange r[3];
    for (int a = 0; a < 3; ++a) {
      r[a] = g.axis_range(c[a], a, v.box.periodic[a]);
      image[a] = r[a].all || v.stale_cells;
    }
    const int nx = g.dims[0];
    const int x_first[3] = {r[0].begin + nx, r[0].begin < 0 ? 0 : r[0].begin, 0};
    const int x_last[3] = {nx, r[0].end > nx ? nx : r[0].end, r[0].end - nx};
    const Real x_shift[3] = {-v.box.length[0], Real(0), v.box.length[0]};
    const int parts = v.frozen_part == 0 ? 1 : 2;  // mobile, then frozen; or everything
    runs.clear();
    for (int kz = r[2].begin; kz < r[2].end; ++kz) {
      Real sz;
      const int wz = g.wrap(kz, 2, v.box.length[2], sz);
      for (int ky = r[1].begin; ky < r[1].end; ++ky) {
        Real sy;
        const int wy = g.wrap(ky, 1, v.box.length[1], sy);
        const int row = g.index(0, wy, wz);
        for (int k = 0; k < 3; ++k) {
          if (x_first[k] >= x_last[k]) continue;
          for (int part = 0; part < parts; ++part) {
            const int base = row + part * v.frozen_part;
            runs.push_back({v.cell_start[base + x_first[k]],
                            v.cell_start[base + x_last[k]],
                            {x_shift[k], sy, sz}});
          }
        }
      }
    }
  }

  // Calls keep(j, r2) for every candidate j > i of particle i in `runs` (a run is contiguous in
  // storage, so its candidates j <= i are skipped by starting it past i: half the candidates of a
  // full scan, never looked at). kImage: some axis takes the minimum image per pair.
  template <bool kImage, class Keep>
  static void scan_runs(const StepView<Real>& v, int i, const std::vector<Run>& runs,
                        const bool image[3], Keep&& keep) {
    const Real xi = v.x[i], yi = v.y[i], zi = v.z[i];
    for (const Run& run : runs) {
      for (int j = run.first > i ? run.first : i + 1; j < run.end; ++j) {
        Real dx = (xi - v.x[j]) - run.shift[0];
        Real dy = (yi - v.y[j]) - run.shift[1];
        Real dz = (zi - v.z[j]) - run.shift[2];
        if constexpr (kImage) {
          if (image[0]) dx = v.box.minimum_image(dx, 0);
          if (image[1]) dy = v.box.minimum_image(dy, 1);
          if (image[2]) dz = v.box.minimum_image(dz, 2);
        }
        keep(j, dx * dx + dy * dy + dz * dz);
      }
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
    std::vector<Run> runs;          // scratch: a cell's stencil
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

  // Appends to a list without branching on whether a candidate is kept: each candidate is
  // written past the end, and the end moves on only if it is kept. Why: about one candidate in
  // six is kept, in no order a branch predictor can follow, and the mispredictions cost more than
  // the distance tests (the fill ran 3x slower with a branch; docs/benchmarks.md).
  class KeptList {
   public:
    explicit KeptList(std::vector<int>& out) : out_(out) { grow(out.capacity()); }
    ~KeptList() { out_.resize(size_); }
    KeptList(const KeptList&) = delete;
    KeptList& operator=(const KeptList&) = delete;
    void push_if(int j, bool keep) {
      if (size_ == capacity_) grow(2 * size_ + 256);  // rarely: predicted
      data_[size_] = j;
      size_ += keep;
    }
    void append(const KeptList& more) {
      for (std::size_t k = 0; k < more.size_; ++k) push_if(more.data_[k], true);
    }
    void clear() { size_ = 0; }
    int size() const { return static_cast<int>(size_); }

   private:
    void grow(std::size_t capacity) {
      out_.resize(capacity);
      data_ = out_.data();
      capacity_ = out_.size();
    }
    std::vector<int>& out_;
    int* data_ = nullptr;
    std::size_t size_ = 0, capacity_ = 0;
  };

  // The block's lists, cell by cell: each particle's pairs with the candidates stored after it.
  static void fill(const StepView<Real>& v, Block& b, Real cut2) {
    b.offsets.clear();
    b.force_ends.clear();
    KeptList near(b.neighbours), frozen_pairs(b.frozen_pairs);
    const CellGrid<Real>& g = v.grid;
    for (int cz = b.first_cell[2]; cz < b.last_cell[2]; ++cz)
      for (int cy = b.first_cell[1]; cy < b.last_cell[1]; ++cy)
        for (int cx = b.first_cell[0]; cx < b.last_cell[0]; ++cx) {
          const int c[3] = {cx, cy, cz};
          const int cell = g.index(cx, cy, cz);
          if (v.cell_start[cell] == v.cell_start[cell + 1]) continue;
          bool image[3];
          stencil_runs(v, c, b.runs, image);
          const bool any_image = image[0] || image[1] || image[2];
          for (int i = v.cell_start[cell]; i < v.cell_start[cell + 1]; ++i) {
            b.offsets.push_back(near.size());
            frozen_pairs.clear();
            const bool frozen_i = v.frozen(i), ghost_i = v.ghost(i);
            // Bitwise on the bools: no branch on the distance test. Without a frozen part a
            // frozen particle's pairs with frozen ones go last (the density pass alone needs
            // them); pairs of two ghosts are left out.
            auto keep_near = [&](int j, Real r2) { near.push_if(j, r2 < cut2); };
            auto keep_sorted = [&](int j, Real r2) {
              const bool keep = (r2 < cut2) & !(ghost_i && v.ghost(j));
              const bool both_frozen = frozen_i && v.frozen(j);
              near.push_if(j, keep & !both_frozen);
              frozen_pairs.push_if(j, keep & both_frozen);
            };
            auto scan = [&](auto&& keep) {
              if (any_image)
                scan_runs<true>(v, i, b.runs, image, keep);
              else
                scan_runs<false>(v, i, b.runs, image, keep);
            };
            if (frozen_i || ghost_i)
              scan(keep_sorted);
            else
              scan(keep_near);
            b.force_ends.push_back(near.size());
            near.append(frozen_pairs);
          }
        }
    b.offsets.push_back(near.size());
  }

  std::vector<Block> blocks_;
  std::array<std::vector<int>, 8> colours_;
  std::array<int, 6> layout_ = {0, 0, 0, 0, 0, 0};  // blocks and cells per axis
};

}  // namespace mesorock::sim
