#include "pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "localization/pose_update.h"
#include "support/synthetic_stream.h"

namespace twocam::pipeline {
namespace {

TEST(Pipeline, RowSupportIsOnForRunsAndSkippedForFrontendOnlyRuns) {
  PipelineConfig config;
  ASSERT_TRUE(config.frontend.sad.row_support) << "twocam run's defaults measure row support";
  const StereoRig rig;
  ASSERT_TRUE(clampToRig(rig, &config).isOk());
  Pipeline pipe(rig, config);
  EXPECT_TRUE(pipe.frontend().options().sad.row_support);
  pipe.skipRowSupport();
  EXPECT_FALSE(pipe.frontend().options().sad.row_support);
  // Everything else of the frontend is kept.
  EXPECT_EQ(pipe.frontend().options().harris.target_count, config.frontend.harris.target_count);
  EXPECT_EQ(pipe.frontend().options().sad.window_width_px, config.frontend.sad.window_width_px);
}

/// A fronto-parallel textured plane at disparity `d` [px] filling the rig's view: 4x4-pixel
/// blocks of seeded random grey (corners on every block edge), the right view shifted by d.
StereoFrame planeFrame(const StereoRig& rig, int d, int64_t t_ns) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> grey(20, 235);
  const int block = 4;
  const int cols = (rig.width_px + d) / block + 2;
  std::vector<uint8_t> blocks(static_cast<size_t>(cols) * (rig.height_px / block + 2));
  for (uint8_t& b : blocks) b = static_cast<uint8_t>(grey(rng));
  const auto texture = [&](int x, int y) {
    return blocks[static_cast<size_t>(y / block) * cols + x / block];
  };
  StereoFrame frame;
  frame.t_ns = t_ns;
  frame.left = ImageU8(rig.width_px, rig.height_px);
  frame.right = ImageU8(rig.width_px, rig.height_px);
  for (int v = 0; v < rig.height_px; ++v) {
    for (int u = 0; u < rig.width_px; ++u) {
      frame.left(u, v) = texture(u, v);
      frame.right(u, v) = texture(u + d, v);  // right(u - d, v) = left(u, v)
    }
  }
  return frame;
}

// twocam run re-measures candidates whose corner it did not find (probe_unseen): the same
// images after a sideways move of 10 cm put every prediction about 14 px from its corner (more
// than the gate), and the plane is still at the predicted disparity there. Replayed
// hypotheses have no images, so nothing is re-measured.
TEST(Pipeline, ProcessReMeasuresUnassociatedCandidatesOnTheFrame) {
  constexpr int kDisparityPx = 17;
  for (const bool probe_unseen : {true, false}) {
    PipelineConfig config;
    config.landmarks.consistency.probe_unseen = probe_unseen;
    const StereoRig rig;
    ASSERT_TRUE(clampToRig(rig, &config).isOk());
    Pipeline pipe(rig, config);
    const StereoFrame frame = planeFrame(rig, kDisparityPx, 0);
    FrameOutput out;
    ASSERT_TRUE(pipe.process(0, frame, Pose2{}, &out).isOk());
    ASSERT_GT(pipe.database().numCandidates(), 100);
    Pose2 moved;
    moved.x_m = 0.1;  // the default rig's T_b_cl is the identity: body x is the image's u
    StereoFrame again = frame;
    again.t_ns = 100'000'000;
    ASSERT_TRUE(pipe.process(1, again, moved, &out).isOk());
    const landmarks::FrameReport& report = pipe.report();
    std::printf("probe_unseen %d: %d candidates re-measured, %d found\n",
                probe_unseen ? 1 : 0,
                report.probed,
                report.probe_found);
    if (probe_unseen) {
      EXPECT_GT(report.probed, 100);
      EXPECT_GT(report.probe_found, report.probed / 2) << "the plane is at the predicted disparity";
      EXPECT_LE(report.probe_found, report.probed);
    } else {
      EXPECT_EQ(report.probed, 0);
    }
    moved.x_m = 0.2;
    ASSERT_TRUE(pipe.processHypotheses(2, 200'000'000, moved, pipe.hypotheses(), &out).isOk());
    EXPECT_EQ(pipe.report().probed, 0);
  }
}

/// Heading error of `estimate` against `truth` [deg], wrapped to (-180, 180].
double headingErrorDeg(const Pose2& estimate, const Pose2& truth) {
  return std::remainder(estimate.yaw_rad - truth.yaw_rad, 2.0 * M_PI) * 180.0 / M_PI;
}

// A heading slip during a blank stretch long enough that nothing seen before it is in view
// after it: the slip search's reference (what the last visual frames saw) cannot catch it, and
// the landmarks confirmed afterwards are placed with the slipped heading and agree with it.
// Once the earlier map's landmarks (the walls seen before the blank, from across the room or
// on the revisit) are predicted in view but not associated, the search against them
// re-anchors the pose.
TEST(Pipeline, TheEarlierMapReAnchorsAPoseThatAnUnnoticedSlipTurned) {
  constexpr uint64_t kSeed = 5;
  constexpr int kBlankStart = 150;  // frames without hypotheses (a blank turn), 6.4 s
  constexpr int kBlankFrames = 96;
  constexpr double kSlipDeg = 7.0;      // heading slip in the middle of the blank [deg]
  constexpr int kFrames = 620;          // a lap is ~470 frames: back over the start by 470
  constexpr double kSlippedDeg = 4.0;   // the slip went unnoticed: still this far off before
  constexpr double kAnchoredDeg = 1.0;  // re-anchored: within this at the end
  constexpr double kAnchoredM = 0.1;
  test::SyntheticStreamOptions so;
  so.seed = kSeed;
  so.periodic_rival_fraction = 0.2;
  so.random_rival_prob = 0.1;
  const StereoRig rig = test::SyntheticStream::defaultRig();
  for (const bool reanchor : {true, false}) {
    PipelineConfig config;
    config.localization.mode = localization::Mode::kFused;
    config.localization.search.reanchor = reanchor;
    ASSERT_TRUE(clampToRig(rig, &config).isOk());
    test::SyntheticStream stream(rig, so);
    Pipeline pipe(rig, config);
    test::SyntheticFrame f;
    FrameOutput out;
    Eigen::Isometry3d T_slip = Eigen::Isometry3d::Identity();  // applied to odometry after it
    int reanchored = 0;
    double before_revisit_deg = 0.0;
    for (int k = 0; k < kFrames; ++k) {
      stream.next(&f);
      if (k == kBlankStart + kBlankFrames / 2) {
        const Eigen::Isometry3d P = toIsometry(f.odom_pose);
        T_slip = P * toIsometry(Pose2{0.0, 0.0, kSlipDeg * M_PI / 180.0}) * P.inverse();
      }
      const Pose2 odom = localization::toPose2(T_slip * toIsometry(f.odom_pose));
      const bool blank = k >= kBlankStart && k < kBlankStart + kBlankFrames;
      const StereoHypotheses none;
      ASSERT_TRUE(pipe.processHypotheses(k, f.t_ns, odom, blank ? none : f.hypotheses, &out).isOk())
          << "frame " << k;
      reanchored += out.reanchored ? 1 : 0;
      if (k == 440) before_revisit_deg = headingErrorDeg(out.pose, f.true_pose);
    }
    const double end_deg = headingErrorDeg(out.pose, f.true_pose);
    const double end_m = std::hypot(out.pose.x_m - f.true_pose.x_m, out.pose.y_m - f.true_pose.y_m);
    std::printf(
        "re-anchoring %s: heading error %.2f deg at frame 440, %.2f deg and %.3f m at "
        "the end; %d frames re-anchored\n",
        reanchor ? "on" : "off",
        before_revisit_deg,
        end_deg,
        end_m,
        reanchored);
    if (reanchor) {
      EXPECT_GE(reanchored, 1);
      EXPECT_LT(std::abs(end_deg), kAnchoredDeg);
      EXPECT_LT(end_m, kAnchoredM);
    } else {
      // Without it the slip search alone does not notice the slip, before or after the revisit.
      EXPECT_EQ(reanchored, 0);
      EXPECT_GT(std::abs(before_revisit_deg), kSlippedDeg);
      EXPECT_GT(std::abs(end_deg), kSlippedDeg);
    }
  }
}

}  // namespace
}  // namespace twocam::pipeline
