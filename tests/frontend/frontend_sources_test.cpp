// Frontend::process with every hypothesis source (frontend.source): each finds the plane's
// disparity at most of its salient points.

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <string>

#include "frontend/frontend.h"
#include "salient_test_support.h"

namespace twocam::frontend {
namespace {

/// A fronto-parallel plane at this disparity [px].
constexpr int kD = 12;
/// Share of salient points whose best hypothesis is within kTruthTolPx of kD: a noise-free
/// plane, so only points at the image edge or on look-alike blocks miss (measured 0.93-1.0).
constexpr double kMinBestCorrect = 0.8;
/// Fewest salient points on the 320 x 240 pair (every source finds hundreds).
constexpr size_t kMinPoints = 100;

/// Blocks of constant grey (8 x 8 px, seeded), lightly blurred: corners for Harris, textured
/// windows for the correlation matchers and uniform runs between edges for the Max-Trees.
cv::Mat blockTexture(int width, int height, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat small(height / 8 + 1, width / 8 + 1, CV_8U);
  rng.fill(small, cv::RNG::UNIFORM, 20, 235);
  cv::Mat big;
  cv::resize(small, big, cv::Size(), 8.0, 8.0, cv::INTER_NEAREST);
  cv::GaussianBlur(big, big, cv::Size(3, 3), 0.7);
  return big(cv::Rect(0, 0, width, height)).clone();
}

class FrontendSources : public ::testing::TestWithParam<HypothesisSource> {};

TEST_P(FrontendSources, FindTheDisparityOfAPlane) {
  const cv::Mat tex = blockTexture(400, 280, 5);
  const StereoPair pair = shiftedPair(tex, 320, 240, kD);
  StereoFrame frame;
  frame.t_ns = 7;
  frame.left = pair.left;
  frame.right = pair.right;
  FrontendOptions options;
  options.source = GetParam();
  options.sad.max_disparity_px = 31;
  ASSERT_TRUE(options.validate().isOk()) << options.validate().message();
  Frontend frontend(options);
  StereoHypotheses out;
  ASSERT_TRUE(frontend.process(frame, &out).isOk());
  EXPECT_EQ(out.t_ns, 7);
  expectWellFormed(out, 8);
  ASSERT_GE(out.points.size(), kMinPoints);
  EXPECT_EQ(frontend.corners().empty(), false);
  size_t correct = 0;
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    if (h != nullptr && std::abs(h->d_px - kD) <= kTruthTolPx) ++correct;
  }
  EXPECT_GE(static_cast<double>(correct), kMinBestCorrect * static_cast<double>(out.points.size()))
      << hypothesisSourceName(GetParam()) << ": " << correct << " of " << out.points.size();
  StereoFrame bad = frame;
  bad.right = ImageU8();
  EXPECT_FALSE(frontend.process(bad, &out).isOk());
}

INSTANTIATE_TEST_SUITE_P(EverySource,
                         FrontendSources,
                         ::testing::Values(HypothesisSource::kSad,
                                           HypothesisSource::kSupport,
                                           HypothesisSource::kNcc,
                                           HypothesisSource::kMaxTree),
                         [](const ::testing::TestParamInfo<HypothesisSource>& param_info) {
                           return std::string(hypothesisSourceName(param_info.param));
                         });

TEST(FrontendSources, NamesParseBothWays) {
  for (HypothesisSource s : {HypothesisSource::kSad,
                             HypothesisSource::kCornerPairing,
                             HypothesisSource::kSupport,
                             HypothesisSource::kNcc,
                             HypothesisSource::kMaxTree}) {
    HypothesisSource parsed = HypothesisSource::kSad;
    ASSERT_TRUE(parseHypothesisSource(hypothesisSourceName(s), &parsed).isOk());
    EXPECT_EQ(parsed, s);
  }
  HypothesisSource parsed = HypothesisSource::kSad;
  const Status s = parseHypothesisSource("sgm", &parsed);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("support, ncc or maxtree"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace twocam::frontend
