#pragma once
/// Range checks for Options::validate(), with one wording for every module:
///   "<key> = <value>; must be in [lo, hi] [unit]"   (checkRange)
///   "<key> = <value>; must be > 0 [unit]"           (checkPositive)
///   "<key> = <value>; must be a finite number"      (checkFinite)
/// NaN fails every check. Each returns Status::ok() when the value is fine, so that checks
/// chain: `if (Status s = checkRange(...); !s) return s;`.

#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>

#include "common/status.h"

namespace twocam {

namespace internal {
template <typename T>
std::string optionValueText(T value) {
  std::ostringstream os;
  if constexpr (std::is_floating_point_v<T>) os.precision(17);
  os << value;
  return os.str();
}
inline std::string unitSuffix(const char* unit) {
  return unit == nullptr || *unit == '\0' ? std::string() : std::string(" [") + unit + "]";
}
}  // namespace internal

/// value must be finite (floating point) and in [lo, hi].
template <typename T>
[[nodiscard]] Status checkRange(
    const std::string& key, T value, T lo, T hi, const char* unit = "") {
  bool ok = value >= lo && value <= hi;
  if constexpr (std::is_floating_point_v<T>) ok = ok && std::isfinite(value);
  if (ok) return Status::ok();
  return Status::error(key + " = " + internal::optionValueText(value) + "; must be in [" +
                       internal::optionValueText(lo) + ", " + internal::optionValueText(hi) + "]" +
                       internal::unitSuffix(unit));
}

/// value must be finite and > 0.
template <typename T>
[[nodiscard]] Status checkPositive(const std::string& key, T value, const char* unit = "") {
  bool ok = value > T{0};
  if constexpr (std::is_floating_point_v<T>) ok = ok && std::isfinite(value);
  if (ok) return Status::ok();
  return Status::error(key + " = " + internal::optionValueText(value) + "; must be > 0" +
                       internal::unitSuffix(unit));
}

/// value must be a finite number.
[[nodiscard]] inline Status checkFinite(const std::string& key, double value) {
  if (std::isfinite(value)) return Status::ok();
  return Status::error(key + " = " + internal::optionValueText(value) +
                       "; must be a finite number");
}

}  // namespace twocam
