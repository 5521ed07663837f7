// rockprep: image stack -> phase grids -> pore statistics -> particles (subcommands grow with the
// rockprep issues).
#include <CLI/CLI.hpp>

#include <iostream>

#include "mesorock/version.h"
#include "pipeline/exit_codes.h"

int main(int argc, char** argv) {
  return mesorock::pipeline::run_main("rockprep", [&]() -> int {
    CLI::App app{"rockprep: turn a rock image stack into phase grids and particle sets"};
    app.set_version_flag("--version", std::string("rockprep ") + mesorock::kVersion + " (" +
                                          mesorock::kGitCommit + ")");
    app.require_subcommand(0, 1);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e) == 0 ? 0 : mesorock::pipeline::kExitBadInput;
    }
    if (argc == 1) std::cout << app.help();
    return 0;
  });
}
