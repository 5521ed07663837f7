#pragma once
// Typed exceptions (OpenVDB Exceptions.h style). Library code throws these and never exits;
// only the executables' main() maps them to exit codes (see pipeline/exit_codes.h).
#include <stdexcept>
#include <string>

namespace mesorock {

namespace detail {
// Messages are one line ("rockflow: error: <message>"), whatever text from a file or a name they
// quote: control characters (a newline in an npy header or a zip member name, found by the
// fuzzers) are written as \xNN.
inline std::string one_line(const std::string& text) {
  static const char hex[] = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  for (const unsigned char c : text) {
    if (c >= 0x20 && c != 0x7f) {
      out += static_cast<char>(c);
    } else {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}
}  // namespace detail

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(detail::one_line(what)) {}
  explicit Error(const char* what) : Error(std::string(what)) {}
};

// Bad user input: a scene key, a command-line value, a label map. Exit code 2.
class ConfigError : public Error {
 public:
  using Error::Error;
};

// A file that is missing, unreadable, truncated or inconsistent with its header. Exit code 2.
class IoError : public Error {
 public:
  using Error::Error;
};

// A backend that was asked for but is not available (no GPU, no CUDA build). Exit code 2.
class DeviceError : public Error {
 public:
  using Error::Error;
};

// The simulation left the physically meaningful range (NaN, runaway velocity). Exit code 3.
class NumericalError : public Error {
 public:
  using Error::Error;
};

// A request that would exceed a resource limit the user can raise (memory, particle count).
class LimitError : public Error {
 public:
  using Error::Error;
};

// The user stopped a command (Ctrl-C, SIGTERM); it wrote a checkpoint where it could and says
// how to continue. Exit code 130.
class Interrupted : public Error {
 public:
  using Error::Error;
};

}  // namespace mesorock
