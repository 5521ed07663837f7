#include "sim/domain/decomposition.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "mesorock/errors.h"

namespace mesorock::sim {

namespace {

Region whole(const BoxSpec& box) {
  Region r;
  r.lo = box.lo;
  r.hi = box.hi;
  return r;
}

int lowest_axis(std::uint32_t axes) {
  for (int a = 0; a < 3; ++a)
    if ((axes >> a) & 1u) return a;
  throw ConfigError("decomposition: no axis allowed for cuts");
}

// Where to cut `region` across `axis` so that the weight below is `fraction` of the region's
// total: the cumulative weight over fine bins, interpolated inside the bin where it crosses.
double weighted_cut(const Region& region, int axis, double fraction,
                    const Decomposition::Histogram& weight, double min_width) {
  constexpr int kBins = 1024;
  const std::vector<double> h = weight(region, axis, kBins);
  double total = 0;
  for (double w : h) total += w;
  const double lo = region.lo[static_cast<size_t>(axis)];
  const double width = region.width(axis);
  double cut = lo + fraction * width;  // no weight at all: cut by volume
  if (total > 0) {
    const double target = fraction * total;
    double below = 0;
    for (int b = 0; b < kBins; ++b) {
      const double w = h[static_cast<size_t>(b)];
      if (below + w >= target) {
        const double t = w > 0 ? (target - below) / w : 0.0;
        cut = lo + (b + t) * width / kBins;
        break;
      }
      below += w;
    }
  }
  const double margin = std::min(min_width, 0.5 * width);
  return std::clamp(cut, lo + margin, lo + width - margin);
}

void bisect(const Region& region, int ranks, const Decomposition::Histogram& weight,
            std::uint32_t axes, double min_width, std::vector<Region>& out) {
  if (ranks == 1) {
    out.push_back(region);
    return;
  }
  int axis = -1;
  for (int a = 0; a < 3; ++a)
    if (((axes >> a) & 1u) && (axis < 0 || region.width(a) > region.width(axis))) axis = a;
  const int left = ranks / 2;
  const double cut =
      weighted_cut(region, axis, static_cast<double>(left) / ranks, weight, min_width);
  Region a = region, b = region;
  a.hi[static_cast<size_t>(axis)] = cut;
  b.lo[static_cast<size_t>(axis)] = cut;
  bisect(a, left, weight, axes, min_width, out);
  bisect(b, ranks - left, weight, axes, min_width, out);
}

}  // namespace

Decomposition Decomposition::slabs(const BoxSpec& box, int ranks, std::uint32_t axes) {
  if (ranks < 1) throw ConfigError("decomposition: at least one rank");
  const int a = lowest_axis(axes);
  Decomposition d;
  const double lo = box.lo[static_cast<size_t>(a)], width = box.length(a) / ranks;
  for (int r = 0; r < ranks; ++r) {
    Region g = whole(box);
    g.lo[static_cast<size_t>(a)] = lo + r * width;
    g.hi[static_cast<size_t>(a)] =
        r + 1 == ranks ? box.hi[static_cast<size_t>(a)] : lo + (r + 1) * width;
    d.regions_.push_back(g);
  }
  return d;
}

Decomposition Decomposition::rcb(const BoxSpec& box, int ranks, const Histogram& weight,
                                 std::uint32_t axes, double min_width) {
  if (ranks < 1) throw ConfigError("decomposition: at least one rank");
  lowest_axis(axes);
  Decomposition d;
  bisect(whole(box), ranks, weight, axes, min_width, d.regions_);
  return d;
}

int Decomposition::owner(const double x[3]) const {
  for (size_t r = 0; r < regions_.size(); ++r)
    if (regions_[r].contains(x)) return static_cast<int>(r);
  return -1;
}

std::string Decomposition::describe() const {
  std::ostringstream s;
  s.precision(4);
  for (size_t r = 0; r < regions_.size(); ++r) {
    const Region& g = regions_[r];
    s << (r ? "; " : "") << "rank " << r << ": [" << g.lo[0] << ", " << g.hi[0] << ") x ["
      << g.lo[1] << ", " << g.hi[1] << ") x [" << g.lo[2] << ", " << g.hi[2] << ")";
  }
  return s.str();
}

bool spans_axis(const Region& r, const BoxSpec& box, int a) {
  return r.lo[static_cast<size_t>(a)] <= box.lo[static_cast<size_t>(a)] &&
         r.hi[static_cast<size_t>(a)] >= box.hi[static_cast<size_t>(a)];
}

std::vector<HaloTarget> halo_targets(const Decomposition& d, const BoxSpec& box, int rank,
                                     double halo) {
  std::vector<HaloTarget> out;
  const Region& mine = d.region(rank);
  for (int q = 0; q < d.size(); ++q) {
    const Region& other = d.region(q);
    // Images along the periodic axes the receiver splits.
    int range[3][2];
    for (int a = 0; a < 3; ++a) {
      const bool images = box.periodic[static_cast<size_t>(a)] && !spans_axis(other, box, a);
      range[a][0] = images ? -1 : 0;
      range[a][1] = images ? 1 : 0;
    }
    for (int i = range[0][0]; i <= range[0][1]; ++i)
      for (int j = range[1][0]; j <= range[1][1]; ++j)
        for (int k = range[2][0]; k <= range[2][1]; ++k) {
          if (q == rank && i == 0 && j == 0 && k == 0) continue;  // its own particles
          HaloTarget t;
          t.rank = q;
          const int n[3] = {i, j, k};
          bool empty = false;
          for (int a = 0; a < 3; ++a) {
            const size_t s = static_cast<size_t>(a);
            t.shift[s] = n[a] * box.length(a);
            // Particles at p with p + shift within the widened region of q, inside my region.
            // Along an axis the receiver spans, it sees every position (no widening needed).
            const bool whole_axis = spans_axis(other, box, a);
            const double lo = whole_axis ? other.lo[s] : other.lo[s] - halo;
            const double hi = whole_axis ? other.hi[s] : other.hi[s] + halo;
            t.box.lo[s] = std::max(mine.lo[s], lo - t.shift[s]);
            t.box.hi[s] = std::min(mine.hi[s], hi - t.shift[s]);
            empty = empty || !(t.box.hi[s] > t.box.lo[s]);
          }
          if (!empty) out.push_back(t);
        }
  }
  return out;
}

}  // namespace mesorock::sim
