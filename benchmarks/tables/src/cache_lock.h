// An exclusive flock on a file for the lifetime of the object, so that processes sharing a table
// cache (ctest -j, concurrent `panoscan tables` runs) simulate each scan and build each panorama once.
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>

#include "panoscan/core/error.h"

namespace panoscan::tables {

class CacheLock {
 public:
  explicit CacheLock(const std::filesystem::path& path) {
    fd_ = ::open(path.c_str(), O_CREAT | O_RDWR, 0644);
    if (fd_ < 0) throw make_error(path.string(), "", "cannot open the cache lock file");
    if (::flock(fd_, LOCK_EX) != 0) {
      ::close(fd_);
      throw make_error(path.string(), "", "cannot lock the cache");
    }
  }
  ~CacheLock() {
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }
  CacheLock(const CacheLock&) = delete;
  CacheLock& operator=(const CacheLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace panoscan::tables
