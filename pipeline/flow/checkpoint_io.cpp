#include "pipeline/flow/checkpoint_io.h"

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
  ResumePoint r;
  r.state = std::move(c.state);
  r.record.texts = std::move(c.texts);
  r.record.numbers = std::move(c.numbers);
  r.record.file = path.string();
  return r;
}

}  // namespace mesorock::pipeline
