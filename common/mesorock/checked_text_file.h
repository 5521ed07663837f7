#pragma once
// A text file written piece by piece (a run's CSV series) whose every write is checked.
//
// std::ofstream keeps going after a failed write: later writes are dropped and nothing is said,
// so a run on a full disk used to finish with exit 0 over a truncated thermo.csv. Here the first
// failed write or flush (ENOSPC, EIO, a removed folder) throws IoError naming the file and the
// reason, at once. The file is opened under a temporary name (StagedOutputs hands it out) and takes
// its final name only when the run commits its outputs.
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "mesorock/errors.h"

namespace mesorock {

class CheckedTextFile {
 public:
  // Opens (truncates) `temporary`; messages name `display` (the final path).
  void open(const std::filesystem::path& temporary, const std::filesystem::path& display) {
    temporary_ = temporary;
    display_ = display;
    out_.open(temporary, std::ios::binary | std::ios::trunc);
    if (!out_) fail("cannot open for writing");
  }
  bool is_open() const { return out_.is_open(); }
  const std::filesystem::path& path() const { return display_; }
  const std::filesystem::path& temporary() const { return temporary_; }
  void set_precision(int digits) { out_.precision(digits); }

  // Writes one value; throws at the first failure. A closed file drops writes (ranks > 0 of a
  // decomposed run write nothing).
  template <class T>
  CheckedTextFile& operator<<(const T& value) {
    if (!out_.is_open()) return *this;
    errno = 0;
    out_ << value;
    if (!out_) fail("write failed");
    return *this;
  }

  // Flushes to the file (before a checkpoint records what was written) and checks.
  void flush() {
    if (!out_.is_open()) return;
    errno = 0;
    out_.flush();
    if (!out_) fail("write failed");
  }

  // Closes and checks the close: the last buffer reaches the disk here.
  void close() {
    if (!out_.is_open()) return;
    errno = 0;
    out_.close();
    if (!out_) fail("write failed");
  }

 private:
  [[noreturn]] void fail(const char* what) {
    const int e = errno;  // the failed write(2)'s reason, when the stream's last call set it
    out_.setstate(std::ios::badbit);
    throw IoError(display_.string() + ": " + what +
                  (e ? std::string(": ") + std::strerror(e) : ""));
  }

  std::ofstream out_;
  std::filesystem::path temporary_, display_;
};

}  // namespace mesorock
