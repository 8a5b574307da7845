#pragma once
/// Wall-clock stopwatch on the monotonic clock, for per-frame stage times and run summaries.

#include <chrono>

namespace twocam {

/// Starts on construction; elapsedMs() reads it without stopping, restart() sets zero again.
class Timer {
 public:
  Timer() : start_(Clock::now()) {}
  void restart() { start_ = Clock::now(); }
  /// Milliseconds since construction or the last restart().
  [[nodiscard]] double elapsedMs() const {
    return std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
  }
  [[nodiscard]] double elapsedS() const { return elapsedMs() * 1e-3; }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_;
};

}  // namespace twocam
