#pragma once
/// A text progress bar on stderr: redrawn in place on a terminal, a line every 10 % otherwise
/// (so CI logs stay short).

#include <unistd.h>

#include <cstdio>
#include <string>

#include "common/timer.h"

namespace twocam::tools {

class ProgressBar {
 public:
  ProgressBar(std::string label, int total, bool enabled = true)
      : label_(std::move(label)),
        total_(total),
        enabled_(enabled),
        tty_(isatty(fileno(stderr)) != 0) {}

  void update(int done) {
    if (!enabled_ || total_ <= 0) return;
    const int pct = static_cast<int>(100.0 * done / total_);
    const double s = start_.elapsedS();
    const double rate = s > 0 ? done / s : 0.0;
    if (tty_) {
      constexpr int kWidth = 30;
      const int filled = kWidth * done / total_;
      std::fprintf(stderr,
                   "\r%s [%s%s] %d/%d %3d%% %.1f/s ",
                   label_.c_str(),
                   std::string(filled, '#').c_str(),
                   std::string(kWidth - filled, '.').c_str(),
                   done,
                   total_,
                   pct,
                   rate);
      if (done == total_) std::fprintf(stderr, "\n");
      std::fflush(stderr);
    } else if (pct / 10 != last_decile_ || done == total_) {
      last_decile_ = pct / 10;
      std::fprintf(stderr, "%s %d/%d (%d%%, %.1f/s)\n", label_.c_str(), done, total_, pct, rate);
    }
  }

 private:
  std::string label_;
  int total_;
  bool enabled_;
  bool tty_;
  int last_decile_ = -1;
  Timer start_;  // from construction
};

}  // namespace twocam::tools
