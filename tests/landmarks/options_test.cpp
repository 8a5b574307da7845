#include "landmarks/options.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace twocam::landmarks {
namespace {

TEST(LandmarkOptions, ValidateNamesTheKey) {
  LandmarkOptions o;
  EXPECT_TRUE(o.validate().isOk());
  o.consistency.confirm_prob = 1.5;
  EXPECT_EQ(o.validate().message(), "landmarks.consistency.confirm_prob = 1.5; must be in (0, 1)");
  o = LandmarkOptions();
  o.consistency.max_row_unsupported_fraction = 1.5;
  EXPECT_NE(o.validate().message().find("max_row_unsupported_fraction"), std::string::npos);
  o = LandmarkOptions();
  o.consistency.max_row_span_px = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(o.validate().message().find("max_row_span_px"), std::string::npos);
  o = LandmarkOptions();
  o.consistency.same_answer_px = -0.5;
  EXPECT_NE(o.validate().message().find("same_answer_px"), std::string::npos);
  o = LandmarkOptions();
  o.tracker.odometry_noise.rot_sigma_per_m = 2.0;
  EXPECT_EQ(o.validate().message(),
            "landmarks.tracker.odometry_noise.rot_sigma_per_m = 2; must be in [0, 1]");
  o = LandmarkOptions();
  // Upper bounds the code can honour: counts far inside int, caps the memory can hold.
  o.tracker.max_confirmed = std::numeric_limits<int>::max();
  EXPECT_NE(o.validate().message().find("landmarks.tracker.max_confirmed"), std::string::npos);
  o = LandmarkOptions();
  o.tracker.gate_chi2 = 1e300;
  EXPECT_NE(o.validate().message().find("landmarks.tracker.gate_chi2"), std::string::npos);
  o = LandmarkOptions();
  o.seen_count.min_observations = 0;
  EXPECT_NE(o.validate().message().find("landmarks.seen_count.min_observations"),
            std::string::npos);
  o = LandmarkOptions();
  o.culling.decision_frames = std::numeric_limits<int>::max();
  EXPECT_NE(o.validate().message().find("landmarks.culling.decision_frames"), std::string::npos);
  o = LandmarkOptions();
  o.inlier_ratio.prune_inlier_ratio = 0.7;
  EXPECT_NE(o.validate().message().find("landmarks.inlier_ratio.prune_inlier_ratio"),
            std::string::npos);
  o = LandmarkOptions();
  o.refine.huber = 0.0;
  EXPECT_NE(o.validate().message().find("landmarks.refine.huber"), std::string::npos);
  o = LandmarkOptions();
  o.consistency.min_parallax_deg = 90.0;
  EXPECT_NE(o.validate().message().find("min_parallax_deg"), std::string::npos);
  o.consistency.min_parallax_deg = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(o.validate().message().find("min_parallax_deg"), std::string::npos);
  Policy p;
  EXPECT_TRUE(parsePolicy("seen-count", &p).isOk());
  EXPECT_EQ(p, Policy::kSeenCount);
  EXPECT_FALSE(parsePolicy("best", &p).isOk());
}

}  // namespace
}  // namespace twocam::landmarks
