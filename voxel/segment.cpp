#include "voxel/segment.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <sstream>

#include "mesorock/errors.h"
#include "voxel/io_common.h"

namespace mesorock::voxel {
namespace {

// Calls row_fn(z, y, first, last) for the columns [first, last] of each row that the exclusion's
// field of view keeps (the whole row without one), in parallel over slices.
template <class RowFn>
void for_each_row(const Shape& s, const Exclusion& exclusion, RowFn&& row_fn) {
  tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, s.nz), [&](const auto& range) {
    for (std::int64_t z = range.begin(); z != range.end(); ++z) {
      for (std::int64_t y = 0; y < s.ny; ++y) {
        std::int64_t first = 0, last = s.nx - 1;
        if (exclusion.field_of_view) exclusion.field_of_view->row_span(y, s.nx, &first, &last);
        row_fn(z, y, first, last);
      }
    }
  });
}

// Offset that maps an integer storage type onto non-negative table indices.
template <class T>
constexpr std::int64_t table_offset() {
  return std::is_signed_v<T> ? -static_cast<std::int64_t>(std::numeric_limits<T>::min()) : 0;
}
template <class T>
constexpr std::size_t table_size() {
  return std::size_t(1) << (8 * sizeof(T));
}

// Counts of every value of an integer volume (a table indexed by value + offset), excluded
// voxels left out.
template <class T>
std::vector<std::uint64_t> value_counts(const Volume& volume, const Exclusion& exclusion) {
  const Shape s = volume.shape();
  tbb::combinable<std::vector<std::uint64_t>> local(
      [] { return std::vector<std::uint64_t>(table_size<T>(), 0); });
  for_each_row(
      s, exclusion, [&](std::int64_t z, std::int64_t y, std::int64_t first, std::int64_t last) {
        std::vector<std::uint64_t>& counts = local.local();
        const T* row = volume.slice<T>(z) + y * s.nx;
        for (std::int64_t x = first; x <= last; ++x) {
          ++counts[static_cast<std::size_t>(static_cast<std::int64_t>(row[x]) + table_offset<T>())];
        }
      });
  std::vector<std::uint64_t> total(table_size<T>(), 0);
  local.combine_each([&](const std::vector<std::uint64_t>& c) {
    for (std::size_t i = 0; i < total.size(); ++i) total[i] += c[i];
  });
  if (exclusion.value) {
    const double v = *exclusion.value;
    const double index = v + static_cast<double>(table_offset<T>());
    if (v == std::floor(v) && index >= 0 && index < static_cast<double>(total.size())) {
      total[static_cast<std::size_t>(index)] = 0;
    }
  }
  return total;
}

// Applies a per-value table (value -> phase code) to an integer volume; voxels outside the field
// of view become kOutside. 1-byte volumes are relabelled in place.
template <class T>
Volume apply_table(Volume volume, const std::vector<std::uint8_t>& table,
                   const Exclusion& exclusion) {
  const Shape s = volume.shape();
  const Spacing spacing = volume.spacing();
  const bool in_place = sizeof(T) == 1;
  Volume out = in_place ? Volume() : Volume(s, DType::kUInt8, spacing);
  std::uint8_t* out_base =
      in_place ? reinterpret_cast<std::uint8_t*>(volume.bytes()) : out.data<std::uint8_t>();
  const T* in_base = volume.data<T>();
  for_each_row(
      s, exclusion, [&](std::int64_t z, std::int64_t y, std::int64_t first, std::int64_t last) {
        const std::int64_t start = (z * s.ny + y) * s.nx;
        const T* in = in_base + start;
        std::uint8_t* o = out_base + start;
        for (std::int64_t x = 0; x < first; ++x) o[x] = 0;
        for (std::int64_t x = first; x <= last; ++x) {
          o[x] =
              table[static_cast<std::size_t>(static_cast<std::int64_t>(in[x]) + table_offset<T>())];
        }
        for (std::int64_t x = std::max(first, last + 1); x < s.nx; ++x) o[x] = 0;
      });
  if (in_place) {
    volume.retag(DType::kUInt8);
    return volume;
  }
  return out;
}

}  // namespace

const char* phase_name(Phase phase) {
  switch (phase) {
    case Phase::kOutside:
      return "outside";
    case Phase::kPore:
      return "pore";
    case Phase::kOrganic:
      return "organic";
    case Phase::kInorganic:
      return "inorganic";
    case Phase::kOrganicPore:
      return "organic_pore";
  }
  return "?";
}

Phase parse_phase(const std::string& name) {
  const std::string n = lowercase(trim(name));
  if (n == "pore") return Phase::kPore;
  if (n == "organic") return Phase::kOrganic;
  if (n == "inorganic" || n == "solid") return Phase::kInorganic;
  if (n == "organic_pore") return Phase::kOrganicPore;
  if (n == "outside") return Phase::kOutside;
  throw ConfigError("unknown phase '" + name +
                    "' (pore, organic, inorganic, organic_pore, solid = inorganic, outside)");
}

std::int64_t PhaseCounts::counted() const {
  std::int64_t n = 0;
  for (int p = 1; p < kPhaseCount; ++p) n += voxels[static_cast<std::size_t>(p)];
  return n;
}

double PhaseCounts::fraction(Phase phase) const {
  const std::int64_t n = counted();
  return n ? static_cast<double>(voxels[static_cast<std::size_t>(phase)]) / static_cast<double>(n)
           : 0.0;
}

double PhaseCounts::porosity() const {
  return fraction(Phase::kPore) + fraction(Phase::kOrganicPore);
}

PhaseCounts count_phases(const Volume& labels) {
  if (labels.dtype() != DType::kUInt8) throw ConfigError("labels must be a uint8 volume");
  const std::vector<std::uint64_t> counts = value_counts<std::uint8_t>(labels, {});
  PhaseCounts result;
  for (std::size_t v = 0; v < counts.size(); ++v) {
    if (counts[v] == 0) continue;
    if (v >= kPhaseCount) {
      throw ConfigError("not a phase label volume: " + std::to_string(counts[v]) +
                        " voxels have value " + std::to_string(v));
    }
    result.voxels[v] = static_cast<std::int64_t>(counts[v]);
  }
  return result;
}

Histogram histogram_of(const Volume& volume, const Exclusion& exclusion, int bins) {
  if (bins < 0 || bins > 65536) throw ConfigError("histogram bins must be 1 to 65536");
  const Shape s = volume.shape();
  return visit_dtype(volume.dtype(), [&](auto tag) -> Histogram {
    using T = decltype(tag);
    Histogram h;
    if constexpr (sizeof(T) <= 2 && !std::is_same_v<T, float>) {
      // Integer volumes: count every value once, then rebin.
      const std::vector<std::uint64_t> counts = value_counts<T>(volume, exclusion);
      std::size_t first = counts.size(), last = 0;
      for (std::size_t i = 0; i < counts.size(); ++i) {
        if (counts[i]) {
          first = std::min(first, i);
          last = i;
        }
      }
      if (first > last) throw ConfigError("no voxels left to segment (all excluded)");
      const std::size_t levels = last - first + 1;
      const std::size_t n = bins ? static_cast<std::size_t>(bins) : (levels <= 1024 ? levels : 256);
      h.integer_values = true;
      h.lo = static_cast<double>(static_cast<std::int64_t>(first) - table_offset<T>());
      h.width = static_cast<double>(levels) / static_cast<double>(n);
      if (n == levels) h.width = 1.0;
      h.counts.assign(n, 0);
      for (std::size_t i = first; i <= last; ++i) {
        const auto b = std::min<std::size_t>(
            n - 1, static_cast<std::size_t>(static_cast<double>(i - first) / h.width));
        h.counts[b] += counts[i];
      }
      return h;
    } else {
      // float32: range first, then 256 (or `bins`) equal bins.
      tbb::combinable<std::pair<float, float>> range([] {
        return std::make_pair(std::numeric_limits<float>::max(),
                              std::numeric_limits<float>::lowest());
      });
      const bool skip_value = exclusion.value.has_value();
      const float skipped = skip_value ? static_cast<float>(*exclusion.value) : 0.0f;
      for_each_row(s, exclusion,
                   [&](std::int64_t z, std::int64_t y, std::int64_t first, std::int64_t last) {
                     auto& r = range.local();
                     const T* row = volume.slice<T>(z) + y * s.nx;
                     for (std::int64_t x = first; x <= last; ++x) {
                       if (!std::isfinite(row[x]) || (skip_value && row[x] == skipped)) continue;
                       r.first = std::min(r.first, row[x]);
                       r.second = std::max(r.second, row[x]);
                     }
                   });
      float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
      range.combine_each([&](const std::pair<float, float>& r) {
        lo = std::min(lo, r.first);
        hi = std::max(hi, r.second);
      });
      if (lo > hi) throw ConfigError("no finite voxels left to segment");
      const std::size_t n = bins ? static_cast<std::size_t>(bins) : 256;
      h.lo = lo;
      h.width = hi > lo ? (static_cast<double>(hi) - lo) / static_cast<double>(n) : 1.0;
      tbb::combinable<std::vector<std::uint64_t>> local(
          [n] { return std::vector<std::uint64_t>(n, 0); });
      for_each_row(
          s, exclusion, [&](std::int64_t z, std::int64_t y, std::int64_t first, std::int64_t last) {
            auto& counts = local.local();
            const T* row = volume.slice<T>(z) + y * s.nx;
            for (std::int64_t x = first; x <= last; ++x) {
              if (!std::isfinite(row[x]) || (skip_value && row[x] == skipped)) continue;
              const double b = (static_cast<double>(row[x]) - h.lo) / h.width;
              counts[std::min<std::size_t>(n - 1, static_cast<std::size_t>(std::max(0.0, b)))]++;
            }
          });
      h.counts.assign(n, 0);
      local.combine_each([&](const std::vector<std::uint64_t>& c) {
        for (std::size_t i = 0; i < n; ++i) h.counts[i] += c[i];
      });
      return h;
    }
  });
}

std::vector<std::size_t> multi_otsu_bins(const std::vector<std::uint64_t>& counts, int classes) {
  if (classes < 2 || classes > 8) throw ConfigError("multi-Otsu needs 2 to 8 classes");
  const std::size_t bins = counts.size();
  const auto k = static_cast<std::size_t>(classes);
  const auto occupied = static_cast<std::size_t>(
      std::count_if(counts.begin(), counts.end(), [](std::uint64_t c) { return c > 0; }));
  if (occupied < k) {
    throw ConfigError("the histogram has " + std::to_string(occupied) +
                      " occupied grey levels, "
                      "too few for " +
                      std::to_string(classes) + " classes");
  }
  // Maximising the between-class variance equals maximising sum_c S_c^2 / W_c, with W_c the
  // voxel count and S_c the sum of bin indices of class c (bin centres are equally spaced, so
  // indices stand in for grey values). Prefix sums make each class term O(1).
  using Real = long double;
  std::vector<Real> w(bins + 1, 0), sum(bins + 1, 0);
  for (std::size_t i = 0; i < bins; ++i) {
    w[i + 1] = w[i] + static_cast<Real>(counts[i]);
    sum[i + 1] = sum[i] + static_cast<Real>(i) * static_cast<Real>(counts[i]);
  }
  auto term = [&](std::size_t i, std::size_t j) -> Real {  // class over bins [i, j)
    const Real n = w[j] - w[i];
    if (n <= 0) return 0;
    const Real s = sum[j] - sum[i];
    return s * s / n;
  };
  // best[c][j]: the best score of c + 1 classes over bins [0, j); from[c][j]: the start of the
  // last class in that optimum.
  const Real kNone = -std::numeric_limits<Real>::infinity();
  std::vector<std::vector<Real>> best(k, std::vector<Real>(bins + 1, kNone));
  std::vector<std::vector<std::size_t>> from(k, std::vector<std::size_t>(bins + 1, 0));
  for (std::size_t j = 1; j <= bins; ++j) best[0][j] = term(0, j);
  for (std::size_t c = 1; c < k; ++c) {
    for (std::size_t j = c + 1; j <= bins; ++j) {
      for (std::size_t i = c; i < j; ++i) {
        if (best[c - 1][i] == kNone) continue;
        const Real score = best[c - 1][i] + term(i, j);
        if (score > best[c][j]) {  // strictly greater: ties keep the lowest boundary
          best[c][j] = score;
          from[c][j] = i;
        }
      }
    }
  }
  std::vector<std::size_t> boundaries(k - 1);
  std::size_t j = bins;
  for (std::size_t c = k - 1; c >= 1; --c) {
    j = from[c][j];
    boundaries[c - 1] = j;
  }
  return boundaries;
}

std::vector<double> multi_otsu_thresholds(const Histogram& histogram, int classes) {
  std::vector<double> thresholds;
  for (std::size_t b : multi_otsu_bins(histogram.counts, classes)) {
    const double edge = histogram.lower_edge(b);
    thresholds.push_back(histogram.integer_values ? std::ceil(edge) : edge);
  }
  return thresholds;
}

std::vector<Phase> default_class_phases(int classes) {
  if (classes == 2) return {Phase::kPore, Phase::kInorganic};
  if (classes == 3) return {Phase::kPore, Phase::kOrganic, Phase::kInorganic};
  throw ConfigError("no default phases for " + std::to_string(classes) +
                    " classes; name them with --phases (darkest first)");
}

Volume segment_by_thresholds(Volume grey, const ThresholdSegmentation& seg) {
  if (seg.phases.size() != seg.thresholds.size() + 1) {
    throw ConfigError(std::to_string(seg.thresholds.size()) + " thresholds make " +
                      std::to_string(seg.thresholds.size() + 1) + " classes, but " +
                      std::to_string(seg.phases.size()) + " phases were named");
  }
  for (std::size_t i = 0; i < seg.thresholds.size(); ++i) {
    if (!std::isfinite(seg.thresholds[i]) || (i && seg.thresholds[i] <= seg.thresholds[i - 1])) {
      throw ConfigError("thresholds must be finite and increasing");
    }
  }
  auto class_of = [&](double v) {
    std::size_t c = 0;
    while (c < seg.thresholds.size() && v >= seg.thresholds[c]) ++c;
    return static_cast<std::uint8_t>(seg.phases[c]);
  };
  return visit_dtype(grey.dtype(), [&](auto tag) -> Volume {
    using T = decltype(tag);
    if constexpr (std::is_same_v<T, float>) {
      const Shape s = grey.shape();
      Volume out(s, DType::kUInt8, grey.spacing());
      const bool skip_value = seg.exclusion.value.has_value();
      const double skipped = skip_value ? *seg.exclusion.value : 0.0;
      std::uint8_t* o = out.data<std::uint8_t>();
      const float* in = grey.data<float>();
      std::fill(o, o + out.voxels(), std::uint8_t(0));
      for_each_row(s, seg.exclusion,
                   [&](std::int64_t z, std::int64_t y, std::int64_t first, std::int64_t last) {
                     const std::int64_t start = (z * s.ny + y) * s.nx;
                     for (std::int64_t x = first; x <= last; ++x) {
                       const float v = in[start + x];
                       if (!std::isfinite(v) || (skip_value && v == skipped)) continue;
                       o[start + x] = class_of(v);
                     }
                   });
      return out;
    } else {
      std::vector<std::uint8_t> table(table_size<T>());
      for (std::size_t i = 0; i < table.size(); ++i) {
        const auto value = static_cast<std::int64_t>(i) - table_offset<T>();
        table[i] = class_of(static_cast<double>(value));
        if (seg.exclusion.value && static_cast<double>(value) == *seg.exclusion.value) {
          table[i] = static_cast<std::uint8_t>(Phase::kOutside);
        }
      }
      return apply_table<T>(std::move(grey), table, seg.exclusion);
    }
  });
}

LabelMap LabelMap::parse(const std::string& text) {
  LabelMap map;
  for (const std::string& item : split(text, ',')) {
    if (trim(item).empty()) continue;
    auto eq = item.find('=');
    if (eq == std::string::npos) eq = item.find(':');
    if (eq == std::string::npos) {
      throw ConfigError("label map entry '" + trim(item) + "' is not value=phase");
    }
    const std::string key = lowercase(trim(item.substr(0, eq)));
    std::int64_t value;
    if (key == "true") {
      value = 1;
    } else if (key == "false") {
      value = 0;
    } else {
      char* end = nullptr;
      value = std::strtoll(key.c_str(), &end, 10);
      if (key.empty() || *end != '\0') {
        throw ConfigError("label map value '" + key + "' is not an integer (or true/false)");
      }
    }
    const Phase phase = parse_phase(item.substr(eq + 1));
    for (const auto& e : map.entries) {
      if (e.first == value) {
        throw ConfigError("label map gives value " + std::to_string(value) + " twice");
      }
    }
    map.entries.emplace_back(value, phase);
  }
  if (map.entries.empty()) throw ConfigError("empty label map");
  return map;
}

std::string LabelMap::str() const {
  std::string s;
  for (const auto& e : entries) {
    s += (s.empty() ? "" : ",") + std::to_string(e.first) + "=" + phase_name(e.second);
  }
  return s;
}

Volume segment_by_label_map(Volume labelled, const LabelMap& map, const Exclusion& exclusion) {
  if (!is_integer(labelled.dtype())) {
    throw ConfigError(std::string("a label map needs an integer volume, this one is ") +
                      dtype_name(labelled.dtype()) + "; use --thresholds or --otsu");
  }
  return visit_dtype(labelled.dtype(), [&](auto tag) -> Volume {
    using T = decltype(tag);
    if constexpr (std::is_same_v<T, float>) {
      return Volume();  // unreachable: refused above
    } else {
      constexpr std::size_t kNoPhase = 255;
      std::vector<std::uint8_t> table(table_size<T>(), kNoPhase);
      for (const auto& [value, phase] : map.entries) {
        const std::int64_t index = value + table_offset<T>();
        if (index < 0 || index >= static_cast<std::int64_t>(table.size())) {
          throw ConfigError("label map value " + std::to_string(value) + " cannot occur in a " +
                            dtype_name(labelled.dtype()) + " volume");
        }
        table[static_cast<std::size_t>(index)] = static_cast<std::uint8_t>(phase);
      }
      // Check coverage before touching anything: every value present must be mapped.
      const std::vector<std::uint64_t> counts = value_counts<T>(labelled, exclusion);
      std::uint64_t unassigned = 0;
      std::ostringstream detail;
      int listed = 0;
      for (std::size_t i = 0; i < counts.size(); ++i) {
        if (counts[i] == 0 || table[i] != kNoPhase) continue;
        unassigned += counts[i];
        if (listed++ < 5) {
          detail << (listed > 1 ? ", " : "") << "value "
                 << static_cast<std::int64_t>(i) - table_offset<T>() << ": " << counts[i];
        }
      }
      if (unassigned) {
        std::ostringstream s;
        s << unassigned << " voxels have values the label map '" << map.str()
          << "' does not assign (" << detail.str() << (listed > 5 ? ", ..." : "") << ")";
        throw ConfigError(s.str());
      }
      if (exclusion.value) {
        const double v = *exclusion.value + static_cast<double>(table_offset<T>());
        if (v >= 0 && v < static_cast<double>(table.size()) && v == std::floor(v)) {
          table[static_cast<std::size_t>(v)] = static_cast<std::uint8_t>(Phase::kOutside);
        }
      }
      for (auto& t : table) {
        if (t == kNoPhase) t = static_cast<std::uint8_t>(Phase::kOutside);  // value absent
      }
      return apply_table<T>(std::move(labelled), table, exclusion);
    }
  });
}

std::int64_t split_organic_pores(Volume& labels) {
  if (labels.dtype() != DType::kUInt8) throw ConfigError("labels must be a uint8 volume");
  const Shape s = labels.shape();
  std::uint8_t* v = labels.data<std::uint8_t>();
  const std::int64_t nx = s.nx, nxy = s.nx * s.ny, n = s.voxels();
  constexpr std::uint8_t kPore = static_cast<std::uint8_t>(Phase::kPore);
  constexpr std::uint8_t kOrganic = static_cast<std::uint8_t>(Phase::kOrganic);
  constexpr std::uint8_t kInorganic = static_cast<std::uint8_t>(Phase::kInorganic);
  constexpr std::uint8_t kOrganicPore = static_cast<std::uint8_t>(Phase::kOrganicPore);
  // Temporary codes: visited in the counting pass, then "stays pore" in the relabelling pass.
  constexpr std::uint8_t kVisited = 250, kKeptPore = 251;
  std::int64_t relabelled = 0;
  std::deque<std::int64_t> queue;

  // Visits the 6-connected cluster of `from`-coded voxels containing `seed`, recoding them to
  // `to`, and calls neighbour(code) for every face neighbour outside the cluster.
  auto flood = [&](std::int64_t seed, std::uint8_t from, std::uint8_t to, auto&& neighbour) {
    queue.clear();
    v[seed] = to;
    queue.push_back(seed);
    std::int64_t size = 0;
    while (!queue.empty()) {
      const std::int64_t i = queue.front();
      queue.pop_front();
      ++size;
      const std::int64_t x = i % nx, y = (i / nx) % s.ny, z = i / nxy;
      const std::int64_t next[6] = {x > 0 ? i - 1 : -1,   x + 1 < nx ? i + 1 : -1,
                                    y > 0 ? i - nx : -1,  y + 1 < s.ny ? i + nx : -1,
                                    z > 0 ? i - nxy : -1, z + 1 < s.nz ? i + nxy : -1};
      for (std::int64_t j : next) {
        if (j < 0) continue;
        if (v[j] == from) {
          v[j] = to;
          queue.push_back(j);
        } else if (v[j] != to) {
          neighbour(v[j]);
        }
      }
    }
    return size;
  };

  for (std::int64_t seed = 0; seed < n; ++seed) {
    if (v[seed] != kPore) continue;
    std::int64_t organic = 0, inorganic = 0;
    flood(seed, kPore, kVisited, [&](std::uint8_t code) {
      organic += code == kOrganic;
      inorganic += code == kInorganic;
    });
    const bool hosted = organic > inorganic;
    const std::int64_t size =
        flood(seed, kVisited, hosted ? kOrganicPore : kKeptPore, [](std::uint8_t) {});
    if (hosted) relabelled += size;
  }
  tbb::parallel_for(std::int64_t(0), n, [&](std::int64_t i) {
    if (v[i] == kKeptPore) v[i] = kPore;
  });
  return relabelled;
}

std::string porosity_warning(const PhaseCounts& counts) {
  const double phi = counts.porosity();
  if (counts.counted() == 0) return "no voxels were assigned a phase";
  if (phi > 0.5 || phi < 0.001) {
    std::ostringstream s;
    s << "porosity " << phi
      << " is implausible for a rock (expected 0.001 to 0.5); is the label map or the threshold "
         "order inverted? (pore is often 0, 1 or 255 depending on the source)";
    return s.str();
  }
  return "";
}

double label_agreement(const Volume& labels, const Volume& truth, bool merge_pores) {
  if (labels.shape() != truth.shape()) {
    throw ConfigError("labels " + labels.shape().str() + " and truth " + truth.shape().str() +
                      " differ in shape");
  }
  const std::uint8_t* a = labels.data<std::uint8_t>();
  const std::uint8_t* b = truth.data<std::uint8_t>();
  auto canonical = [merge_pores](std::uint8_t c) -> std::uint8_t {
    if (merge_pores && c == static_cast<std::uint8_t>(Phase::kOrganicPore)) {
      return static_cast<std::uint8_t>(Phase::kPore);
    }
    return c;
  };
  std::int64_t agree = 0, total = 0;
  for (std::int64_t i = 0; i < labels.voxels(); ++i) {
    if (b[i] == static_cast<std::uint8_t>(Phase::kOutside)) continue;
    ++total;
    agree += canonical(a[i]) == canonical(b[i]);
  }
  return total ? static_cast<double>(agree) / static_cast<double>(total) : 0.0;
}

}  // namespace mesorock::voxel
