#include "pipeline/flow/commands.h"

#include "mesorock/errors.h"
#include "pipeline/flow/study.h"

namespace mesorock::pipeline {

void add_solver_flags(CLI::App& sub, SolverFlags& flags, bool backend) {
  if (backend) sub.add_option("--backend", flags.backend, "cpu or cuda");
  sub.add_option("--threads", flags.threads, "CPU threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
}

void add_watchdog_flag(CLI::App& sub, SolverFlags& flags) {
  sub.add_option("--watchdog", flags.watchdog,
                 "stop a blow-up (NaN, runaway velocity) with a diagnostic")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
}

sim::SimulationOptions solver_options(const SolverFlags& flags,
                                      std::shared_ptr<sim::Communicator> world,
                                      bool require_device_now) {
  sim::SimulationOptions so;
  if (flags.backend == "cpu")
    so.backend = sim::BackendKind::CPU;
  else if (flags.backend == "cuda")
    so.backend = sim::BackendKind::CUDA;
  else
    throw ConfigError("--backend must be cpu or cuda (got " + flags.backend + ")");
  so.threads = flags.threads;
  so.comm = std::move(world);
  so.watchdog.enabled = flags.watchdog != "off";
  so.watchdog.runaway_displacement = flags.runaway_displacement;
  if (require_device_now) require_device(so);
  return so;
}

void require_device(const sim::SimulationOptions& so) {
  if (so.backend != sim::BackendKind::CUDA) return;
  const std::string why = sim::cuda_unavailable_reason();
  if (!why.empty()) throw DeviceError(why);
}

FlowCommand add_study_flow_command(CLI::App& rockflow) {
  auto flags = std::make_shared<SolverFlags>();
  const StudyCommand study = add_study_command(rockflow, flags->backend, flags->threads);
  return {study.app, [flags, study](std::shared_ptr<sim::Communicator> world) {
            return study.run(solver_options(*flags, std::move(world)));
          }};
}

}  // namespace mesorock::pipeline
