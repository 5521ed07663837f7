#pragma once
// The shared cache of results worth keeping between runs (viscosity calibrations, tile sets):
// where it lives and how its files are named. A cache file holds the full key it was made for,
// and a reader checks it, so a hash collision or a damaged file only costs a recomputation.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace mesorock {

// 64-bit FNV-1a: a stable file name for a key text (the same on every machine and build).
inline std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// $MESOROCK_CACHE_DIR/WHAT, else $XDG_CACHE_HOME/mesorock/WHAT, else ~/.cache/mesorock/WHAT,
// else ./.mesorock-cache/WHAT.
inline std::filesystem::path default_cache_dir(const std::string& what) {
  if (const char* d = std::getenv("MESOROCK_CACHE_DIR"); d && *d)
    return std::filesystem::path(d) / what;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
    return std::filesystem::path(d) / "mesorock" / what;
  if (const char* d = std::getenv("HOME"); d && *d)
    return std::filesystem::path(d) / ".cache" / "mesorock" / what;
  return std::filesystem::path(".mesorock-cache") / what;
}

}  // namespace mesorock
