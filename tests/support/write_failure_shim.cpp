// Test-only LD_PRELOAD library that makes writes to chosen files fail as a full disk does, so the
// stability suite can check that every output stream notices (tests/stability/
// test_write_failures.cpp, docs/stability.md "Write failures").
//
//   MESOROCK_FAIL_WRITES_TO     substring of the file's path (as /proc/self/fd names it); only
//                               regular files whose path contains it are affected
//   MESOROCK_FAIL_WRITES_AFTER  bytes those files may take in all before the disk is "full"
//                               (default 0); the write that crosses the limit is cut short there
//   MESOROCK_FAIL_WRITES_CALLS  how many write calls then fail with ENOSPC before the disk has
//                               room again (default: all of them), to mimic space freed mid-run
//
// It wraps write, pwrite, pwrite64, writev and fwrite (glibc's stdio flushes through internal
// calls, so fwrite is wrapped at its entry). Everything else passes through untouched.
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <dlfcn.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>

namespace {

struct Settings {
  const char* match = nullptr;
  long long after = 0;
  long long calls = -1;  // -1: every call fails once the limit is reached
};

const Settings& settings() {
  static const Settings s = [] {
    Settings r;
    r.match = getenv("MESOROCK_FAIL_WRITES_TO");
    if (r.match && !*r.match) r.match = nullptr;
    if (const char* a = getenv("MESOROCK_FAIL_WRITES_AFTER")) r.after = atoll(a);
    if (const char* c = getenv("MESOROCK_FAIL_WRITES_CALLS")) r.calls = atoll(c);
    return r;
  }();
  return s;
}

std::atomic<long long> written{0};  // bytes taken by the matching files so far
std::atomic<long long> failed_calls{0};

bool matches(int fd) {
  const Settings& s = settings();
  if (!s.match) return false;
  struct stat st;
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return false;
  char link[64], target[4096];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, target, sizeof target - 1);
  if (n <= 0) return false;
  target[n] = '\0';
  return strstr(target, s.match) != nullptr;
}

// How many of `want` bytes the "disk" takes: all of them, part (the limit is crossed), or none
// (-1, errno = ENOSPC).
long long allowance(int fd, long long want) {
  if (want <= 0 || !matches(fd)) return want;
  const Settings& s = settings();
  const long long before = written.fetch_add(want);
  if (before + want <= s.after) return want;
  if (before < s.after) {
    written.fetch_sub(before + want - s.after);
    return s.after - before;  // cut short at the limit, as a full disk does
  }
  written.fetch_sub(want);
  if (s.calls >= 0 && failed_calls.fetch_add(1) >= s.calls) return want;  // room again
  errno = ENOSPC;
  return -1;
}

template <class F>
F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

}  // namespace

extern "C" {

ssize_t write(int fd, const void* buf, size_t count) {
  static auto real = next<ssize_t (*)(int, const void*, size_t)>("write");
  const long long n = allowance(fd, static_cast<long long>(count));
  if (n < 0) return -1;
  return real(fd, buf, static_cast<size_t>(n));
}

ssize_t pwrite(int fd, const void* buf, size_t count, off_t offset) {
  static auto real = next<ssize_t (*)(int, const void*, size_t, off_t)>("pwrite");
  const long long n = allowance(fd, static_cast<long long>(count));
  if (n < 0) return -1;
  return real(fd, buf, static_cast<size_t>(n), offset);
}

ssize_t pwrite64(int fd, const void* buf, size_t count, off64_t offset) {
  static auto real = next<ssize_t (*)(int, const void*, size_t, off64_t)>("pwrite64");
  const long long n = allowance(fd, static_cast<long long>(count));
  if (n < 0) return -1;
  return real(fd, buf, static_cast<size_t>(n), offset);
}

ssize_t writev(int fd, const struct iovec* iov, int iovcnt) {
  static auto real = next<ssize_t (*)(int, const struct iovec*, int)>("writev");
  long long total = 0;
  for (int i = 0; i < iovcnt; ++i) total += static_cast<long long>(iov[i].iov_len);
  const long long n = allowance(fd, total);
  if (n < 0) return -1;
  if (n == total) return real(fd, iov, iovcnt);
  // Cut short: write only the first n bytes.
  long long left = n, done = 0;
  for (int i = 0; i < iovcnt && left > 0; ++i) {
    const size_t part = static_cast<size_t>(left < static_cast<long long>(iov[i].iov_len)
                                                ? left
                                                : static_cast<long long>(iov[i].iov_len));
    static auto real_write = next<ssize_t (*)(int, const void*, size_t)>("write");
    const ssize_t w = real_write(fd, iov[i].iov_base, part);
    if (w < 0) return done > 0 ? done : w;
    done += w;
    left -= w;
  }
  return done;
}

size_t fwrite(const void* ptr, size_t size, size_t nmemb, FILE* stream) {
  static auto real = next<size_t (*)(const void*, size_t, size_t, FILE*)>("fwrite");
  if (size == 0 || nmemb == 0) return real(ptr, size, nmemb, stream);
  const long long want = static_cast<long long>(size * nmemb);
  const long long n = allowance(fileno(stream), want);
  if (n < 0) return 0;
  if (n == want) return real(ptr, size, nmemb, stream);
  return real(ptr, 1, static_cast<size_t>(n), stream) / size;
}

}  // extern "C"
