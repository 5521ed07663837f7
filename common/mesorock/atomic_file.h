#pragma once
// Write-to-temporary-then-rename, so a failed run never leaves a half-written output behind.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "mesorock/errors.h"

namespace mesorock {

// Temporary name next to the target (same filesystem, so rename is atomic), unique to this
// process (".NAME.PID.partial"): two processes writing one name never share a temporary.
inline std::filesystem::path temporary_path_for(const std::filesystem::path& target) {
  return target.parent_path() /
         ("." + target.filename().string() + "." + std::to_string(::getpid()) + ".partial");
}

// Calls write(tmp) with a temporary path, then renames it over `target`. On any exception the
// temporary file is removed and the exception propagates; `target` is untouched.
inline void write_atomically(const std::filesystem::path& target,
                             const std::function<void(const std::filesystem::path&)>& write) {
  const auto tmp = temporary_path_for(target);
  try {
    write(tmp);
    std::error_code ec;
    std::filesystem::rename(tmp, target, ec);
    if (ec) throw IoError(target.string() + ": cannot rename temporary file: " + ec.message());
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw;
  }
}

// Writes `text` to `path` (no rename), checking the writes and the close; errors name `display`
// (the file the user knows; `path` may be its temporary name).
inline void write_text_file(const std::filesystem::path& path, const std::string& text,
                            const std::filesystem::path& display = {}) {
  const std::string name = (display.empty() ? path : display).string();
  std::ofstream out(path, std::ios::binary);
  if (!out) throw IoError(name + ": cannot open for writing");
  out << text;
  out.close();
  if (!out) throw IoError(name + ": write failed");
}

// Convenience for text files.
inline void write_text_atomically(const std::filesystem::path& target, const std::string& text) {
  write_atomically(target,
                   [&](const std::filesystem::path& tmp) { write_text_file(tmp, text, target); });
}

}  // namespace mesorock
