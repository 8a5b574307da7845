#include "pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <vector>

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

}  // namespace
}  // namespace twocam::pipeline
