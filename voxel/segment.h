#pragma once
// Segmentation of a grey-level or labelled volume into rock phases.
//
// Labels are stored as uint8 phase codes (Phase below), one byte per voxel. Three ways in:
// thresholds given by the user, multi-Otsu thresholds for k classes, or an already labelled
// volume with an explicit value -> phase map (label conventions differ: pore may be 0, 1, 255 or
// True; the map is never guessed).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "voxel/filters.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

enum class Phase : std::uint8_t {
  kOutside = 0,  // outside the field of view or excluded: no phase, not counted
  kPore = 1,
  kOrganic = 2,
  kInorganic = 3,
  kOrganicPore = 4,  // pore hosted by organic matter
};
constexpr int kPhaseCount = 5;

const char* phase_name(Phase phase);  // "outside", "pore", "organic", "inorganic", "organic_pore"
// Accepts the names above, plus "solid" (= inorganic) for two-phase rocks. Throws ConfigError.
Phase parse_phase(const std::string& name);
inline bool is_pore(Phase p) {
  return p == Phase::kPore || p == Phase::kOrganicPore;
}

// Voxels to leave out of statistics and label as kOutside.
struct Exclusion {
  std::optional<FieldOfView> field_of_view;  // voxels outside the circle
  std::optional<double> value;               // voxels equal to this value (a scanner's sentinel)
};

// Voxel counts per phase code.
struct PhaseCounts {
  std::array<std::int64_t, kPhaseCount> voxels{};
  std::int64_t counted() const;        // every voxel but kOutside
  double fraction(Phase phase) const;  // of counted voxels
  double porosity() const;             // (pore + organic_pore) / counted
};
PhaseCounts count_phases(const Volume& labels);

// ---------------------------------------------------------------------------------------------
// Histograms and multi-Otsu

struct Histogram {
  double lo = 0;                // lower edge of bin 0
  double width = 1;             // bin width in grey levels
  bool integer_values = false;  // the volume holds integers: thresholds are rounded up
  std::vector<std::uint64_t> counts;
  double lower_edge(std::size_t bin) const { return lo + width * static_cast<double>(bin); }
};

// Histogram of the voxels not excluded. bins = 0 picks: one bin per grey level for integer
// volumes spanning at most 1024 levels (exact), else 256 bins between the minimum and maximum.
Histogram histogram_of(const Volume& volume, const Exclusion& exclusion = {}, int bins = 0);

// Exact multi-Otsu (Liao et al. 2001) over a histogram, by dynamic programming: the k - 1 class
// boundaries b_1 < ... < b_{k-1} (bin indices; class c holds bins [b_c, b_{c+1})) that maximise
// the between-class variance. Ties go to the lowest boundaries. Throws ConfigError when the
// histogram has fewer occupied bins than classes.
std::vector<std::size_t> multi_otsu_bins(const std::vector<std::uint64_t>& counts, int classes);

// Grey-level thresholds: the lower edges of the boundary bins (rounded up to the next integer
// for integer volumes, which classifies the same voxels). A voxel with value v belongs to class
// c = number of thresholds t with v >= t.
std::vector<double> multi_otsu_thresholds(const Histogram& histogram, int classes);

// ---------------------------------------------------------------------------------------------
// Labelling

// The phase of each class, darkest first: 2 classes -> pore, inorganic; 3 -> pore, organic,
// inorganic (SEM of shale: pores darkest, organic matter dark grey, minerals bright).
std::vector<Phase> default_class_phases(int classes);

struct ThresholdSegmentation {
  std::vector<double> thresholds;  // increasing
  std::vector<Phase> phases;       // thresholds.size() + 1 entries, darkest class first
  Exclusion exclusion;
};

// Labels by thresholds. The grey volume is taken by value: an 8-bit volume is overwritten in
// place (std::move it in to avoid a second full-size buffer); wider types get a new uint8 volume.
Volume segment_by_thresholds(Volume grey, const ThresholdSegmentation& segmentation);

// value -> phase, e.g. "0=pore,255=inorganic" or "true=pore,false=solid".
struct LabelMap {
  std::vector<std::pair<std::int64_t, Phase>> entries;
  static LabelMap parse(const std::string& text);  // throws ConfigError
  std::string str() const;
};

// Labels an already segmented volume through `map`. Every voxel that is not excluded must have a
// value in the map; otherwise ConfigError lists the unassigned values and their counts, before
// anything is changed. Integer volumes only.
Volume segment_by_label_map(Volume labelled, const LabelMap& map, const Exclusion& exclusion = {});

// Relabels pores whose surroundings are mostly organic matter as organic_pore: for each
// 6-connected pore cluster, the face neighbours that are organic are compared with those that
// are inorganic. Returns the number of voxels relabelled.
std::int64_t split_organic_pores(Volume& labels);

// A warning text when the porosity is implausible for a rock (above 0.5 or below 0.001, the usual
// sign of an inverted label map); empty otherwise.
std::string porosity_warning(const PhaseCounts& counts);

// Fraction of voxels (both not kOutside in `truth`) whose labels agree. With merge_pores,
// organic_pore and pore count as the same phase.
double label_agreement(const Volume& labels, const Volume& truth, bool merge_pores);

}  // namespace mesorock::voxel
