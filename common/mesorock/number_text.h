#pragma once
// Numbers in messages: the shortest text that reads back to the same double ("0.1", "1e-09"),
// with "nan", "inf" and "-inf" spelled out, so that a message quotes exactly what was given; and
// numbers in reports, to a few significant digits.
#include <charconv>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

namespace mesorock {

inline std::string shortest_number_text(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// A number for reports and progress lines: `precision` significant digits ("0.0114", "1321").
inline std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

}  // namespace mesorock
