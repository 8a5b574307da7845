#pragma once
/// Silences the C library's stderr (file descriptor 2) for the lifetime of a scope: libpng and
/// other C libraries print there ("libpng error: ...") before the C++ caller learns of the
/// failure, which TwoCam then reports in its own words. Process-wide while it lives, so use it
/// around single-threaded library calls only.

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>

namespace twocam {

class QuietStderr {
 public:
  QuietStderr() : saved_(::dup(2)), null_fd_(::open("/dev/null", O_WRONLY)) {
    std::fflush(stderr);
    if (saved_ >= 0 && null_fd_ >= 0) ::dup2(null_fd_, 2);
  }
  ~QuietStderr() {
    std::fflush(stderr);
    if (saved_ >= 0) {
      ::dup2(saved_, 2);
      ::close(saved_);
    }
    if (null_fd_ >= 0) ::close(null_fd_);
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_;
  int null_fd_;
};

}  // namespace twocam
