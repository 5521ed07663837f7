// `rockflow validate CASE`: one built-in physics validation case against its reference value.
#include <chrono>
#include <iostream>

#include "mesorock/errors.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/commands.h"
#include "pipeline/flow/progress.h"
#include "pipeline/flow/validation.h"

namespace mesorock::pipeline {

FlowCommand add_validate_command(CLI::App& rockflow) {
  struct Args {
    SolverFlags flags;
    std::string case_name, size = "small", kernel = "warren";
    bool list = false, json = false;
    std::uint64_t seed_offset = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* val = rockflow.add_subcommand("validate", "run a built-in physics validation case");
  val->add_option("case", a->case_name, "case name (see --list)");
  val->add_flag("--list", a->list, "print the case names, one per line");
  val->add_option("--size", a->size, "small (CI) or full")->check(CLI::IsMember({"small", "full"}));
  val->add_option("--density-kernel", a->kernel, "warren or lucy")
      ->check(CLI::IsMember({"warren", "lucy"}));
  val->add_option("--seed-offset", a->seed_offset,
                  "added to every seed of the case: another sample of the same physics (default "
                  "0: the seeds of the recorded results)");
  add_solver_flags(*val, a->flags);
  val->add_flag("--json", a->json, "print one JSON object");
  add_watchdog_flag(*val, a->flags);
  return {
      val, [a](std::shared_ptr<sim::Communicator> world) {
        const sim::SimulationOptions so = solver_options(a->flags, std::move(world), false);
        if (a->list) {
          for (const auto& c : validation_cases()) std::cout << c.name << "\n";
          return static_cast<int>(kExitOk);
        }
        if (a->case_name.empty()) throw ConfigError("validate: name a case (see --list)");
        const ValidationCase* c = find_validation_case(a->case_name);
        if (!c) throw ConfigError("validate: unknown case '" + a->case_name + "' (see --list)");
        require_device(so);  // CUDA asked for and absent: one line, once the case is known
        const bool root = !so.comm || so.comm->rank() == 0;  // rank 0 alone prints
        ValidateOptions vo;
        vo.size = a->size == "full" ? CaseSize::Full : CaseSize::Small;
        vo.density_kernel =
            a->kernel == "lucy" ? sim::DensityKernelKind::Lucy : sim::DensityKernelKind::Warren;
        vo.sim = so;
        vo.verbose = root;
        vo.seed_offset = a->seed_offset;
        ProgressMeter meter("validate " + a->case_name, std::cerr, root);
        meter.set_total(1e6 * (vo.size == CaseSize::Full ? c->work_full : c->work_small));
        vo.sim.on_run = [&meter](std::uint64_t steps, std::size_t n) { meter.advance(steps, n); };
        const auto t0 = std::chrono::steady_clock::now();
        CaseResult r = c->run(vo);
        if (vo.seed_offset != 0)
          r.notes.push_back("seed offset " + std::to_string(vo.seed_offset) +
                            " (another sample than the recorded results)");
        meter.finish(r.pass() ? "pass" : "FAIL");
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (root) std::cout << (a->json ? format_case_json(r) + "\n" : format_case_text(r));
        return static_cast<int>(r.pass() ? kExitOk : kExitFailed);
      }};
}

}  // namespace mesorock::pipeline
