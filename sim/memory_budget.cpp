#include "sim/memory_budget.h"

#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace mesorock::sim {

namespace fs = std::filesystem;

namespace {

// The first number of a one-line file ("max" or an unreadable file: nullopt).
std::optional<double> read_number_file(const fs::path& path) {
  std::ifstream in(path);
  std::string word;
  if (!(in >> word) || word == "max") return std::nullopt;
  try {
    size_t used = 0;
    const double v = std::stod(word, &used);
    if (used != word.size() || !(v >= 0)) return std::nullopt;
    return v;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// "Key:   123 kB" of a /proc file, in bytes.
std::optional<double> read_proc_kb(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size() + 1, key + ":") != 0) continue;
    std::istringstream s(line.substr(key.size() + 1));
    double kb = 0;
    if (s >> kb && kb >= 0) return kb * 1024.0;
    return std::nullopt;
  }
  return std::nullopt;
}

void take(MemoryAvailable& m, std::optional<double> bytes, const std::string& source) {
  if (!bytes) return;
  if (!m.bytes || *bytes < *m.bytes) {
    m.bytes = *bytes;
    m.source = source;
  }
}

// The cgroup's limit less its usage, for this process's cgroup and every ancestor (a limit set
// higher up binds too). v2: one hierarchy ("0::/path"); v1: the memory controller's.
void take_cgroup(MemoryAvailable& m) {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line)) {
    const size_t a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1);
    const fs::path path = fs::path(line.substr(b + 1)).relative_path();
    fs::path root;
    const char *limit = nullptr, *usage = nullptr;
    if (line.compare(0, a, "0") == 0 && controllers.empty()) {
      root = "/sys/fs/cgroup";
      limit = "memory.max";
      usage = "memory.current";
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {
      root = "/sys/fs/cgroup/memory";
      limit = "memory.limit_in_bytes";
      usage = "memory.usage_in_bytes";
    } else {
      continue;
    }
    // In a container the cgroup namespace makes its own cgroup the root: the listed path may not
    // exist under /sys/fs/cgroup, whose top then is the process's cgroup.
    for (fs::path p = path;; p = p.parent_path()) {
      const fs::path dir = root / p;
      if (const auto lim = read_number_file(dir / limit)) {
        const double used = read_number_file(dir / usage).value_or(0.0);
        take(m, *lim > used ? *lim - used : 0.0, std::string("cgroup ") + limit);
      }
      if (p.empty() || p == p.parent_path()) break;
    }
  }
}

}  // namespace

double host_bytes_per_particle(Precision p) {
  const double real = p == Precision::Single ? 4 : 8;
  return 286 + 15 * real;
}

double device_bytes_per_particle(Precision p) {
  const double real = p == Precision::Single ? 4 : 8;
  return 342 + 28 * real;
}

MemoryAvailable host_memory_available() {
  MemoryAvailable m;
  take(m, read_proc_kb("/proc/meminfo", "MemAvailable"), "MemAvailable");
  take_cgroup(m);
  rlimit r{};
  if (getrlimit(RLIMIT_AS, &r) == 0 && r.rlim_cur != RLIM_INFINITY) {
    const double limit = static_cast<double>(r.rlim_cur);
    const double used = read_proc_kb("/proc/self/status", "VmSize").value_or(0.0);
    take(m, limit > used ? limit - used : 0.0, "RLIMIT_AS (ulimit -v)");
  }
  return m;
}

std::string bytes_text(double bytes) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3g bytes (%.1f GiB)", bytes, bytes / (1024.0 * 1024 * 1024));
  return buf;
}

std::string memory_shortfall(double needed, const MemoryAvailable& available,
                             const std::string& what) {
  if (!available.bytes || !(needed > *available.bytes)) return "";
  return "needs about " + bytes_text(needed) + " of " + what + " memory, " +
         bytes_text(*available.bytes) + " available (" + available.source + ")";
}

#if !defined(MESOROCK_HAVE_CUDA)
MemoryAvailable device_memory_available(int /*device*/) {
  return {};  // no CUDA in this build: unknown
}
#endif

}  // namespace mesorock::sim
