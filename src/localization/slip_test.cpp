#include "localization/slip_test.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "common/status.h"
#include "localization/pose_update.h"

namespace twocam::localization {

Eigen::Matrix3d stepCovariance(const OdometryNoise& noise,
                               const Pose2& increment,
                               const Pose2& step,
                               const Eigen::Matrix3d& previous_cov,
                               const Eigen::Matrix3d& step_cov) {
  const Pose2 motion = toPose2(toIsometry(increment) * toIsometry(step));
  return step_cov + previous_cov +
         odometryCovariance(noise, std::hypot(motion.x_m, motion.y_m), std::abs(motion.yaw_rad));
}

Pose2 odometryError(const Pose2& T_w_b_from, const Pose2& odometry_motion, const Pose2& T_w_b_to) {
  return toPose2((toIsometry(T_w_b_from) * toIsometry(odometry_motion)).inverse() *
                 toIsometry(T_w_b_to));
}

SlipTest::SlipTest(const SlipTestOptions& options) : options_(options) {
  const Status st = options.validate();
  TWOCAM_CHECK(st.isOk()) << "invalid SlipTestOptions: " << st.message();
}

int32_t SlipTest::add(int32_t frame, const Pose2& error, const Eigen::Matrix3d& cov) {
  const auto w = static_cast<size_t>(options_.window_frames);
  window_.push_back({frame, Eigen::Vector3d(error.x_m, error.y_m, error.yaw_rad), cov});
  if (window_.size() > w) window_.erase(window_.begin());
  if (window_.size() < w) return -1;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_cov = Eigen::Matrix3d::Zero();
  for (const Entry& e : window_) {
    sum += e.error;
    sum_cov += e.cov;
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(sum_cov);
  if (ldlt.info() != Eigen::Success || sum.dot(ldlt.solve(sum)) <= options_.chi2) return -1;
  size_t worst = 0;
  double worst_chi2 = -1.0;
  for (size_t k = 0; k < window_.size(); ++k) {
    const double c = window_[k].error.dot(window_[k].cov.ldlt().solve(window_[k].error));
    if (c > worst_chi2) {
      worst_chi2 = c;
      worst = k;
    }
  }
  if (window_[worst].frame <= last_slip_frame_) return -1;
  last_slip_frame_ = window_[worst].frame;
  return last_slip_frame_;
}

}  // namespace twocam::localization
