// rockflow study: runs the studies (study_common.h lists their files) and writes study.json and
// one CSV per study. See study.h.
#include "pipeline/flow/study.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <thread>

#if defined(MESOROCK_HAVE_CUDA)
#include <cuda_runtime_api.h>
#endif

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/exit_codes.h"
#include "pipeline/flow/study_common.h"
#include "sim/domain/communicator.h"

namespace mesorock::pipeline {

using namespace study_detail;

namespace {

const char* size_name(StudySize s) {
  return s == StudySize::Tiny ? "tiny" : (s == StudySize::Small ? "small" : "full");
}

// Provenance and output.

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        std::string v = line.substr(colon + 1);
        v.erase(0, v.find_first_not_of(' '));
        return v;
      }
    }
  return "unknown";
}

std::string device_description(const sim::SimulationOptions& so) {
  if (so.backend == sim::BackendKind::CPU) {
    const int threads = so.threads > 0 ? so.threads : omp_get_max_threads();
    return cpu_model() + " (" + std::to_string(std::thread::hardware_concurrency()) +
           " hardware threads), OpenMP threads: " + std::to_string(threads);
  }
#if defined(MESOROCK_HAVE_CUDA)
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, so.device) == cudaSuccess) {
    int driver = 0, runtime = 0;
    cudaDriverGetVersion(&driver);
    cudaRuntimeGetVersion(&runtime);
    std::ostringstream s;
    s << prop.name << " (" << std::setprecision(3)
      << static_cast<double>(prop.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0) << " GiB, compute "
      << prop.major << "." << prop.minor << ", CUDA driver " << driver / 1000 << "."
      << (driver % 1000) / 10 << ", runtime " << runtime / 1000 << "." << (runtime % 1000) / 10
      << "), host " << cpu_model();
    return s.str();
  }
#endif
  return "cuda device " + std::to_string(so.device);
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string csv_cell(const Json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return q + "\"";
  }
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_float()) {
    std::ostringstream s;
    s << std::setprecision(10) << v.get<double>();
    return s.str();
  }
  return v.dump();
}

std::string rows_to_csv(const Json& rows, const std::string& header) {
  std::ostringstream s;
  s << header;
  if (rows.empty()) return s.str();
  std::vector<std::string> keys;
  for (auto it = rows[0].begin(); it != rows[0].end(); ++it) keys.push_back(it.key());
  for (size_t k = 0; k < keys.size(); ++k) s << (k ? "," : "") << keys[k];
  s << "\n";
  for (const auto& row : rows) {
    for (size_t k = 0; k < keys.size(); ++k)
      s << (k ? "," : "") << (row.contains(keys[k]) ? csv_cell(row[keys[k]]) : "");
    s << "\n";
  }
  return s.str();
}

const char* describe(const std::string& study) {
  if (study == "timestep")
    return "time step vs error in temperature, pressure, viscosity and permeability, and cost";
  if (study == "precision") return "single vs double precision at dt = 0.01";
  if (study == "resolution")
    return "slit width in rc vs the permeability's error from H^2/12, and cost";
  if (study == "reorder") return "cell-list reorder interval, skin and cells per rc vs MPS/s";
  return "the cost of each effect alone over the bare conservative pass";
}

}  // namespace

const std::vector<std::string>& study_names() {
  static const std::vector<std::string> names{"timestep", "precision", "resolution", "reorder",
                                              "effects"};
  return names;
}

nlohmann::ordered_json run_study(const StudyOptions& o) {
  if (o.sim.comm && o.sim.comm->size() > 1)
    throw ConfigError("study: runs on one rank (start it without mpirun)");
  for (const auto& name : o.only)
    if (std::find(study_names().begin(), study_names().end(), name) == study_names().end())
      throw ConfigError("study: unknown study '" + name +
                        "' (timestep, precision, resolution, reorder, effects)");
  auto wanted = [&](const std::string& name) {
    return o.only.empty() || std::find(o.only.begin(), o.only.end(), name) != o.only.end();
  };
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec || !std::filesystem::is_directory(o.out_dir))
    throw IoError(o.out_dir.string() + ": cannot create the output folder");

  Context c;
  c.o = o;
  c.o.sim.comm.reset();
  c.z = sizes_for(o.size);
  c.vo.sim = c.o.sim;
  c.vo.verbose = false;
  c.vo.size = o.size == StudySize::Full ? CaseSize::Full : CaseSize::Small;
  const auto t0 = Clock::now();
  const std::string started = utc_now();

  Json doc;
  doc["tool"] = "rockflow study";
  doc["mesorock_version"] = kVersion;
  doc["git_commit"] = kGitCommit;
  doc["date"] = started;
  doc["host"] = host_name();
  doc["backend"] = sim::to_string(c.o.sim.backend);
  doc["threads"] = c.o.sim.backend == sim::BackendKind::CPU
                       ? (c.o.sim.threads > 0 ? c.o.sim.threads : omp_get_max_threads())
                       : 0;
  doc["device"] = device_description(c.o.sim);
  doc["size"] = size_name(o.size);
  doc["seed"] = o.seed;
  doc["command"] = o.command_line;
  doc["units"] = "reduced: rc = m = kBT = 1, time unit tau = rc sqrt(m / kBT)";
  doc["studies"] = Json::object();

  std::map<std::string, StudyResult> results;
  if (wanted("timestep") || wanted("precision"))
    run_timestep_and_precision(c, wanted("timestep"), wanted("precision"), results["timestep"],
                               results["precision"]);
  if (!wanted("timestep")) results.erase("timestep");
  if (!wanted("precision")) results.erase("precision");
  if (wanted("resolution")) results["resolution"] = run_resolution(c);
  if (wanted("reorder")) results["reorder"] = run_reorder(c);
  if (wanted("effects")) results["effects"] = run_effects(c);

  // CSVs first, study.json last: a folder with study.json is complete.
  const std::string header = "# mesorock " + std::string(kVersion) + " (" + kGitCommit +
                             "), rockflow study, " + started + ", " +
                             doc["device"].get<std::string>() + "\n";
  for (const auto& name : study_names()) {
    auto it = results.find(name);
    if (it == results.end()) continue;
    const std::string csv = name + ".csv";
    write_text_atomically(o.out_dir / csv,
                          rows_to_csv(it->second.rows, header + "# " + describe(name) + "\n"));
    Json j;
    j["description"] = describe(name);
    j["seconds"] = it->second.seconds;
    j["csv"] = csv;
    j["parameters"] = it->second.parameters;
    if (!it->second.summary.empty()) j["summary"] = it->second.summary;
    j["rows"] = it->second.rows;
    doc["studies"][name] = j;
  }
  doc["seconds"] = seconds_since(t0);
  write_text_atomically(o.out_dir / "study.json", doc.dump(1) + "\n");
  say(c, "wrote " + (o.out_dir / "study.json").string() + " (" + fmt(seconds_since(t0), 4) +
             " s in all)");
  return doc;
}

StudyCommand add_study_command(CLI::App& rockflow, std::string& backend, int& threads) {
  struct Args {
    std::string size = "small", out, only;
    std::uint64_t seed = 1;
    std::string command;
  };
  auto a = std::make_shared<Args>();
  CLI::App* app = rockflow.add_subcommand(
      "study",
      "what accuracy costs: error against time for the time step, precision, resolution, "
      "cell-list settings and each effect (docs/accuracy.md)");
  app->add_option("--size", a->size, "tiny (smoke test), small (CPU minutes) or full (GPU)")
      ->check(CLI::IsMember({"tiny", "small", "full"}))
      ->capture_default_str();
  app->add_option("--out", a->out, "output folder (study.json and one CSV per study)")->required();
  app->add_option("--only", a->only,
                  "comma-separated studies: timestep,precision,resolution,reorder,effects");
  app->add_option("--seed", a->seed, "seed of every random choice")->capture_default_str();
  app->add_option("--backend", backend, "cpu or cuda");
  app->add_option("--threads", threads, "CPU threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  StudyCommand cmd;
  cmd.app = app;
  cmd.run = [a](const sim::SimulationOptions& so) {
    StudyOptions o;
    o.size = a->size == "tiny" ? StudySize::Tiny
                               : (a->size == "full" ? StudySize::Full : StudySize::Small);
    o.sim = so;
    o.out_dir = a->out;
    o.seed = a->seed;
    std::stringstream list(a->only);
    for (std::string item; std::getline(list, item, ',');)
      if (!item.empty()) o.only.push_back(item);
    o.command_line = "rockflow study --size " + a->size + " --out " + a->out + " --backend " +
                     sim::to_string(so.backend) +
                     (so.threads > 0 ? " --threads " + std::to_string(so.threads) : "") +
                     (a->only.empty() ? "" : " --only " + a->only) + " --seed " +
                     std::to_string(a->seed);
    run_study(o);
    return static_cast<int>(kExitOk);
  };
  return cmd;
}

}  // namespace mesorock::pipeline
