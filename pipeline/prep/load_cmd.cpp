// rockprep load: read any supported stack and write it as one canonical volume file.
#include <memory>

#include "pipeline/prep/common.h"

namespace mesorock::pipeline::prep {
namespace {

struct LoadArgs {
  InputArgs input;
  std::string out;
  bool quiet = false;
};

int run_load(const LoadArgs& args) {
  Progress progress(args.quiet);
  voxel::ReadReport report;
  const std::string out = args.out;
  voxel::Volume volume = load_input(args.input, progress, &report);
  nlohmann::json record = provenance("load");
  record["input"] = input_record(args.input, volume, report);
  record["warnings"] = progress.warnings();
  write_volume(volume, out, record, progress);
  return 0;
}

}  // namespace

Command add_load_command(CLI::App& rockprep) {
  auto args = std::make_shared<LoadArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "load",
      "Read a stack (TIFF folder or file, raw, .mhd, .npy/.npz, HDF5) and write it as "
      "one volume: .mhd + .raw (canonical), .tif or .npy, with a .json sidecar");
  args->input.add_to(app);
  app->add_option("--out", args->out, "Output file: .mhd, .tif or .npy")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_load(*args); }};
}

}  // namespace mesorock::pipeline::prep
