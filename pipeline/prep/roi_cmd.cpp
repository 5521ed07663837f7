// rockprep crop / resample: regions of interest and regridding of any volume (grey or labels).
#include <memory>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/prep/common.h"
#include "voxel/roi.h"

namespace mesorock::pipeline::prep {
namespace {

struct CropArgs {
  InputArgs input;
  std::string box;
  std::string physical_box;
  std::string out;
  bool quiet = false;
};

struct ResampleArgs {
  InputArgs input;
  std::string zoom;
  std::string target_spacing;
  std::string interpolation = "nearest";
  std::string out;
  bool quiet = false;
};

// The record of a volume derived from `volume` (loaded with `report`): provenance, input, and
// the phase codes and origin carried over from the input's sidecar.
nlohmann::json derived_record(const std::string& command, const InputArgs& input,
                              const voxel::Volume& volume, const voxel::ReadReport& report) {
  nlohmann::json record = provenance(command);
  record["input"] = input_record(input, volume, report);
  if (has_phase_codes(report)) record["phase_codes"] = report.provenance["phase_codes"];
  return record;
}

std::array<double, 3> input_origin(const voxel::ReadReport& report) {
  std::array<double, 3> origin{};
  if (report.provenance.is_object() && report.provenance.contains("origin_zyx")) {
    const auto& o = report.provenance["origin_zyx"];
    for (std::size_t a = 0; a < 3 && a < o.size(); ++a) origin[a] = o[a].get<double>();
  }
  return origin;
}

std::array<double, 3> three(const std::string& text, const std::string& option) {
  const std::vector<double> v = parse_numbers(text, option);
  if (v.size() == 1) return {v[0], v[0], v[0]};
  if (v.size() != 3) throw ConfigError(option + ": expected one value or three (Z,Y,X)");
  return {v[0], v[1], v[2]};
}

int run_crop(const CropArgs& a) {
  if (a.box.empty() == a.physical_box.empty()) {
    throw ConfigError("crop: give exactly one of --box (voxels) or --physical-box");
  }
  // Parse before loading.
  std::optional<voxel::VoxelBox> box;
  std::optional<voxel::PhysicalBox> physical;
  if (!a.box.empty()) box = voxel::parse_voxel_box(a.box, "--box");
  if (!a.physical_box.empty()) {
    physical = voxel::parse_physical_box(a.physical_box, "--physical-box");
  }
  Progress progress(a.quiet);
  voxel::ReadReport report;
  voxel::Volume volume = load_input(a.input, progress, &report);
  nlohmann::json record = derived_record("crop", a.input, volume, report);
  const voxel::Spacing spacing = volume.spacing();
  if (physical) {
    box = about_file(a.input.path,
                     [&] { return voxel::voxels_in(*physical, volume.shape(), spacing); });
  }
  about_file(a.input.path, [&] { voxel::check_box(*box, volume.shape()); });
  const voxel::Volume cropped = progress.stage("crop " + box->str(), box->shape().voxels(),
                                               [&] { return voxel::crop(volume, *box); });
  progress.note("cropped " + volume.shape().str() + " to " + cropped.shape().str());
  const std::array<double, 3> origin0 = input_origin(report);
  const double h[3] = {spacing.dz, spacing.dy, spacing.dx};
  std::array<double, 3> origin{};
  for (std::size_t ax = 0; ax < 3; ++ax) origin[ax] = origin0[ax] + double(box->lo[ax]) * h[ax];
  record["parameters"] = {{"box_lo_zyx", box->lo}, {"box_hi_zyx", box->hi}};
  if (physical) {
    record["parameters"]["physical_box_lo_zyx"] = physical->lo;
    record["parameters"]["physical_box_hi_zyx"] = physical->hi;
    record["parameters"]["physical_box_rule"] = "voxels whose centres lie in [lo, hi)";
  }
  record["origin_zyx"] = origin;  // of the first voxel's corner, in the unit, in the original
  record["shape_zyx"] = {cropped.shape().nz, cropped.shape().ny, cropped.shape().nx};
  record["warnings"] = progress.warnings();
  write_volume(cropped, a.out, record, progress);
  return 0;
}

int run_resample(const ResampleArgs& a) {
  if (a.zoom.empty() == a.target_spacing.empty()) {
    throw ConfigError("resample: give exactly one of --zoom or --target-spacing");
  }
  const voxel::Interpolation interpolation = voxel::parse_interpolation(a.interpolation);
  const std::array<double, 3> values =
      a.zoom.empty() ? three(a.target_spacing, "--target-spacing") : three(a.zoom, "--zoom");
  Progress progress(a.quiet);
  voxel::ReadReport report;
  voxel::Volume volume = load_input(a.input, progress, &report);
  if (interpolation == voxel::Interpolation::kLinear &&
      (has_phase_codes(report) || volume.dtype() == voxel::DType::kBool)) {
    throw ConfigError(a.input.path +
                      ": linear interpolation would mix phase codes; labels are resampled "
                      "with --interpolation nearest");
  }
  nlohmann::json record = derived_record("resample", a.input, volume, report);
  const voxel::ResampleOptions grid = about_file(a.input.path, [&] {
    voxel::ResampleOptions o = a.zoom.empty()
                                   ? voxel::spacing_grid(volume.shape(), volume.spacing(), values)
                                   : voxel::zoom_grid(volume.shape(), volume.spacing(), values);
    o.interpolation = interpolation;
    return o;
  });
  // A refusal before allocating, like the loaders (LimitError beyond physical memory).
  voxel::checked_volume_bytes(grid.shape, volume.dtype(), 0, a.out);
  const voxel::Volume out =
      progress.stage(std::string("resample (") + voxel::interpolation_name(interpolation) +
                         ") to " + grid.shape.str() + ", spacing " + grid.spacing.str(),
                     grid.shape.voxels(), [&] { return voxel::resample(volume, grid); });
  record["parameters"] = {{"interpolation", voxel::interpolation_name(interpolation)},
                          {"rule",
                           "output centre (i + 0.5) d' maps to input coordinate "
                           "(i + 0.5) d' / d - 0.5, clamped"}};
  if (!a.zoom.empty()) {
    record["parameters"]["zoom_zyx"] = values;
  } else {
    record["parameters"]["target_spacing_zyx"] = values;
  }
  record["origin_zyx"] = input_origin(report);
  record["shape_zyx"] = {grid.shape.nz, grid.shape.ny, grid.shape.nx};
  record["warnings"] = progress.warnings();
  write_volume(out, a.out, record, progress);
  return 0;
}

}  // namespace

Command add_crop_command(CLI::App& rockprep) {
  auto args = std::make_shared<CropArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "crop",
      "Cut a region of interest out of a volume (grey or labels) by a voxel box or a physical "
      "box; writes .mhd (+.raw), .tif or .npy with a .json sidecar");
  args->input.add_to(app);
  app->add_option("--box", args->box,
                  "Voxel box Z0:Z1,Y0:Y1,X0:X1, half-open like numpy slices (z0 <= z < z1)");
  app->add_option("--physical-box", args->physical_box,
                  "Box Z0:Z1,Y0:Y1,X0:X1 in the spacing's unit: the voxels whose centres lie in "
                  "it");
  app->add_option("--out", args->out, "Output file: .mhd, .tif or .npy")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_crop(*args); }};
}

Command add_resample_command(CLI::App& rockprep) {
  auto args = std::make_shared<ResampleArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "resample",
      "Resample a volume to another grid: --zoom (keeps the physical extent) or "
      "--target-spacing; nearest neighbour (labels) or linear (grey values)");
  args->input.add_to(app);
  app->add_option("--zoom", args->zoom,
                  "Factor F or FZ,FY,FX: F > 1 refines, F < 1 coarsens (shape round(n F))");
  app->add_option("--target-spacing", args->target_spacing,
                  "Voxel size DZ,DY,DX (or one value) in the input's unit");
  app->add_option("--interpolation", args->interpolation,
                  "nearest (default; the only choice for labels) or linear")
      ->check(CLI::IsMember({"nearest", "linear"}));
  app->add_option("--out", args->out, "Output file: .mhd, .tif or .npy")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_resample(*args); }};
}

}  // namespace mesorock::pipeline::prep
