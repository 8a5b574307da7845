#include "io/trajectory.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace twocam::io {

std::string toTum(const std::vector<TimedPose>& poses, const std::string& comment) {
  std::string out;
  if (!comment.empty()) out += "# " + comment + "\n";
  out += "# t x y z qx qy qz qw\n";
  char line[256];
  for (const TimedPose& p : poses) {
    const Eigen::Quaterniond q(p.T_w_b.linear());
    const Eigen::Vector3d& t = p.T_w_b.translation();
    const int64_t s = p.t_ns / 1000000000;
    const int64_t ns = p.t_ns % 1000000000;
    std::snprintf(line,
                  sizeof(line),
                  "%lld.%09lld %.7f %.7f %.7f %.9f %.9f %.9f %.9f\n",
                  static_cast<long long>(s),
                  static_cast<long long>(ns < 0 ? -ns : ns),
                  t.x(),
                  t.y(),
                  t.z(),
                  q.x(),
                  q.y(),
                  q.z(),
                  q.w());
    out += line;
  }
  return out;
}

Status parseTum(const std::string& text, std::vector<TimedPose>* poses) {
  poses->clear();
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double v[8];
    int n = 0;
    std::string token;
    while (fields >> token) {
      if (n == 8)
        return Status::error("TUM line " + std::to_string(line_no) + ": more than 8 fields");
      char* end = nullptr;
      v[n] = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0' || !std::isfinite(v[n])) {
        return Status::error("TUM line " + std::to_string(line_no) + ": '" + token +
                             "' is not a finite number");
      }
      ++n;
    }
    if (n != 8)
      return Status::error("TUM line " + std::to_string(line_no) + ": expected 8 fields, got " +
                           std::to_string(n));
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      return Status::error("TUM line " + std::to_string(line_no) + ": quaternion norm " +
                           std::to_string(q.norm()) + " is not 1");
    }
    q.normalize();
    TimedPose p;
    p.t_ns = std::llround(v[0] * 1e9);
    p.T_w_b.linear() = q.toRotationMatrix();
    p.T_w_b.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    poses->push_back(p);
  }
  return Status::ok();
}

}  // namespace twocam::io
