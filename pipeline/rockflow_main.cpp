// rockflow: the mDPD flow solver's command line. Each subcommand lives in its own file
// (pipeline/flow/*_command.cpp, declared in pipeline/flow/commands.h), as rockprep's do.
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <vector>

#include "mesorock/version.h"
#include "pipeline/cli_checks.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "sim/domain/communicator.h"
#include "sim/particle_io.h"

int main(int argc, char** argv) {
  namespace mp = mesorock::pipeline;
  namespace ms = mesorock::sim;
  // Under mpirun every rank runs this program; MPI starts only then (a plain run never calls
  // MPI_Init). A rank that fails alone aborts the others, which would wait in a collective.
  ms::MpiSession mpi(&argc, &argv);
  ms::skip_hdf5_exit_cleanup();
  const int code = mp::run_main("rockflow", [&]() -> int {
    CLI::App app{"rockflow: the mesorock mDPD flow solver"};
    app.set_version_flag("--version", std::string("rockflow ") + mesorock::kVersion + " (" +
                                          mesorock::kGitCommit + ")");
    app.require_subcommand(1);
    const std::vector<mp::FlowCommand> commands = {
        mp::add_run_command(app),     mp::add_validate_command(app),
        mp::add_sweep_command(app),   mp::add_bench_command(app),
        mp::add_lbm_command(app),     mp::add_study_flow_command(app),
        mp::add_relperm_command(app), mp::add_pc_command(app)};
    mp::bound_count_options(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
      std::cerr << mp::usage_error_line("rockflow", e) << "\n";
      return mp::kExitBadInput;
    }
    for (const mp::FlowCommand& command : commands)
      if (command.app->parsed()) return command.run(mpi.world());
    return mp::kExitOk;
  });
  if (code != mp::kExitOk && mpi.world() && mpi.world()->size() > 1) ms::MpiSession::abort(code);
  return code;
}
