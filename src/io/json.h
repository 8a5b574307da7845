#pragma once
/// JSON values (nlohmann-json, Debian's nlohmann-json3-dev) and TwoCam's one JSON text writer.
///
/// Values are nlohmann::ordered_json, so keys keep the order in which the schema adds them. The
/// writer differs from nlohmann's dump() in two ways that keep run outputs comparable across
/// versions: floating-point numbers are printed with a fixed number of significant digits
/// (printf "%.<digits>g", as TwoCam's writers always did: metrics.json 10, timing.json 6) instead
/// of the shortest round-trip form, and a non-finite number is written as null (JSON has no NaN).
/// Layout, that of TwoCam's hand-written JSON before it: the top-level value and any object or
/// array of more than 12 members are broken over lines (two spaces of indent per level), every
/// other one goes on one line (`"mapping": {"resolution_m": 0.05, "occupied_voxels": 14256}`).
/// So a metrics.json differs from an earlier version's only in the lines of keys that changed.

#include <nlohmann/json.hpp>
#include <string>

namespace twocam::io {

using Json = nlohmann::ordered_json;

/// Significant digits of floating-point numbers in metrics.json (the compare script's
/// precision, scripts/compare_runs.py).
constexpr int kMetricsJsonDigits = 10;

/// JSON text of `value`, ending in a newline. Strings are escaped by nlohmann (invalid UTF-8 is
/// replaced by U+FFFD rather than thrown on: a log path is bytes).
[[nodiscard]] std::string toJsonText(const Json& value, int significant_digits);

/// A finite number as JSON, or null for NaN and infinities (a metric that has no value, e.g. a
/// precision over zero landmarks).
[[nodiscard]] Json numberOrNull(double value);

}  // namespace twocam::io
