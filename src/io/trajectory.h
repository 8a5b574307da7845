#pragma once
/// Trajectories as TUM text files (Sturm et al., IROS 2012): one pose per line,
/// "t x y z qx qy qz qw" with t in seconds and the body pose in the world frame; lines starting
/// with '#' are comments.

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"

namespace twocam::io {

struct TimedPose {
  int64_t t_ns = 0;
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
};

/// TUM text of a trajectory, with `comment` (may be empty) as a leading '#' line. Time stamps
/// are written with nanosecond resolution, positions with 0.1 um.
std::string toTum(const std::vector<TimedPose>& poses, const std::string& comment);

/// Parses TUM text. Errors name the line: wrong number of fields, non-numbers, a quaternion far
/// from unit norm (it is normalised when within 1e-3).
Status parseTum(const std::string& text, std::vector<TimedPose>* poses);

}  // namespace twocam::io
