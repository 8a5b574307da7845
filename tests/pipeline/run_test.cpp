#include "pipeline/run.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <string>
#include <vector>

namespace twocam::pipeline {
namespace {

constexpr int64_t kFramePeriodNs = 66'666'667;  // 15 Hz

StereoRig smallRig() {
  StereoRig rig;
  rig.width_px = 160;
  rig.height_px = 120;
  rig.fx_px = rig.fy_px = 150.0;
  rig.cx_px = 79.5;
  rig.cy_px = 59.5;
  return rig;
}

/// Frames of seeded noise images (the right one the left shifted by 4 px), odometry driving
/// forward; `edit` changes frame i before it is handed out.
class Frames {
 public:
  Frames(int n, std::function<void(io::LogFrame*)> edit = nullptr) {
    const StereoRig rig = smallRig();
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> grey(0, 255);
    for (int i = 0; i < n; ++i) {
      io::LogFrame f;
      f.index = i;
      f.stereo.t_ns = i * kFramePeriodNs;
      f.stereo.left = ImageU8(rig.width_px, rig.height_px);
      for (auto& p : f.stereo.left.data) p = static_cast<uint8_t>(grey(rng));
      f.stereo.right = ImageU8(rig.width_px, rig.height_px);
      for (int v = 0; v < rig.height_px; ++v) {
        for (int u = 0; u < rig.width_px; ++u)
          f.stereo.right(u, v) = f.stereo.left(std::min(rig.width_px - 1, u + 4), v);
      }
      f.odometry = OdometrySample{f.stereo.t_ns, Pose2{0.02 * i, 0.0, 0.0}};
      if (edit) edit(&f);
      frames_.push_back(f);
    }
  }
  FrameSource source() {
    return [this](io::LogFrame* f, Status* s) {
      *s = Status::ok();
      if (next_ >= frames_.size()) return false;
      *f = frames_[next_++];
      return true;
    };
  }

 private:
  std::vector<io::LogFrame> frames_;
  size_t next_ = 0;
};

PipelineConfig fittedConfig() {
  PipelineConfig config;
  EXPECT_TRUE(clampToRig(smallRig(), &config).isOk());
  return config;
}

struct Calls {
  std::vector<std::string> warnings;
  std::vector<int> frames_seen;
  std::vector<int> progress;
  int between = 0;  // between_frames calls
  RunCallbacks callbacks() {
    return {[this](const std::string& w) { warnings.push_back(w); },
            [this](const RunFrame& f) {
              frames_seen.push_back(f.log.index);
              return Status::ok();
            },
            [this](int n) { progress.push_back(n); },
            [this](Pipeline* /*pipe*/) {
              ++between;
              return Status::ok();
            }};
  }
};

TEST(PipelineRun, SkipsFramesWithoutOdometryOrRefusedByTheDatabase) {
  Frames frames(6, [](io::LogFrame* f) {
    if (f->index == 2) f->odometry.reset();
    if (f->index == 4) f->odometry->pose.x_m = std::numeric_limits<double>::quiet_NaN();
  });
  pipeline::Run run(smallRig(), fittedConfig());
  Calls calls;
  ASSERT_TRUE(run.execute(frames.source(), "test.rawlog", std::nullopt, calls.callbacks()).isOk());
  const RunSummary& s = run.summary();
  EXPECT_TRUE(s.odometry_mode);
  EXPECT_EQ(s.frames, 6);
  EXPECT_EQ(s.processed, 4);
  EXPECT_EQ(s.skipped, 2);
  ASSERT_EQ(calls.warnings.size(), 2u);
  EXPECT_NE(calls.warnings[0].find("skipping frame 2"), std::string::npos) << calls.warnings[0];
  EXPECT_NE(calls.warnings[1].find("skipping"), std::string::npos) << calls.warnings[1];
  EXPECT_EQ(calls.frames_seen, (std::vector<int>{0, 1, 3, 5}));
  EXPECT_EQ(calls.between, 4) << "once after each processed frame";
  EXPECT_EQ(calls.progress, (std::vector<int>{1, 2, 3, 4, 5, 6}));
  ASSERT_EQ(s.records.size(), 4u);
  EXPECT_EQ(s.records[2].frame, 3);
  EXPECT_EQ(s.odom_track.size(), 4u);
  EXPECT_GT(s.sum_corners, 0);
  EXPECT_GE(s.wall_ms, 0.0);
}

TEST(PipelineRun, WithoutFrameRecordsKeepsTheCountsOnly) {
  Frames frames(6);
  RunOptions options;
  options.keep_frame_records = false;
  pipeline::Run run(smallRig(), fittedConfig(), options);
  Calls calls;
  ASSERT_TRUE(run.execute(frames.source(), "t", std::nullopt, calls.callbacks()).isOk());
  const RunSummary& s = run.summary();
  EXPECT_EQ(s.processed, 6);
  EXPECT_EQ(calls.frames_seen.size(), 6u) << "the callbacks still see every frame";
  EXPECT_GT(s.sum_corners, 0);
  EXPECT_TRUE(s.records.empty());
  EXPECT_TRUE(s.odom_track.empty());
  EXPECT_TRUE(s.pose_track.empty());
  EXPECT_TRUE(s.landmarks_used.empty());
  EXPECT_TRUE(s.landmarks_observed.empty());
}

TEST(PipelineRun, ALogWithoutOdometryRunsTheFrontendOnly) {
  Frames frames(3, [](io::LogFrame* f) { f->odometry.reset(); });
  pipeline::Run run(smallRig(), fittedConfig());
  Calls calls;
  ASSERT_TRUE(run.execute(frames.source(), "euroc.rawlog", std::nullopt, calls.callbacks()).isOk());
  EXPECT_FALSE(run.summary().odometry_mode);
  EXPECT_EQ(run.summary().processed, 3);
  EXPECT_TRUE(run.summary().odom_track.empty());
  EXPECT_EQ(run.pipeline().database().numCandidates() + run.pipeline().database().numConfirmed(),
            0);
  ASSERT_EQ(calls.warnings.size(), 1u);
  EXPECT_NE(calls.warnings[0].find("euroc.rawlog has no odometry"), std::string::npos);
}

TEST(PipelineRun, StopsAtMaxFramesAndOnACallbackError) {
  {
    Frames frames(5);
    pipeline::Run run(smallRig(), fittedConfig());
    ASSERT_TRUE(run.execute(frames.source(), "t", 3, {}).isOk());
    EXPECT_EQ(run.summary().frames, 3);
  }
  Frames frames(5);
  pipeline::Run run(smallRig(), fittedConfig());
  RunCallbacks cb;
  cb.on_frame = [](const RunFrame& f) {
    return f.log.index == 1 ? Status::error("evaluator says no") : Status::ok();
  };
  const Status s = run.execute(frames.source(), "t", std::nullopt, cb);
  EXPECT_FALSE(s.isOk());
  EXPECT_EQ(s.message(), "evaluator says no");
  EXPECT_EQ(run.summary().frames, 2);
}

TEST(PipelineRun, ErrorsNameTheSourceOrTheFrame) {
  {
    Frames none(0);
    pipeline::Run run(smallRig(), fittedConfig());
    const Status s = run.execute(none.source(), "empty.rawlog", std::nullopt, {});
    EXPECT_EQ(s.message(), "empty.rawlog: no stereo frames");
  }
  {
    Frames bad(2, [](io::LogFrame* f) {
      f->odometry->pose.yaw_rad = std::numeric_limits<double>::infinity();
    });
    pipeline::Run run(smallRig(), fittedConfig());
    const Status s = run.execute(bad.source(), "bad.rawlog", std::nullopt, {});
    EXPECT_EQ(s.message(), "bad.rawlog: no frame could be processed");
  }
  {
    Frames small(2, [](io::LogFrame* f) {
      if (f->index == 1) f->stereo.left = ImageU8(20, 20);
    });
    pipeline::Run run(smallRig(), fittedConfig());
    const Status s = run.execute(small.source(), "t", std::nullopt, {});
    EXPECT_FALSE(s.isOk());
    EXPECT_EQ(s.message().rfind("frame 1: ", 0), 0u) << s.message();
  }
  {
    pipeline::Run run(smallRig(), fittedConfig());
    const FrameSource broken = [](io::LogFrame*, Status* s) {
      *s = Status::error("broken.rawlog: truncated");
      return false;
    };
    EXPECT_EQ(run.execute(broken, "broken.rawlog", std::nullopt, {}).message(),
              "broken.rawlog: truncated");
  }
}

}  // namespace
}  // namespace twocam::pipeline
