#pragma once
// Count options (steps, blocks, particles, tile variants, ...) are unsigned, and CLI11 converts
// "-1" to 2^64 - 1 for them: `bench --steps -1` hung, and a sweep's step budget wrapped round
// and passed its check. bound_count_options gives every unsigned option of an app and of its
// subcommands the range 0 .. kMaxCount, checked on the text before conversion, so a negative
// or absurd count is refused at parse time with the option's name. Seeds keep their full range.
// --threads is bounded by a small multiple of the cores: 100,000 threads segfaulted and 1,000
// aborted inside libgomp under a memory cap.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <thread>

namespace mesorock::pipeline {

// 1e15 steps or particles is beyond any run on any machine; a larger number is a typo.
inline constexpr double kMaxCount = 1e15;

// Checks the text; a text that is no number is left to CLI11's conversion, which names it.
inline std::string check_count_text(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str()) return "";
  if (value < 0) return "a count cannot be negative (got " + text + ")";
  if (!(value <= kMaxCount)) return "a count above 1e15 is not plausible (got " + text + ")";
  return "";
}

inline std::string check_threads_text(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const double most = 4.0 * cores;
  if (end != text.c_str() && value > most)
    return "at most 4 threads per core, " + std::to_string(static_cast<int>(most)) + " on the " +
           std::to_string(cores) + " cores here (got " + text + ")";
  return "";
}

// For a length scale typed by the user: 0 used to read as "not given" (rockprep run then picked
// one; walls asked to "give exactly one of" the two options).
inline CLI::Validator positive_value() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (end != text.c_str() && !(value > 0)) return "must be positive (got " + text + ")";
        return "";
      },
      "");
}

inline void bound_count_options(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_name() == "--threads")
      option->check(CLI::Validator([](std::string& text) { return check_threads_text(text); }, ""));
    const std::string type = option->get_type_name();
    if (type.rfind("UINT", 0) != 0) continue;
    if (option->get_name().find("seed") != std::string::npos) continue;
    option->check(CLI::Validator([](std::string& text) { return check_count_text(text); }, ""));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    bound_count_options(*sub);
}

}  // namespace mesorock::pipeline
