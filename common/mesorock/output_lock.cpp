#include "mesorock/output_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <system_error>
#include <thread>

#include "mesorock/errors.h"

namespace fs = std::filesystem;

namespace mesorock {

namespace {

// "1234 rockflow": the pid and the program, as the holder wrote them (it writes them just after
// it takes the lock, so an empty file is read again for a moment).
std::string holder_of(const fs::path& file) {
  for (int attempt = 0; attempt < 20; ++attempt) {
    std::ifstream in(file);
    std::string pid, program;
    in >> pid >> program;
    if (!pid.empty()) return "pid " + pid + (program.empty() ? "" : ", " + program);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return "pid unknown";
}

std::string program_name() {
  std::ifstream in("/proc/self/comm");
  std::string name;
  std::getline(in, name);
  return name;
}

// Temporaries of an earlier process that was killed before it could remove them: the folder's
// owner is this process now, so none of them can be in use.
void remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const std::string suffix = ".partial";
    if (name.size() > suffix.size() + 1 && name[0] == '.' &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      std::error_code ignored;
      fs::remove_all(it->path(), ignored);
    }
  }
}

}  // namespace

OutputLock::OutputLock(const fs::path& dir, const std::string& what) : dir_(dir) {
  const std::string name = what + " " + dir.string();
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) throw IoError(name + ": exists and is not a folder");
  } else {
    if (!fs::create_directories(dir, ec) && ec) {
      for (fs::path q = dir.parent_path(); !q.empty() && q != q.parent_path(); q = q.parent_path())
        if (fs::exists(q) && !fs::is_directory(q))
          throw IoError(name + ": " + q.string() + " is a file, not a folder");
      throw IoError(name + ": cannot create the folder: " + ec.message());
    }
    created_dir_ = true;
  }
  file_ = dir / kFileName;
  // The last owner removes the file when it lets go: a lock taken on a file that was removed
  // meanwhile is no lock at all, so the file locked must still be the one at the path.
  for (int attempt = 0; attempt < 100 && fd_ < 0; ++attempt) {
    const int fd = ::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      const int e = errno;
      if (created_dir_) fs::remove(dir_, ec);
      throw IoError(name + ": cannot write in this folder: " + std::strerror(e));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      ::close(fd);
      if (e == EWOULDBLOCK)
        throw ConfigError(name + ": in use by another process (" + holder_of(file_) +
                          "): one command at a time writes a folder; wait for it to end or "
                          "choose another folder");
      throw IoError(name + ": cannot lock " + file_.string() + ": " + std::strerror(e));
    }
    struct stat held {
    }, now{};
    if (::fstat(fd, &held) == 0 && ::stat(file_.c_str(), &now) == 0 && held.st_dev == now.st_dev &&
        held.st_ino == now.st_ino)
      fd_ = fd;
    else
      ::close(fd);
  }
  if (fd_ < 0) throw IoError(name + ": cannot lock " + file_.string() + ": it keeps changing");
  const std::string holder = std::to_string(::getpid()) + " " + program_name() + "\n";
  if (::ftruncate(fd_, 0) != 0 ||
      ::pwrite(fd_, holder.data(), holder.size(), 0) != static_cast<ssize_t>(holder.size())) {
    const int e = errno;
    ::unlink(file_.c_str());
    ::close(fd_);
    fd_ = -1;
    throw IoError(file_.string() + ": cannot write: " + std::strerror(e));
  }
  remove_stale_temporaries(dir_);
}

void OutputLock::remove_earlier_record(const std::string& name) const {
  const fs::path record = dir_ / name;
  std::error_code ec;
  if (fs::is_directory(record, ec))
    throw IoError(record.string() + ": a folder is where this command writes its record");
  if (!fs::remove(record, ec) && ec)
    throw IoError(record.string() + ": cannot remove the earlier record: " + ec.message());
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(file_.c_str());  // before the unlock: a waiting process then sees another file
  ::close(fd_);
  std::error_code ec;
  if (created_dir_) fs::remove(dir_, ec);  // only when empty: nothing was written into it
}

}  // namespace mesorock
