#include "mesorock/staged_outputs.h"

#include <string>
#include <system_error>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"

namespace fs = std::filesystem;

namespace mesorock {

StagedOutputs StagedOutputs::files() {
  return StagedOutputs();
}

StagedOutputs StagedOutputs::in_directory(const fs::path& dir) {
  StagedOutputs out;
  out.dir_ = dir;
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) throw IoError(dir.string() + ": exists and is not a folder");
  } else {
    // Missing parents are created, as users expect of --out (mkdir -p); a parent that is a file
    // is named.
    const fs::path parent = dir.parent_path();
    if (!parent.empty() && !fs::create_directories(parent, ec) && ec) {
      for (fs::path q = parent; !q.empty() && q != q.parent_path(); q = q.parent_path())
        if (fs::exists(q, ec) && !fs::is_directory(q, ec))
          throw IoError(dir.string() + ": " + q.string() + " is a file, not a folder");
      throw IoError(dir.string() + ": cannot create its parent folder: " + ec.message());
    }
    out.staging_dir_ = temporary_path_for(dir);
    fs::remove_all(out.staging_dir_, ec);  // a leftover from a killed run
    if (!fs::create_directory(out.staging_dir_, ec)) {
      throw IoError(dir.string() + ": cannot create staging folder: " + ec.message());
    }
  }
  return out;
}

StagedOutputs::StagedOutputs(StagedOutputs&& other) noexcept
    : dir_(std::move(other.dir_)),
      staging_dir_(std::move(other.staging_dir_)),
      entries_(std::move(other.entries_)),
      created_dirs_(std::move(other.created_dirs_)),
      committed_(other.committed_),
      active_(other.active_) {
  other.active_ = false;
}

StagedOutputs::~StagedOutputs() {
  if (active_ && !committed_) discard();
}

fs::path StagedOutputs::final_path(const fs::path& target) const {
  return dir_.empty() ? target : dir_ / target;
}

fs::path StagedOutputs::stage(const fs::path& target) {
  fs::path temporary;
  const fs::path final = final_path(target);
  std::error_code ec;
  if (!staging_dir_.empty()) {
    temporary = staging_dir_ / target;
  } else {
    temporary = temporary_path_for(final);
  }
  // Remember folders created here, so that a discarded run removes them again.
  std::vector<fs::path> missing;
  for (fs::path p = temporary.parent_path(); !p.empty() && !fs::exists(p, ec);
       p = p.parent_path()) {
    missing.push_back(p);
  }
  if (!temporary.parent_path().empty()) fs::create_directories(temporary.parent_path(), ec);
  if (ec) throw IoError(final.string() + ": cannot create folder: " + ec.message());
  created_dirs_.insert(created_dirs_.end(), missing.begin(), missing.end());
  if (staging_dir_.empty() && !final.parent_path().empty() &&
      !fs::is_directory(final.parent_path(), ec)) {
    throw IoError(final.string() + ": folder " + final.parent_path().string() + " does not exist");
  }
  entries_.push_back({temporary, final});
  return temporary;
}

void StagedOutputs::write(const fs::path& target,
                          const std::function<void(const fs::path&)>& write) {
  const fs::path temporary = stage(target);
  try {
    write(temporary);
  } catch (const IoError& e) {
    std::string message = e.what();
    const std::string from = temporary.string(), to = final_path(target).string();
    for (size_t at = message.find(from); at != std::string::npos; at = message.find(from, at))
      message.replace(at, from.size(), to), at += to.size();
    throw IoError(message);
  }
}

void StagedOutputs::write_text(const fs::path& target, const std::string& text) {
  const fs::path temporary = stage(target);
  write_text_file(temporary, text, final_path(target));
}

void StagedOutputs::commit() {
  std::error_code ec;
  if (!staging_dir_.empty()) {
    fs::rename(staging_dir_, dir_, ec);
    if (ec) throw IoError(dir_.string() + ": cannot rename staging folder: " + ec.message());
  } else {
    // All or nothing: a final name that a rename cannot take (a folder where a file goes, or a
    // file where a folder goes) is found before any output takes its name; a rename that fails
    // anyway takes the outputs renamed before it back to their temporary names, so none of this
    // set is left under a final name (the outputs they replaced are gone, as before).
    for (const Entry& e : entries_) {
      const bool folder = fs::is_directory(e.temporary, ec);
      if (fs::exists(e.target, ec) && fs::is_directory(e.target, ec) != folder)
        throw IoError(e.target.string() + ": " +
                      (folder ? "a file is in the way of this folder"
                              : "a folder is in the way of this file") +
                      ": no output was renamed into place");
    }
    for (std::size_t k = 0; k < entries_.size(); ++k) {
      const Entry& e = entries_[k];
      fs::rename(e.temporary, e.target, ec);
      if (!ec) continue;
      const std::string why = ec.message();
      for (std::size_t j = k; j-- > 0;) fs::rename(entries_[j].target, entries_[j].temporary, ec);
      throw IoError(e.target.string() + ": cannot rename temporary file: " + why +
                    ": no output was left under its final name");
    }
  }
  committed_ = true;
}

void StagedOutputs::discard() noexcept {
  std::error_code ec;
  if (!staging_dir_.empty()) {
    fs::remove_all(staging_dir_, ec);
  } else {
    for (const Entry& e : entries_) {
      if (fs::is_directory(e.temporary, ec)) {
        fs::remove_all(e.temporary, ec);
      } else {
        fs::remove(e.temporary, ec);
      }
    }
    for (const fs::path& d : created_dirs_) fs::remove(d, ec);  // only removes empty folders
  }
}

}  // namespace mesorock
