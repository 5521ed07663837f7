#pragma once
// Several output files that appear together or not at all.
//
// mesorock::write_atomically (common/mesorock/atomic_file.h) makes one file atomic. A .mhd header
// with its .raw data, or a segmentation folder (phases.vdb, labels.mhd/.raw, segment.json), is a
// set: if the third file fails, the first two must not be left behind. StagedOutputs hands out
// temporary paths (the same ".name.partial" names write_atomically uses, or a ".DIR.partial"
// folder for a new output folder), and commit() renames them all at the end. If commit() is never
// reached (an exception), the destructor removes every temporary.
#include <filesystem>
#include <functional>
#include <vector>

namespace mesorock {

class StagedOutputs {
 public:
  // Outputs that are single files anywhere (e.g. vol.mhd + vol.raw). Their folders must exist.
  static StagedOutputs files();
  // Outputs inside `dir`. When `dir` does not exist yet, everything is written into a sibling
  // ".dir.partial" folder that is renamed to `dir` at commit, so the folder itself is atomic.
  // Missing parent folders are created (they stay if the outputs are discarded).
  static StagedOutputs in_directory(const std::filesystem::path& dir);

  StagedOutputs(StagedOutputs&&) noexcept;
  StagedOutputs& operator=(StagedOutputs&&) = delete;
  StagedOutputs(const StagedOutputs&) = delete;
  ~StagedOutputs();

  // The path to write `target` to now; `target` is either absolute/relative as a file path (for
  // files()), or a path relative to the folder (for in_directory()). Subfolders are created.
  std::filesystem::path stage(const std::filesystem::path& target);
  // Stages `target` and calls write(temporary path). An IoError from it names the final path,
  // not the temporary one: the user knows the file by that name, and it will not exist.
  void write(const std::filesystem::path& target,
             const std::function<void(const std::filesystem::path&)>& write);
  // Stages `target` and writes `text` to it (checked).
  void write_text(const std::filesystem::path& target, const std::string& text);
  // Final path of a staged target.
  std::filesystem::path final_path(const std::filesystem::path& target) const;

  // Renames every staged file (or the staging folder) into place. Throws IoError on failure.
  void commit();

 private:
  StagedOutputs() = default;
  void discard() noexcept;

  std::filesystem::path dir_;          // output folder (in_directory mode), else empty
  std::filesystem::path staging_dir_;  // ".dir.partial" when dir_ did not exist
  struct Entry {
    std::filesystem::path temporary;
    std::filesystem::path target;
  };
  std::vector<Entry> entries_;
  std::vector<std::filesystem::path> created_dirs_;  // deepest first
  bool committed_ = false;
  bool active_ = true;
};

}  // namespace mesorock
