#include "io/json.h"

#include <cmath>
#include <cstdio>

namespace twocam::io {
namespace {

bool isScalar(const Json& v) { return !v.is_object() && !v.is_array(); }

/// Containers with more members than this are broken over lines (below the top level).
constexpr size_t kMaxInlineMembers = 12;

void writeScalar(const Json& v, int digits, std::string* out) {
  if (v.is_number_float()) {
    const double x = v.get<double>();
    if (!std::isfinite(x)) {
      *out += "null";
      return;
    }
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.*g", digits, x);
    *out += buf;
    return;
  }
  *out += v.dump(-1, ' ', false, Json::error_handler_t::replace);
}

void write(const Json& v, int digits, int depth, std::string* out) {
  if (isScalar(v)) {
    writeScalar(v, digits, out);
    return;
  }
  const bool object = v.is_object();
  const char open = object ? '{' : '[';
  const char close = object ? '}' : ']';
  if (v.empty()) {
    *out += open;
    *out += close;
    return;
  }
  const bool inline_members = depth > 0 && v.size() <= kMaxInlineMembers;
  const std::string indent(static_cast<size_t>(2 * (depth + 1)), ' ');
  *out += open;
  bool first = true;
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (!first) *out += inline_members ? ", " : ",";
    if (!inline_members) *out += "\n" + indent;
    first = false;
    if (object) {
      *out += Json(it.key()).dump(-1, ' ', false, Json::error_handler_t::replace);
      *out += ": ";
    }
    write(*it, digits, depth + 1, out);
  }
  if (!inline_members) *out += "\n" + std::string(static_cast<size_t>(2 * depth), ' ');
  *out += close;
}

}  // namespace

std::string toJsonText(const Json& value, int significant_digits) {
  std::string out;
  write(value, significant_digits, 0, &out);
  out += '\n';
  return out;
}

Json numberOrNull(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }

}  // namespace twocam::io
