#pragma once
// Checks on option text, run by CLI11 before conversion, for both CLIs.
// - Count options (steps, blocks, particles, tile variants, ...) are unsigned, and CLI11 converts
//   "-1" to 2^64 - 1 for them: `bench --steps -1` hung, and a sweep's step budget wrapped round
//   and passed its check. bound_count_options gives every unsigned option of an app and of its
//   subcommands the range 0 .. kMaxCount (seeds keep their full range).
// - --threads is bounded by a small multiple of the cores: 100,000 threads segfaulted and 1,000
//   aborted inside libgomp under a memory cap.
// - positive_value() for a length scale: 0 used to read as "not given".
// - usage_error_line(): CLI11's own errors in the one-line form of every other error.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

namespace mesorock::pipeline {

// 1e15 steps or particles is beyond any run on any machine; a larger number is a typo.
inline constexpr double kMaxCount = 1e15;

// A validator from a check of the option's number; a text that is no number is left to CLI11's
// conversion, which names it.
inline CLI::Validator number_check(std::function<std::string(double, const std::string&)> check) {
  return CLI::Validator(
      [check](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        return end == text.c_str() ? std::string() : check(value, text);
      },
      "");
}

inline CLI::Validator positive_value() {
  return number_check([](double v, const std::string& text) {
    return v > 0 ? std::string() : "must be positive (got " + text + ")";
  });
}

inline CLI::Validator non_negative_value() {
  return number_check([](double v, const std::string& text) {
    return v >= 0 ? std::string() : "must not be negative (got " + text + ")";
  });
}

// A CLI11 usage error as one line, "TOOL: error: --option: what (see TOOL --help)". CLI11 printed
// two lines without the tool's name, and its range checks wrote their upper bound, the largest
// double, with all its 309 digits ("--threads -1": "Value -1 not in range 0.000000 to 1797...").
inline std::string usage_error_line(const std::string& tool, const CLI::ParseError& e) {
  std::string what = e.what();
  static const std::regex unbounded(
      "Value (.*) not in range (-?[0-9.]+) to [0-9]{30,}(\\.[0-9]*)?");
  std::smatch m;
  if (std::regex_search(what, m, unbounded)) {
    std::ostringstream lower;
    lower << std::stod(m[2].str());
    what = m.prefix().str() + "must be a number >= " + lower.str() + " (got " + m[1].str() + ")" +
           m.suffix().str();
  }
  for (char& c : what)
    if (c == '\n' || c == '\r') c = ' ';
  return tool + ": error: " + what + " (see " + tool + " --help)";
}

inline void bound_count_options(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_name() == "--threads")
      option->check(number_check([](double v, const std::string& text) {
        const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
        if (v <= 4.0 * cores) return std::string();
        return "at most 4 threads per core, " + std::to_string(4 * cores) + " on the " +
               std::to_string(cores) + " cores here (got " + text + ")";
      }));
    if (option->get_type_name().rfind("UINT", 0) != 0) continue;
    if (option->get_name().find("seed") != std::string::npos) continue;
    option->check(number_check([](double v, const std::string& text) {
      if (v < 0) return "a count cannot be negative (got " + text + ")";
      if (!(v <= kMaxCount)) return "a count above 1e15 is not plausible (got " + text + ")";
      return std::string();
    }));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    bound_count_options(*sub);
}

}  // namespace mesorock::pipeline
