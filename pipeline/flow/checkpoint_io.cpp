#include "pipeline/flow/checkpoint_io.h"

#include <cctype>
#include <cstdlib>
#include <sstream>

#include "mesorock/checksum.h"
#include "mesorock/errors.h"

namespace mesorock::pipeline {

namespace {
// BinnedAverage::Saved as numbers: the four counters, then total, current and the blocks.
constexpr const char* kCounters = ".counters";
constexpr const char* kTotal = ".total";
constexpr const char* kCurrent = ".current";
constexpr const char* kBlocks = ".blocks";
}  // namespace

void RunRecord::put_binned(const std::string& name, const sim::BinnedAverage& average) {
  const sim::BinnedAverage::Saved s = average.save();
  numbers[name + kCounters] = {static_cast<double>(s.max_blocks),
                               static_cast<double>(s.block_length),
                               static_cast<double>(s.in_current), static_cast<double>(s.samples)};
  numbers[name + kTotal] = s.total;
  numbers[name + kCurrent] = s.current;
  std::vector<double> blocks;
  for (const auto& b : s.blocks) blocks.insert(blocks.end(), b.begin(), b.end());
  numbers[name + kBlocks] = blocks;
}

void RunRecord::get_binned(const std::string& name, sim::BinnedAverage& average) const {
  const std::vector<double>& c = series(name + kCounters);
  if (c.size() != 4) throw IoError(file + ": " + name + kCounters + ": expected 4 values");
  sim::BinnedAverage::Saved s;
  s.max_blocks = static_cast<std::size_t>(c[0]);
  s.block_length = static_cast<std::size_t>(c[1]);
  s.in_current = static_cast<std::size_t>(c[2]);
  s.samples = static_cast<std::size_t>(c[3]);
  s.total = series(name + kTotal);
  s.current = series(name + kCurrent);
  const std::size_t fields = average.grid().count() * sim::kBinFields;
  if ((!s.total.empty() && s.total.size() != fields) || s.current.size() != s.total.size())
    throw IoError(file + ": " + name + ": the saved bins do not match the scene's grid");
  const std::vector<double>& blocks = series(name + kBlocks);
  if (blocks.size() % (fields ? fields : 1) != 0 || (s.total.empty() && !blocks.empty()))
    throw IoError(file + ": " + name + kBlocks + ": wrong length");
  for (std::size_t k = 0; k + fields <= blocks.size() && fields > 0; k += fields)
    s.blocks.emplace_back(blocks.begin() + static_cast<std::ptrdiff_t>(k),
                          blocks.begin() + static_cast<std::ptrdiff_t>(k + fields));
  average.restore(s);
}

double RunRecord::number(const std::string& name) const {
  const std::vector<double>& v = series(name);
  if (v.size() != 1) throw IoError(file + ": /run/numbers/" + name + ": expected one value");
  return v[0];
}

const std::vector<double>& RunRecord::series(const std::string& name) const {
  const auto it = numbers.find(name);
  if (it == numbers.end()) throw IoError(file + ": /run/numbers/" + name + ": missing");
  return it->second;
}

const std::string& RunRecord::text(const std::string& name) const {
  const auto it = texts.find(name);
  if (it == texts.end()) throw IoError(file + ": /run/text/" + name + ": missing");
  return it->second;
}

std::string named_files_record(const Scene& scene) {
  std::string record;
  for (const std::filesystem::path& f : scene.named_files)
    record += file_checksum_hex(f) + " " + f.string() + "\n";
  return record;
}

namespace {

// The files the scene names must hold what they held when the checkpoint was written.
void check_named_files(const std::string& file, const std::string& saved, const Scene& scene) {
  std::istringstream lines(saved);
  std::string line;
  for (const std::filesystem::path& f : scene.named_files) {
    if (!std::getline(lines, line) || line.size() < 17)
      throw ConfigError(file + ": /meta/input_files: holds no checksum of " + f.string() +
                        ", which " + scene.path.string() + " names");
    if (file_checksum_hex(f) != line.substr(0, 16))
      throw ConfigError(file + ": /meta/input_files: " + f.string() +
                        " has changed since the checkpoint was written (its checksum differs): "
                        "resume with the files the run was started with");
  }
}

// The step of the last data row of a CSV text ("step,..." rows; comment and header lines are
// skipped); false when it has none.
bool last_row_step(const std::string& text, std::uint64_t* step) {
  std::istringstream lines(text);
  std::string line;
  bool found = false;
  while (std::getline(lines, line)) {
    if (line.empty() || !std::isdigit(static_cast<unsigned char>(line[0]))) continue;
    *step = std::strtoull(line.c_str(), nullptr, 10);  // saturates: never throws
    found = true;
  }
  return found;
}

// The step must lie within the scene's stages, and thermo.csv's rows must end at the last
// multiple of thermo_every at or before it (a row is written at every multiple).
void check_step(const std::string& file, const sim::CheckpointFile& c, const Scene& scene) {
  std::uint64_t total = 0;
  for (const StageSpec& stage : scene.stages) total += stage.steps;
  const std::uint64_t step = c.state.step;
  if (step > total)
    throw ConfigError(file + ": /checkpoint/step: step " + std::to_string(step) +
                      " lies past the end of " + scene.path.string() + " (" +
                      std::to_string(total) + " steps): this checkpoint is not of this run");
  const std::uint64_t every = scene.output.thermo_every;
  const auto thermo = c.texts.find("thermo.csv");
  if (every == 0 || thermo == c.texts.end()) return;
  std::uint64_t last = 0;
  const bool rows = last_row_step(thermo->second, &last);
  if (rows ? (last > step || step - last >= every) : step >= every)
    throw ConfigError(file + ": /run/text/thermo.csv: the saved rows end at " +
                      (rows ? "step " + std::to_string(last) : std::string("no row")) +
                      ", but /checkpoint/step is " + std::to_string(step) + " (a row every " +
                      std::to_string(every) + " steps): the checkpoint disagrees with itself");
}

}  // namespace

void write_run_checkpoint(const std::filesystem::path& path, sim::SimulationState state,
                          const Scene& scene, const std::string& parameters_json,
                          const RunRecord& record) {
  sim::CheckpointFile c;
  c.state = std::move(state);
  c.created_by = "rockflow run";
  c.scene_path = scene.path.string();
  c.scene_text = scene.source_text;
  c.parameters_json = parameters_json;
  c.texts = record.texts;
  c.numbers = record.numbers;
  c.input_files = record.input_files;
  sim::write_checkpoint(path, c);
}

ResumePoint read_run_checkpoint(const std::filesystem::path& path, const Scene& scene) {
  sim::CheckpointFile c = sim::read_checkpoint(path);
  if (c.created_by != "rockflow run")
    throw ConfigError(path.string() + ": written by '" + c.created_by +
                      "', not by rockflow run: cannot resume from it");
  if (c.scene_text != scene.source_text)
    throw ConfigError(path.string() + ": belongs to another scene (" + c.scene_path + "); " +
                      scene.path.string() +
                      " differs from it: resume with the scene the run was started with");
  check_named_files(path.string(), c.input_files, scene);
  check_step(path.string(), c, scene);
  ResumePoint r;
  r.state = std::move(c.state);
  r.record.input_files = std::move(c.input_files);
  r.record.texts = std::move(c.texts);
  r.record.numbers = std::move(c.numbers);
  r.record.file = path.string();
  return r;
}

}  // namespace mesorock::pipeline
