#pragma once
/// A landmark's tracker record and its observations (landmarks/landmark_database.h).
///
/// Frames: w = odometry world frame, cl = left camera optical frame.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/frames.h"

namespace twocam::landmarks {

/// One associated stereo measurement of a landmark, with the odometry pose of its frame.
struct Observation {
  int32_t frame = 0;
  float u_px = 0.0f;
  float v_px = 0.0f;
  float d_px = 0.0f;
  Pose2 odom_pose;
};

enum class LandmarkState : uint8_t { kFree, kCandidate, kConfirmed };

/// A landmark as the tracker keeps it, whatever the policy: plain data, read through
/// LandmarkDatabase::find(). Each confirmation policy keeps its own per-landmark state beside it
/// (ConfirmationPolicy).
struct Landmark {
  uint64_t id = 0;
  LandmarkState state = LandmarkState::kFree;
  /// Position estimate in the odometry world frame [m]: the anchor's triangulation until the
  /// landmark is confirmed, then the multi-view refinement.
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  /// Position from the latest observation [m]; predictions start here so that only the odometry
  /// error since the landmark was last seen enters the gate.
  Eigen::Vector3d p_w_last = Eigen::Vector3d::Zero();
  /// The observation that created the landmark (frames counted from 0 in log order).
  Observation anchor;
  int32_t first_frame = 0;
  int32_t confirmed_frame = -1;
  int32_t last_seen_frame = 0;
  /// The last frame whose pose predicted it in view (seen or not); -1 never.
  int32_t last_visible_frame = -1;
  int64_t first_t_ns = 0;
  /// Odometry path length and absolute turn (since the run started) when last seen [m], [rad].
  double path_at_last_seen_m = 0.0;
  double turn_at_last_seen_rad = 0.0;
  /// The confirmation policy's confidence in [0, 1] (consistency: rival-normalised existence
  /// probability; ConfirmationPolicy). The candidate cap drops the least confident first.
  float confidence = 0.0f;
  int32_t n_obs = 0;
  int32_t n_visible = 0;
  int32_t consecutive_misses = 0;
  int32_t frames_out_of_view = 0;
  /// Candidates: the anchor plus the most recent observations (at most
  /// TrackerOptions::max_observations), for the refinement at confirmation. Emptied when the
  /// landmark is confirmed (confirmed landmarks are not re-refined).
  std::vector<Observation> observations;
};

}  // namespace twocam::landmarks
