#pragma once
/// What TwoCam's rawlog writer and reader share (internal to src/io): the header and end
/// comments of a TwoCam log and the conversions of time stamps and poses to and from MRPT.

#include <mrpt/core/Clock.h>
#include <mrpt/math/CMatrixFixed.h>
#include <mrpt/poses/CPose3D.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cstdint>
#include <limits>

namespace twocam::io::internal {

inline constexpr const char* kHeaderPrefix = "twocam rawlog v1";
inline constexpr const char* kEndPrefix = "twocam rawlog end";
/// Last field of the header of a log with synthetic odometry, followed by the note.
inline constexpr const char* kSyntheticOdometryField = "; synthetic odometry: ";

inline mrpt::Clock::time_point toMrptTime(int64_t t_ns) {
  return mrpt::Clock::time_point(
      std::chrono::duration_cast<mrpt::Clock::duration>(std::chrono::nanoseconds(t_ns)));
}
/// MRPT time stamps count 100 ns ticks since 1601-01-01 (Windows FILETIME). TwoCam's writer
/// stores t_ns directly as ticks (simulated runs start at 1 s; EuRoC's UNIX-epoch stamps land
/// in the 17th century), and those come back unchanged. Logs recorded by MRPT tools with a real
/// clock (mrpt::Clock::now()) hold ticks whose nanosecond count overflows int64 (any date after
/// 1893): they are returned as UNIX-epoch ns instead. Nonsense stamps (corrupt logs) saturate
/// rather than overflow.
inline int64_t fromMrptTime(mrpt::Clock::time_point t) {
  constexpr int64_t kNsPerTick = 100;
  constexpr int64_t kMaxDirectTicks = std::numeric_limits<int64_t>::max() / kNsPerTick;
  constexpr int64_t kUnixEpochTicks = 116'444'736'000'000'000LL;  // 1970-01-01 on MRPT's clock
  const int64_t ticks = t.time_since_epoch().count();
  if (ticks < -kMaxDirectTicks) return std::numeric_limits<int64_t>::min();
  if (ticks <= kMaxDirectTicks) return ticks * kNsPerTick;
  if (ticks - kUnixEpochTicks > kMaxDirectTicks) return std::numeric_limits<int64_t>::max();
  return (ticks - kUnixEpochTicks) * kNsPerTick;
}

inline mrpt::poses::CPose3D toMrptPose(const Eigen::Isometry3d& T) {
  mrpt::math::CMatrixDouble44 M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = T.matrix()(r, c);
  return mrpt::poses::CPose3D(M);
}
inline Eigen::Isometry3d fromMrptPose(const mrpt::poses::CPose3D& p) {
  const auto M = p.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = M(r, c);
  return T;
}

}  // namespace twocam::io::internal
