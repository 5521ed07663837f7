#pragma once
// One owner per output folder. Two processes writing one --out folder corrupted each other: two
// `rockflow run`s shared `.thermo.csv.partial`, and the first ended with exit 0 over the second's
// rows (issue 58). Every command that writes a folder takes an OutputLock on it first: an
// exclusive flock(2) on DIR/.mesorock.lock, which holds the owner's pid. A second process is
// refused at once (no waiting) with a ConfigError naming the folder and the holder's pid. The
// kernel drops the lock when its process ends, however it ends (a SIGKILL too), so a stale lock
// file never blocks a later run.
//
// The folder (and its parents) is created when missing, so taking the lock also proves that
// the folder can be written before any work (an IoError naming it otherwise). On release the
// lock file is removed, and a folder the lock created and nothing else filled is removed again.
#include <filesystem>
#include <string>

namespace mesorock {

class OutputLock {
 public:
  // Takes the lock on `dir`; `what` names the folder's role in messages (e.g. "--out").
  explicit OutputLock(const std::filesystem::path& dir, const std::string& what = "--out");
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock();

  const std::filesystem::path& folder() const { return dir_; }
  // Removes the completion record `name` (sweep.json, relperm.json, ...) an earlier command left
  // in the folder, before this one works: killed or failed, it must not leave the old record
  // beside its own partial outputs, where a script waiting for the record would read the old
  // numbers. IoError naming it when it cannot go (a folder in its place, say).
  void remove_earlier_record(const std::string& name) const;
  // The lock file's name inside the folder.
  static constexpr const char* kFileName = ".mesorock.lock";

 private:
  std::filesystem::path dir_, file_;
  bool created_dir_ = false;
  int fd_ = -1;
};

}  // namespace mesorock
