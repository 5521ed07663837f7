// rockprep: image stack -> phase grids -> pore statistics -> particles (subcommands grow with the
// rockprep issues). Part 1: load, filter, segment, synth; part 2: analyze, crop, resample, walls
// (see docs/voxel.md); part 3: tiles, run, validate (docs/packing.md).
#include <CLI/CLI.hpp>

#include <iostream>
#include <vector>

#include "mesorock/version.h"
#include "pipeline/cli_checks.h"
#include "pipeline/exit_codes.h"
#include "pipeline/prep/common.h"
#include "sim/particle_io.h"

int main(int argc, char** argv) {
  namespace prep = mesorock::pipeline::prep;
  mesorock::sim::skip_hdf5_exit_cleanup();
  return mesorock::pipeline::run_main("rockprep", [&]() -> int {
    prep::set_command_line(argc, argv);
    CLI::App app{"rockprep: turn a rock image stack into phase grids and particle sets"};
    app.set_version_flag("--version", std::string("rockprep ") + mesorock::kVersion + " (" +
                                          mesorock::kGitCommit + ")");
    const std::vector<prep::Command> commands = {
        prep::add_load_command(app),     prep::add_filter_command(app),
        prep::add_segment_command(app),  prep::add_synth_command(app),
        prep::add_analyze_command(app),  prep::add_crop_command(app),
        prep::add_resample_command(app), prep::add_walls_command(app),
        prep::add_tiles_command(app),    prep::add_run_command(app),
        prep::add_validate_command(app)};
    app.require_subcommand(0, 1);
    mesorock::pipeline::bound_count_options(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
      // One line, like every other rockprep error (pipeline/cli_checks.h).
      std::cerr << mesorock::pipeline::usage_error_line("rockprep", e) << "\n";
      return mesorock::pipeline::kExitBadInput;
    }
    for (const prep::Command& command : commands) {
      if (command.app->parsed()) return command.run();
    }
    std::cout << app.help();
    return 0;
  });
}
