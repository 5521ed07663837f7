#pragma once
// Pieces the rockprep subcommands share: input options, filter options, progress lines and
// provenance records.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mesorock/errors.h"
#include "voxel/filters.h"
#include "voxel/load.h"
#include "voxel/volume.h"

namespace mesorock::pipeline::prep {

// A subcommand: its CLI11 node and what to run when the user picked it.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command add_load_command(CLI::App& rockprep);
Command add_filter_command(CLI::App& rockprep);
Command add_segment_command(CLI::App& rockprep);
Command add_synth_command(CLI::App& rockprep);
Command add_analyze_command(CLI::App& rockprep);
Command add_crop_command(CLI::App& rockprep);
Command add_resample_command(CLI::App& rockprep);
Command add_walls_command(CLI::App& rockprep);
// Part 3 (docs/packing.md): the tile database, the whole chain to a flooding set-up, and the
// packing validation case.
Command add_tiles_command(CLI::App& rockprep);
Command add_run_command(CLI::App& rockprep);
Command add_validate_command(CLI::App& rockprep);

// The command line as typed, recorded in every output's provenance.
void set_command_line(int argc, char** argv);
const std::vector<std::string>& command_line();

// "a,b,c" -> three integers / doubles (ConfigError naming `option` otherwise).
voxel::Shape parse_shape(const std::string& text, const std::string& option);
std::vector<double> parse_numbers(const std::string& text, const std::string& option);

// Options naming an input stack and how to read it (load, filter and segment take them all).
struct InputArgs {
  std::string path;
  std::string shape;
  std::string dtype;
  std::string byte_order = "little";
  std::uint64_t header_bytes = 0;
  std::string spacing;
  std::string unit;
  std::string array;
  std::string dataset;

  void add_to(CLI::App* app);
  voxel::LoadOptions load_options() const;
};

// Filters applied before writing (filter) or before segmenting (segment), in this order:
// field-of-view detection (on the raw values), median, Gaussian, field-of-view fill.
struct FilterArgs {
  std::string median;  // "R" or "RZ,RY,RX", voxels
  std::string median_shape = "cube";
  double gaussian = 0;
  bool gaussian_physical = false;
  std::string fov;  // "", "auto", "value=V" or "CX,CY,R"
  double fov_fill = 0;

  void add_to(CLI::App* app, bool with_fill);
  bool any() const { return !median.empty() || gaussian > 0 || !fov.empty(); }
};

// One line per stage with its wall time and throughput, on stdout; warnings on stderr.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet) {}
  template <class Fn>
  decltype(auto) stage(const std::string& what, std::int64_t voxels, Fn&& fn) {
    const auto start = std::chrono::steady_clock::now();
    if constexpr (std::is_void_v<decltype(fn())>) {
      fn();
      report(what, voxels, start);
    } else {
      decltype(auto) result = fn();
      report(what, voxels, start);
      return result;
    }
  }
  void note(const std::string& line) const;
  void warn(const std::string& line);
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  void report(const std::string& what, std::int64_t voxels,
              std::chrono::steady_clock::time_point start) const;
  bool quiet_;
  std::vector<std::string> warnings_;
};

// Loads the input with a progress line and prints the loader's warnings.
voxel::Volume load_input(const InputArgs& input, Progress& progress, voxel::ReadReport* report);

// A phase-label volume: a file whose mesorock sidecar gives phase codes (segment's labels.mhd,
// synth's truth.mhd, or crop/resample outputs of them), a segment output folder (its
// labels.mhd), or any integer volume with an explicit --labels map. Labels are never guessed.
struct LabelInputArgs {
  InputArgs input;
  std::string labels;  // "value=phase,..." ("" : the sidecar must give phase codes)

  void add_to(CLI::App* app);
};

// Loads a phase-label volume (uint8 phase codes) with its progress line; `record` receives the
// input record with how the phases were obtained.
voxel::Volume load_labels(const LabelInputArgs& args, Progress& progress, nlohmann::json* record);

// True when the input's sidecar marks it as a phase-label volume.
bool has_phase_codes(const voxel::ReadReport& report);

// Re-throws a library ConfigError with `file` in front, so the one-line error names the file.
template <class Fn>
decltype(auto) about_file(const std::string& file, Fn&& fn) {
  try {
    return fn();
  } catch (const ConfigError& e) {
    throw ConfigError(file + ": " + e.what());
  }
}

// Writes `record` as indented JSON to a staged path (IoError naming `display_name`).
void write_json(const std::filesystem::path& path, const nlohmann::json& record,
                const std::string& display_name);

// Refuses an output folder whose parent is missing, or a file in its place (before any work).
void check_output_folder(const std::string& out);

// Runs FilterArgs on `volume`; returns the parameters and the field of view (if any) as JSON.
nlohmann::json apply_filters(const FilterArgs& filters, voxel::Volume& volume, Progress& progress,
                             std::optional<voxel::FieldOfView>* fov_out);

// Writes `volume` to `out` by extension: .mhd (+ .raw), .tif (multi-page) or .npy, always with
// a .json sidecar holding `record`; all files appear together or not at all.
void write_volume(const voxel::Volume& volume, const std::string& out, const nlohmann::json& record,
                  Progress& progress);

// {"tool", "command", "mesorock_version", "git_commit", "command_line"}.
nlohmann::json provenance(const std::string& command);
// {"path", "format", "shape_zyx", "dtype", "spacing_zyx", "unit", "spacing_source", and the
// input's own provenance when it has a mesorock sidecar}.
nlohmann::json input_record(const InputArgs& input, const voxel::Volume& volume,
                            const voxel::ReadReport& report);

}  // namespace mesorock::pipeline::prep
