// rockprep filter: median / Gaussian filtering and field-of-view masking of a grey stack.
#include <memory>

#include "mesorock/errors.h"
#include "pipeline/prep/common.h"

namespace mesorock::pipeline::prep {
namespace {

struct FilterCommandArgs {
  InputArgs input;
  FilterArgs filters;
  std::string out;
  bool quiet = false;
};

int run_filter(const FilterCommandArgs& args) {
  if (!args.filters.any()) {
    throw ConfigError("filter: nothing to do; give --median, --gaussian and/or --fov");
  }
  Progress progress(args.quiet);
  voxel::ReadReport report;
  voxel::Volume volume = load_input(args.input, progress, &report);
  std::optional<voxel::FieldOfView> fov;
  nlohmann::json filters = apply_filters(args.filters, volume, progress, &fov);
  if (fov) {
    const std::int64_t outside = progress.stage("field-of-view fill", volume.voxels(), [&] {
      return voxel::apply_field_of_view(volume, *fov, args.filters.fov_fill);
    });
    filters["fov_fill"] = args.filters.fov_fill;
    filters["voxels_outside_fov"] = outside;
  }
  nlohmann::json record = provenance("filter");
  record["input"] = input_record(args.input, volume, report);
  record["filters"] = filters;
  record["warnings"] = progress.warnings();
  write_volume(volume, args.out, record, progress);
  return 0;
}

}  // namespace

Command add_filter_command(CLI::App& rockprep) {
  auto args = std::make_shared<FilterCommandArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "filter",
      "Filter a grey stack: --fov detection (on the raw values), --median, --gaussian, then "
      "the voxels outside the field of view are set to --fov-fill; the field of view is "
      "recorded for 'segment'");
  args->input.add_to(app);
  args->filters.add_to(app, /*with_fill=*/true);
  app->add_option("--out", args->out, "Output file: .mhd, .tif or .npy")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_filter(*args); }};
}

}  // namespace mesorock::pipeline::prep
