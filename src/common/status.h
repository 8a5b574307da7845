#pragma once
/// Error handling after Ceres' three tiers (see ../shared/STYLE.md §5):
/// TWOCAM_CHECK for broken invariants, Status for bad input or config.

#include <sstream>
#include <string>
#include <utility>

namespace twocam {

/// Result of an operation that can fail because of bad input or configuration.
/// Default-constructed Status is OK. The message names what was wrong. [[nodiscard]]: a
/// Status that nobody reads is an error that nobody handles.
class [[nodiscard]] Status {
 public:
  Status() = default;
  static Status ok() { return Status(); }
  static Status error(std::string message) { return Status(std::move(message), true); }

  [[nodiscard]] bool isOk() const { return !failed_; }
  explicit operator bool() const { return !failed_; }
  [[nodiscard]] const std::string& message() const { return message_; }

 private:
  Status(std::string message, bool failed) : message_(std::move(message)), failed_(failed) {}
  std::string message_;
  bool failed_ = false;
};

namespace internal {
/// Collects the streamed explanation of a failed TWOCAM_CHECK and aborts on destruction.
class CheckFailure {
 public:
  CheckFailure(const char* file, int line, const char* condition);
  [[noreturn]] ~CheckFailure();
  template <typename T>
  CheckFailure& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }

 private:
  std::ostringstream stream_;
};
}  // namespace internal

}  // namespace twocam

/// Always-on invariant check: aborts with file, line, condition and the streamed message.
#define TWOCAM_CHECK(condition) \
  if (condition) {              \
  } else                        \
    ::twocam::internal::CheckFailure(__FILE__, __LINE__, #condition)
