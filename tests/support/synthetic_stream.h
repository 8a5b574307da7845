#pragma once
/// A seeded synthetic stream of frontend output for landmark tests and benchmarks, without
/// rendering: world points on the walls of a room, a robot driving a circle in it with noisy
/// wheel odometry, and per frame the stereo hypotheses a frontend would hand over: the true
/// disparity (with noise) for detected points, plus rivals that behave like the spurious matches
/// of a periodic texture (disparity offset by a fixed world period, so the phantom point moves
/// consistently but wrongly) or like random mismatches. The truth of every hypothesis is known.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"

namespace twocam::test {

struct SyntheticStreamOptions {
  int num_points = 3000;
  /// Room [m]: walls at x = +-half_x, y = +-half_y; points at heights [0.2, 2.5] m.
  double half_x_m = 5.0;
  double half_y_m = 3.0;
  /// The robot drives a circle of this radius about the origin [m] at this speed [m/s].
  double circle_radius_m = 2.0;
  double speed_mps = 0.4;
  double rate_hz = 15.0;
  /// Wheel odometry errors (same model as the simulator's): [m/sqrt(m)], [rad/sqrt(rad)], [-], [-].
  double odom_sigma_per_m = 0.02;
  double odom_sigma_per_rad = 0.03;
  double odom_scale_error = 0.01;
  double odom_wheel_base_error = 0.01;
  /// Probability that a visible point yields a corner in a frame [-].
  double detection_prob = 0.8;
  /// Disparity noise of true hypotheses [px].
  double disparity_sigma_px = 0.25;
  /// Fraction of points with a periodic-texture rival, and of points with a random rival [-].
  double periodic_rival_fraction = 0.5;
  double random_rival_prob = 0.3;
  /// Probability that a rival has the lower cost (rank 0) [-].
  double rival_wins_prob = 0.3;
  /// Disparity search range of the simulated frontend [px].
  double max_disparity_px = 63.0;
  /// Mark every point's hypothesis list complete (SalientPoint::complete), which is true here:
  /// the real match is always listed.
  bool complete_lists = false;
  /// Probability that the real match is listed twice, the twin up to 0.6 px away: one
  /// disparity found by two of the frontend's cost curves (window alignments) as integer
  /// minima 1 px apart [-]. The twin counts as real (it is within 1 px of the truth).
  double twin_prob = 0.0;
  uint64_t seed = 1;
};

struct SyntheticFrame {
  int32_t frame = 0;
  int64_t t_ns = 0;
  Pose2 true_pose;
  Pose2 odom_pose;
  StereoHypotheses hypotheses;
  /// Per hypothesis: 1 when it is the real match.
  std::vector<uint8_t> hypothesis_true;
  /// Per hypothesis: 0 real match, 1 periodic-texture rival, 2 random rival.
  std::vector<uint8_t> hypothesis_kind;
  /// Per hypothesis: the world point it belongs to (the real one, whatever its truth).
  std::vector<int32_t> hypothesis_point;
};

class SyntheticStream {
 public:
  SyntheticStream(const StereoRig& rig, const SyntheticStreamOptions& options);
  /// Fills the next frame (frame 0 at the start pose).
  void next(SyntheticFrame* out);
  [[nodiscard]] const std::vector<Eigen::Vector3d>& points() const { return points_w_; }
  /// The rig used: office-like, left camera 0.5 m high, pitched down 5 degrees.
  static StereoRig defaultRig();

 private:
  StereoRig rig_;
  SyntheticStreamOptions options_;
  std::mt19937_64 rng_;
  std::vector<Eigen::Vector3d> points_w_;
  std::vector<double> period_m_;  // 0 = no periodic rival
  int32_t frame_ = 0;
  double angle_rad_ = 0.0;
  Pose2 true_pose_;
  Pose2 odom_pose_;
};

}  // namespace twocam::test
