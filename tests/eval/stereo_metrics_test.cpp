#include "eval/stereo_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "eval/disparity_io.h"
#include "eval/stereo_pictures.h"
#include "frontend/cv_interop.h"
#include "support/test_paths.h"

namespace twocam::eval {
namespace {

// Hand-computed percentages are ratios of small integers evaluated in double.
constexpr double kPercentTol = 1e-12;
// Mean errors are sums of a few float-exact values divided once in double.
constexpr double kErrorTol = 1e-12;

DisparityGroundTruth flatGroundTruth(int w, int h, float d) {
  return DisparityGroundTruth{ImageF32(w, h, d), ImageU8(w, h, 1)};
}

cv::Vec3b pixel(const cv::Mat& picture, int u, int v) { return picture.at<cv::Vec3b>(v, u); }

// ---------------------------------------------------------------------------------------------
// Dense

/// The 4x3 case worked by hand in the comments below.
struct HandCase {
  DisparityGroundTruth gt;
  ImageF32 disparity;
};

HandCase handCase() {
  HandCase c{flatGroundTruth(4, 3, 10.0f), ImageF32(4, 3)};
  for (int u = 0; u < 3; ++u) c.gt.d_px(u, 2) = 5.0f;
  c.gt.valid(3, 2) = 0;  // no ground truth: ignored whatever the estimate
  const float rows[3][4] = {
      {10.5f, 11.5f, 13.0f, -1.0f},                                  // .5, 1.5, 3, none
      {10.0f, std::numeric_limits<float>::quiet_NaN(), 9.0f, 7.5f},  // 0, none, 1.0, 2.5
      {5.25f, 0.0f, 5.0f, 100.0f},                                   // .25, 5, 0, (no GT)
  };
  for (int v = 0; v < 3; ++v) {
    for (int u = 0; u < 4; ++u) c.disparity(u, v) = rows[v][u];
  }
  return c;
}

TEST(EvaluateDense, HandBuiltMapGivesHandComputedMetrics) {
  const HandCase c = handCase();
  StereoMetrics m;
  const Status s = evaluateDense(c.disparity, c.gt, nullptr, StereoEvalOptions{}, &m);
  ASSERT_TRUE(s.isOk()) << s.message();
  // 11 evaluated pixels, 9 with estimate; errors .5 1.5 3 0 1 2.5 .25 5 0 (sum 13.75).
  EXPECT_EQ(m.points, 12);
  EXPECT_EQ(m.evaluated, 11);
  EXPECT_EQ(m.estimated, 9);
  EXPECT_NEAR(m.bad1, 100.0 * 4 / 11, kPercentTol);   // 1.5 3 2.5 5 (1.0 is not > 1)
  EXPECT_NEAR(m.bad2, 100.0 * 3 / 11, kPercentTol);   // 3 2.5 5
  EXPECT_NEAR(m.bad05, 100.0 * 5 / 11, kPercentTol);  // 1.5 3 1.0 2.5 5 (.5 is not > .5)
  EXPECT_NEAR(m.avgerr, 13.75 / 9, kErrorTol);
  EXPECT_NEAR(m.density, 100.0 * 9 / 11, kPercentTol);
  EXPECT_EQ(m.k, 1);
  EXPECT_NEAR(m.recall_at_k, 100.0 * 5 / 11, kPercentTol);  // .5 0 1.0 .25 0
  EXPECT_NEAR(m.recall_at_k, m.density - m.bad1, kPercentTol);
  EXPECT_EQ(m.recall_at_1, m.recall_at_k);
  EXPECT_NEAR(m.mean_hypotheses, 9.0 / 11, kPercentTol);
  EXPECT_EQ(m.ms, 0.0);
}

TEST(EvaluateDense, ThresholdsComeFromOptions) {
  const HandCase c = handCase();
  StereoEvalOptions o;
  o.bad1_px = 0.4;   // adds .5 (and keeps 1.0)
  o.bad2_px = 2.75;  // drops 2.5
  o.bad05_px = 0.2;  // adds .5 and .25
  o.recall_tol_px = 0.3;
  StereoMetrics m;
  ASSERT_TRUE(evaluateDense(c.disparity, c.gt, nullptr, o, &m).isOk());
  EXPECT_NEAR(m.bad1, 100.0 * 6 / 11, kPercentTol);
  EXPECT_NEAR(m.bad2, 100.0 * 2 / 11, kPercentTol);
  EXPECT_NEAR(m.bad05, 100.0 * 7 / 11, kPercentTol);
  EXPECT_NEAR(m.recall_at_k, 100.0 * 3 / 11, kPercentTol);  // 0 .25 0
}

TEST(EvaluateDense, BorderExcludesTheOuterFrame) {
  const DisparityGroundTruth gt = flatGroundTruth(5, 5, 8.0f);
  ImageF32 disparity(5, 5, 13.0f);  // wrong on the ring ...
  for (int v = 1; v < 4; ++v) {
    for (int u = 1; u < 4; ++u) disparity(u, v) = 8.0f;  // ... right inside
  }
  StereoEvalOptions o;
  StereoMetrics m;
  ASSERT_TRUE(evaluateDense(disparity, gt, nullptr, o, &m).isOk());
  EXPECT_EQ(m.evaluated, 25);
  EXPECT_NEAR(m.bad1, 100.0 * 16 / 25, kPercentTol);
  o.border_px = 1;
  ASSERT_TRUE(evaluateDense(disparity, gt, nullptr, o, &m).isOk());
  EXPECT_EQ(m.evaluated, 9);
  EXPECT_EQ(m.bad1, 0.0);
  EXPECT_EQ(m.avgerr, 0.0);
  EXPECT_EQ(m.density, 100.0);
  // Nothing left to evaluate: every ratio is undefined.
  o.border_px = 3;
  ASSERT_TRUE(evaluateDense(disparity, gt, nullptr, o, &m).isOk());
  EXPECT_EQ(m.evaluated, 0);
  EXPECT_TRUE(std::isnan(m.bad1));
  EXPECT_TRUE(std::isnan(m.avgerr));
  EXPECT_TRUE(std::isnan(m.density));
  EXPECT_TRUE(std::isnan(m.recall_at_k));
}

TEST(EvaluateDense, MaskKeepsOnly255) {
  const DisparityGroundTruth gt = flatGroundTruth(6, 2, 4.0f);
  ImageF32 disparity(6, 2, 4.0f);
  ImageU8 mask(6, 2, 255);
  for (int v = 0; v < 2; ++v) {
    disparity(4, v) = 9.0f;
    disparity(5, v) = -1.0f;
    mask(4, v) = 128;  // Middlebury's "occluded"
    mask(5, v) = 0;
  }
  StereoMetrics m;
  ASSERT_TRUE(evaluateDense(disparity, gt, &mask, StereoEvalOptions{}, &m).isOk());
  EXPECT_EQ(m.evaluated, 8);
  EXPECT_EQ(m.bad1, 0.0);
  EXPECT_EQ(m.density, 100.0);
  ASSERT_TRUE(evaluateDense(disparity, gt, nullptr, StereoEvalOptions{}, &m).isOk());
  EXPECT_EQ(m.evaluated, 12);
  EXPECT_NEAR(m.bad1, 100.0 * 2 / 12, kPercentTol);
  EXPECT_NEAR(m.density, 100.0 * 10 / 12, kPercentTol);
}

TEST(EvaluateDense, SizeMismatchesAndBadOptionsAreErrors) {
  const DisparityGroundTruth gt = flatGroundTruth(6, 4, 4.0f);
  StereoMetrics m;
  Status s = evaluateDense(ImageF32(4, 6), gt, nullptr, StereoEvalOptions{}, &m);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("4x6"), std::string::npos) << s.message();
  const ImageU8 small_mask(6, 3, 255);
  s = evaluateDense(ImageF32(6, 4), gt, &small_mask, StereoEvalOptions{}, &m);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("mask"), std::string::npos) << s.message();
  DisparityGroundTruth broken = gt;
  broken.valid = ImageU8(5, 4, 1);
  EXPECT_FALSE(evaluateDense(ImageF32(6, 4), broken, nullptr, StereoEvalOptions{}, &m).isOk());
  EXPECT_FALSE(
      evaluateDense(ImageF32(), DisparityGroundTruth{}, nullptr, StereoEvalOptions{}, &m).isOk());
  StereoEvalOptions o;
  o.border_px = -1;
  s = evaluateDense(ImageF32(6, 4), gt, nullptr, o, &m);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("border_px"), std::string::npos) << s.message();
  o = StereoEvalOptions{};
  o.bad1_px = std::nan("");
  EXPECT_FALSE(o.validate().isOk());
  o = StereoEvalOptions{};
  o.bad05_px = -0.5;
  s = o.validate();
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("bad05_px"), std::string::npos) << s.message();
  o = StereoEvalOptions{};
  o.k = 0;
  EXPECT_FALSE(o.validate().isOk());
  o = StereoEvalOptions{};
  o.recall_tol_px = -0.5;
  EXPECT_FALSE(o.validate().isOk());
  EXPECT_TRUE(StereoEvalOptions{}.validate().isOk());
}

// ---------------------------------------------------------------------------------------------
// Salient

using Hyp = std::tuple<float, int, bool>;  // d_px, rank, lr_consistent

void addPoint(StereoHypotheses* hyps, int u, int v, const std::vector<Hyp>& list) {
  SalientPoint p;
  p.corner.u_px = u;
  p.corner.v_px = v;
  p.first_hypothesis = static_cast<uint32_t>(hyps->hypotheses.size());
  p.num_hypotheses = static_cast<uint32_t>(list.size());
  for (const auto& [d, rank, consistent] : list) {
    DisparityHypothesis h;
    h.d_px = d;
    h.rank = static_cast<uint8_t>(rank);
    h.lr_consistent = consistent;
    h.point_index = static_cast<uint32_t>(hyps->points.size());
    hyps->hypotheses.push_back(h);
  }
  hyps->points.push_back(p);
}

/// Ground truth 6 px everywhere except (15, 5); seven points worked by hand in the test.
struct SalientCase {
  DisparityGroundTruth gt;
  StereoHypotheses hyps;
};

SalientCase salientCase() {
  SalientCase c{flatGroundTruth(20, 10, 6.0f), {}};
  c.gt.valid(15, 5) = 0;
  addPoint(&c.hyps, 5, 5, {{6.5f, 0, true}});                    // p0 estimate .5, recalled
  addPoint(&c.hyps, 6, 5, {{9.0f, 0, true}, {6.2f, 1, false}});  // p1 estimate 3, in top-k
  addPoint(&c.hyps, 7, 5, {{5.5f, 0, false}});                   // p2 no estimate, recalled
  addPoint(&c.hyps, 8, 5, {});                                   // p3 nothing
  addPoint(&c.hyps, 15, 5, {{6.0f, 0, true}});                   // p4 no GT
  addPoint(
      &c.hyps,  // p5 stored by falling rank:
      9,
      5,
      {{6.0f, 4, false}, {12.0f, 3, true}, {11.0f, 2, true}, {10.0f, 1, true}, {7.5f, 0, true}});
  addPoint(&c.hyps, 0, 0, {{6.0f, 0, true}});  // p6 image corner, exact
  return c;
}

TEST(EvaluateSalient, HandBuiltHypothesesGiveHandComputedMetrics) {
  const SalientCase c = salientCase();
  StereoMetrics m;
  const Status s = evaluateSalient(c.hyps, c.gt, nullptr, StereoEvalOptions{}, &m);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(m.points, 7);
  EXPECT_EQ(m.evaluated, 6);  // all but p4
  // p0 p1 p6: best is LR-consistent and unambiguous; p5's best has consistent rivals 2.5 to
  // 4.5 px away, so it is ambiguous and gives no single-best estimate.
  EXPECT_EQ(m.estimated, 3);
  EXPECT_NEAR(m.bad1, 100.0 * 1 / 6, kPercentTol);   // p1 (3 px)
  EXPECT_NEAR(m.bad2, 100.0 * 1 / 6, kPercentTol);   // p1
  EXPECT_NEAR(m.bad05, 100.0 * 1 / 6, kPercentTol);  // p1 (p0's .5 is not > .5)
  EXPECT_NEAR(m.avgerr, (0.5 + 3.0 + 0.0) / 3, kErrorTol);
  EXPECT_NEAR(m.density, 100.0 * 3 / 6, kPercentTol);
  EXPECT_EQ(m.k, 4);
  EXPECT_NEAR(m.recall_at_k, 100.0 * 4 / 6, kPercentTol);  // p0 p1 p2 p6 (p5's true one is rank 4)
  EXPECT_NEAR(m.recall_at_1, 100.0 * 3 / 6, kPercentTol);  // p0 p2 p6
  EXPECT_NEAR(m.mean_hypotheses, (1 + 2 + 1 + 0 + 5 + 1) / 6.0, kPercentTol);
  // One answer: p0 p2 p6 (p1 and p5 have rivals over 1 px away, p3 has none), all true.
  EXPECT_NEAR(m.one_answer_fraction, 100.0 * 3 / 6, kPercentTol);
  EXPECT_NEAR(m.one_answer_precision, 100.0, kPercentTol);
}

TEST(EvaluateSalient, OneAnswerCountsTwinsAsOneAndJudgesTheBest) {
  SalientCase c{flatGroundTruth(20, 10, 6.0f), {}};
  addPoint(&c.hyps, 5, 5, {{6.4f, 0, true}, {5.6f, 1, true}});    // twins 0.8 px apart, true
  addPoint(&c.hyps, 6, 5, {{9.0f, 0, true}});                     // lone, 3 px off
  addPoint(&c.hyps, 7, 5, {{6.0f, 0, true}, {8.5f, 1, false}});   // a rival 2.5 px away
  addPoint(&c.hyps, 8, 5, {{10.0f, 0, true}, {10.9f, 1, true}});  // twins, both wrong
  StereoMetrics m;
  ASSERT_TRUE(evaluateSalient(c.hyps, c.gt, nullptr, StereoEvalOptions{}, &m).isOk());
  EXPECT_NEAR(m.one_answer_fraction, 100.0 * 3 / 4, kPercentTol);
  EXPECT_NEAR(m.one_answer_precision, 100.0 * 1 / 3, kPercentTol);
}

TEST(EvaluateSalient, KBorderAndMaskChangeWhatCounts) {
  const SalientCase c = salientCase();
  StereoEvalOptions o;
  o.k = 5;  // now p5's rank-4 hypothesis counts
  StereoMetrics m;
  ASSERT_TRUE(evaluateSalient(c.hyps, c.gt, nullptr, o, &m).isOk());
  EXPECT_EQ(m.k, 5);
  EXPECT_NEAR(m.recall_at_k, 100.0 * 5 / 6, kPercentTol);
  o.k = 1;
  ASSERT_TRUE(evaluateSalient(c.hyps, c.gt, nullptr, o, &m).isOk());
  EXPECT_EQ(m.recall_at_k, m.recall_at_1);
  o = StereoEvalOptions{};
  o.border_px = 1;  // drops p6 at (0, 0)
  ASSERT_TRUE(evaluateSalient(c.hyps, c.gt, nullptr, o, &m).isOk());
  EXPECT_EQ(m.evaluated, 5);
  EXPECT_EQ(m.estimated, 2);
  EXPECT_NEAR(m.avgerr, (0.5 + 3.0) / 2, kErrorTol);
  ImageU8 mask(20, 10, 255);
  mask(6, 5) = 0;  // drops p1
  ASSERT_TRUE(evaluateSalient(c.hyps, c.gt, &mask, StereoEvalOptions{}, &m).isOk());
  EXPECT_EQ(m.evaluated, 5);
  EXPECT_NEAR(m.bad2, 0.0, kPercentTol);
  EXPECT_NEAR(m.bad1, 0.0, kPercentTol);
  // Rivals within recall_tol_px are the same answer, not an ambiguity.
  StereoHypotheses near_rivals;
  addPoint(&near_rivals, 5, 5, {{6.2f, 0, true}, {6.9f, 1, true}});
  ASSERT_TRUE(evaluateSalient(near_rivals, c.gt, nullptr, StereoEvalOptions{}, &m).isOk());
  EXPECT_EQ(m.estimated, 1);
}

TEST(EvaluateSalient, InconsistentInputIsAnError) {
  const SalientCase good = salientCase();
  StereoMetrics m;
  auto expect_error = [&](const StereoHypotheses& hyps, const char* needle) {
    const Status s = evaluateSalient(hyps, good.gt, nullptr, StereoEvalOptions{}, &m);
    EXPECT_FALSE(s.isOk()) << needle;
    EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
  };
  StereoHypotheses h = good.hyps;
  h.points[2].corner.u_px = 20;
  expect_error(h, "outside");
  h = good.hyps;
  h.points[3].corner.v_px = -1;
  expect_error(h, "outside");
  h = good.hyps;
  h.points.back().num_hypotheses = 2;
  expect_error(h, "only 11 exist");
  h = good.hyps;
  h.hypotheses[1].point_index = 0;
  expect_error(h, "point_index");
  h = good.hyps;
  h.hypotheses[2].rank = 0;  // p1 now has two rank-0 hypotheses
  expect_error(h, "two rank-0");
  h = good.hyps;
  h.hypotheses[0].rank = 1;
  expect_error(h, "none of rank 0");
  const ImageU8 mask(19, 10, 255);
  EXPECT_FALSE(evaluateSalient(good.hyps, good.gt, &mask, StereoEvalOptions{}, &m).isOk());
  StereoEvalOptions o;
  o.k = 0;
  EXPECT_FALSE(evaluateSalient(good.hyps, good.gt, nullptr, o, &m).isOk());
  // No points at all is valid input with undefined ratios.
  ASSERT_TRUE(
      evaluateSalient(StereoHypotheses{}, good.gt, nullptr, StereoEvalOptions{}, &m).isOk());
  EXPECT_EQ(m.points, 0);
  EXPECT_TRUE(std::isnan(m.recall_at_k));
}

// ---------------------------------------------------------------------------------------------
// JSON and timing

TEST(StereoMetricsJson, WritesMetricsKeysInOrderWithFixedFormatting) {
  StereoMetrics m;
  m.bad1 = 12.5;
  m.bad2 = 1.0 / 3.0;
  m.bad05 = 25.0;
  m.avgerr = std::numeric_limits<double>::quiet_NaN();
  m.density = 100.0;
  m.recall_at_k = 50.0;
  m.points = 110592;
  m.k = 4;
  setTiming(11.0592, 384, 288, &m);
  const std::string json = toJson(m);
  EXPECT_NE(json.find("\"bad1\": 12.5,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"bad2\": 0.3333333333,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"bad0.5\": 25,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"avgerr\": null,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"points\": 110592,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"ms\": 11.0592,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"s_per_mp\": 0.1,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"estimated\": 0,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"one_answer_precision\": null\n}"), std::string::npos) << json;
  size_t last = 0;
  for (const char* key : {"bad1",
                          "bad2",
                          "bad0.5",
                          "avgerr",
                          "density",
                          "recall_at_k",
                          "points",
                          "ms",
                          "s_per_mp",
                          "k",
                          "recall_at_1",
                          "mean_hypotheses",
                          "evaluated",
                          "estimated",
                          "one_answer_fraction",
                          "one_answer_precision"}) {
    const size_t at = json.find(std::string("\"") + key + "\":");
    ASSERT_NE(at, std::string::npos) << key;
    EXPECT_GT(at, last) << key << " out of order";
    last = at;
  }
  EXPECT_EQ(json.front(), '{');
  EXPECT_EQ(json.back(), '}');
  // The same value as the run's writer gives it, read back by nlohmann.
  const io::Json back = io::Json::parse(json);
  EXPECT_EQ(back["points"].get<int64_t>(), 110592);
  EXPECT_TRUE(back["avgerr"].is_null());

  const std::string dir = test::makeTempDir("eval_json");
  ASSERT_TRUE(writeJson(dir + "/m.json", m).isOk());
  std::ifstream f(dir + "/m.json");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()),
            json + "\n");
  const Status s = writeJson(dir + "/missing/m.json", m);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("missing/m.json"), std::string::npos) << s.message();
}

TEST(StereoMetricsJson, TimingPerMegapixel) {
  StereoMetrics m;
  setTiming(50.0, 1000, 1000, &m);
  EXPECT_EQ(m.ms, 50.0);
  EXPECT_NEAR(m.s_per_mp, 0.05, kErrorTol);
  setTiming(1.0, 0, 10, &m);
  EXPECT_TRUE(std::isnan(m.s_per_mp));
}

// ---------------------------------------------------------------------------------------------
// Pictures

constexpr int kGapPx = 4;  // gap between panels in stereo_pictures.cpp
const cv::Vec3b kGreenPx(0, 200, 0);
const cv::Vec3b kOrangePx(0, 150, 255);
const cv::Vec3b kRedPx(0, 0, 230);
const cv::Vec3b kYellowPx(0, 230, 230);
const cv::Vec3b kGreyPx(128, 128, 128);
const cv::Vec3b kBluePx(230, 120, 0);
const cv::Vec3b kBlackPx(0, 0, 0);

TEST(StereoPictures, DenseErrorPanelColoursEachOutcome) {
  constexpr int kW = 60;
  constexpr int kH = 100;
  constexpr int kRow = 50;  // clear of the text labels at the top and bottom
  DisparityGroundTruth gt = flatGroundTruth(kW, kH, 10.0f);
  for (int v = 0; v < kH; ++v) gt.valid(55, v) = 0;
  ImageF32 disparity(kW, kH, 10.2f);
  for (int v = 0; v < kH; ++v) {
    disparity(10, v) = 10.0f;  // exact
    disparity(20, v) = 11.5f;  // > bad1, <= bad2
    disparity(30, v) = 15.0f;  // > bad2
    disparity(40, v) = -1.0f;  // no estimate
  }
  const ImageU8 left(kW, kH, 90);
  cv::Mat picture;
  const Status s = renderDenseEvalPicture(left, disparity, gt, 16.0, StereoEvalOptions{}, &picture);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(picture.type(), CV_8UC3);
  ASSERT_EQ(picture.cols, 4 * kW + 3 * kGapPx);
  ASSERT_EQ(picture.rows, kH);
  const int errors_x = 3 * (kW + kGapPx);
  EXPECT_EQ(pixel(picture, errors_x + 10, kRow), kGreenPx);
  EXPECT_EQ(pixel(picture, errors_x + 20, kRow), kOrangePx);
  EXPECT_EQ(pixel(picture, errors_x + 30, kRow), kRedPx);
  EXPECT_EQ(pixel(picture, errors_x + 40, kRow), kGreyPx);
  EXPECT_EQ(pixel(picture, errors_x + 55, kRow), kBlackPx);
  // Left panel is the grey image; no-estimate is black in the estimate panel, and the GT panel
  // is black where there is no ground truth.
  EXPECT_EQ(pixel(picture, 10, kRow), cv::Vec3b(90, 90, 90));
  EXPECT_EQ(pixel(picture, (kW + kGapPx) + 40, kRow), kBlackPx);
  EXPECT_NE(pixel(picture, (kW + kGapPx) + 10, kRow), kBlackPx);
  EXPECT_EQ(pixel(picture, 2 * (kW + kGapPx) + 55, kRow), kBlackPx);
  // Estimate equal to GT gets the same colour in both panels.
  EXPECT_EQ(pixel(picture, (kW + kGapPx) + 10, kRow), pixel(picture, 2 * (kW + kGapPx) + 10, kRow));

  EXPECT_FALSE(
      renderDenseEvalPicture(ImageU8(kW - 1, kH), disparity, gt, 16.0, {}, &picture).isOk());
  EXPECT_FALSE(renderDenseEvalPicture(left, ImageF32(kW, kH - 1), gt, 16.0, {}, &picture).isOk());
  EXPECT_FALSE(renderDenseEvalPicture(left, disparity, gt, 0.0, {}, &picture).isOk());
  EXPECT_FALSE(renderDenseEvalPicture(ImageU8(), disparity, gt, 16.0, {}, &picture).isOk());
}

TEST(StereoPictures, DenseErrorPanelHonoursTheMask) {
  constexpr int kW = 60;
  constexpr int kH = 100;
  constexpr int kRow = 50;
  const DisparityGroundTruth gt = flatGroundTruth(kW, kH, 10.0f);
  ImageF32 disparity(kW, kH, 15.0f);  // wrong everywhere: red where evaluated
  ImageU8 mask(kW, kH, 255);
  for (int v = 0; v < kH; ++v) {
    for (int u = 30; u < kW; ++u) mask(u, v) = 0;  // the right half is not evaluated
  }
  const ImageU8 left(kW, kH, 90);
  cv::Mat picture;
  ASSERT_TRUE(
      renderDenseEvalPicture(left, disparity, gt, 16.0, StereoEvalOptions{}, &picture, &mask)
          .isOk());
  const int errors_x = 3 * (kW + kGapPx);
  EXPECT_EQ(pixel(picture, errors_x + 10, kRow), kRedPx);
  EXPECT_EQ(pixel(picture, errors_x + 40, kRow), kBlackPx) << "outside the mask: not evaluated";
  const ImageU8 wrong_size(kW - 1, kH, 255);
  EXPECT_FALSE(
      renderDenseEvalPicture(left, disparity, gt, 16.0, StereoEvalOptions{}, &picture, &wrong_size)
          .isOk());
}

TEST(StereoPictures, SalientPointsColouredByOutcome) {
  constexpr int kW = 60;
  constexpr int kH = 100;
  constexpr int kRow = 50;
  constexpr int kRadiusPx = 3;  // marker radius in stereo_pictures.cpp
  DisparityGroundTruth gt = flatGroundTruth(kW, kH, 6.0f);
  gt.valid(50, kRow) = 0;
  StereoHypotheses hyps;
  addPoint(&hyps, 10, kRow, {{6.3f, 0, true}});                    // best correct, filled
  addPoint(&hyps, 20, kRow, {{9.0f, 0, false}, {6.0f, 1, true}});  // within k, hollow
  addPoint(&hyps, 30, kRow, {{1.0f, 0, true}});                    // wrong, filled
  addPoint(&hyps, 40, kRow, {});                                   // none, hollow
  addPoint(&hyps, 50, kRow, {{6.0f, 0, true}});                    // no GT, filled
  const StereoEvalOptions o;
  EXPECT_EQ(classifySalientPoint(hyps, 0, gt, o), SalientOutcome::kBestCorrect);
  EXPECT_EQ(classifySalientPoint(hyps, 1, gt, o), SalientOutcome::kCorrectWithinK);
  EXPECT_EQ(classifySalientPoint(hyps, 2, gt, o), SalientOutcome::kWrong);
  EXPECT_EQ(classifySalientPoint(hyps, 3, gt, o), SalientOutcome::kNoHypothesis);
  EXPECT_EQ(classifySalientPoint(hyps, 4, gt, o), SalientOutcome::kNotEvaluated);

  const ImageU8 left(kW, kH, 90);
  const cv::Vec3b background(90, 90, 90);
  cv::Mat picture;
  const Status s = renderSalientEvalPicture(left, hyps, gt, 16.0, o, &picture);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(picture.cols, 3 * kW + 2 * kGapPx);
  ASSERT_EQ(picture.rows, kH);
  EXPECT_EQ(pixel(picture, 10, kRow), kGreenPx);
  EXPECT_EQ(pixel(picture, 20, kRow), background);  // hollow: centre untouched
  EXPECT_EQ(pixel(picture, 20 + kRadiusPx, kRow), kYellowPx);
  EXPECT_EQ(pixel(picture, 30, kRow), kRedPx);
  EXPECT_EQ(pixel(picture, 40, kRow), background);
  EXPECT_EQ(pixel(picture, 40 + kRadiusPx, kRow), kGreyPx);
  EXPECT_EQ(pixel(picture, 50, kRow), kBluePx);
  EXPECT_EQ(pixel(picture, 5, kRow), background);
  // Second panel: the best hypothesis' disparity in the GT panel's colours.
  const int sparse_x = kW + kGapPx;
  const int gt_x = 2 * (kW + kGapPx);
  EXPECT_EQ(pixel(picture, sparse_x + 50, kRow), pixel(picture, gt_x + 10, kRow));
  EXPECT_EQ(pixel(picture, gt_x + 50, kRow), kBlackPx);

  StereoHypotheses bad = hyps;
  bad.points[0].corner.u_px = kW;
  EXPECT_FALSE(renderSalientEvalPicture(left, bad, gt, 16.0, o, &picture).isOk());
  EXPECT_FALSE(renderSalientEvalPicture(ImageU8(kW, kH + 1), hyps, gt, 16.0, o, &picture).isOk());
  EXPECT_FALSE(renderSalientEvalPicture(left, hyps, gt, std::nan(""), o, &picture).isOk());
}

// ---------------------------------------------------------------------------------------------
// Real data: Tsukuba ground truth with seeded, known corruption

TEST(StereoMetricsReal, TsukubaWithSeededErrorsCountsExactlyThoseErrors) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  DisparityGroundTruth gt;
  ASSERT_TRUE(
      loadDisparityGroundTruth(data + "/middlebury/tsukuba/disp3.pgm", 16.0, std::nullopt, &gt)
          .isOk());
  ImageU8 left;
  ASSERT_TRUE(frontend::loadGrey(data + "/middlebury/tsukuba/im3.png", &left).isOk());

  // Dense: GT plus a small error everywhere, 10 % of pixels off by 3 px, 5 % without estimate.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ImageF32 disparity(gt.d_px.width, gt.d_px.height);
  int64_t evaluated = 0, estimated = 0, bad = 0;
  for (size_t i = 0; i < disparity.data.size(); ++i) {
    const double r = unit(rng);
    const bool has_gt = gt.valid.data[i] != 0;
    if (r < 0.05) {
      disparity.data[i] = -1.0f;
    } else if (r < 0.15) {
      disparity.data[i] = gt.d_px.data[i] + 3.0f;
      bad += has_gt ? 1 : 0;
    } else {
      disparity.data[i] = gt.d_px.data[i] + 0.25f;
    }
    evaluated += has_gt ? 1 : 0;
    estimated += has_gt && r >= 0.05 ? 1 : 0;
  }
  StereoMetrics m;
  ASSERT_TRUE(evaluateDense(disparity, gt, nullptr, StereoEvalOptions{}, &m).isOk());
  EXPECT_EQ(m.evaluated, evaluated);
  EXPECT_EQ(m.estimated, estimated);
  EXPECT_NEAR(
      m.bad1, 100.0 * static_cast<double>(bad) / static_cast<double>(evaluated), kPercentTol);
  EXPECT_EQ(m.bad1, m.bad2);
  EXPECT_NEAR(m.avgerr,
              (3.0 * static_cast<double>(bad) + 0.25 * static_cast<double>(estimated - bad)) /
                  static_cast<double>(estimated),
              kErrorTol);
  cv::Mat picture;
  ASSERT_TRUE(
      renderDenseEvalPicture(left, disparity, gt, 16.0, StereoEvalOptions{}, &picture).isOk());
  const std::string dir = test::makeTempDir("eval_tsukuba_pictures");
  EXPECT_TRUE(cv::imwrite(dir + "/dense.png", picture));

  // Salient: seeded points; a third have the truth as best, a third only at rank 1..3, a third
  // never. The picture's classification and the metrics must agree.
  StereoHypotheses hyps;
  std::uniform_int_distribution<int> u_dist(0, gt.d_px.width - 1), v_dist(0, gt.d_px.height - 1);
  for (int i = 0; i < 600; ++i) {
    const int u = u_dist(rng);
    const int v = v_dist(rng);
    const float d = gt.d_px(u, v);
    if (i % 3 == 0) addPoint(&hyps, u, v, {{d + 0.2f, 0, true}, {d + 6.0f, 1, false}});
    if (i % 3 == 1)
      addPoint(&hyps, u, v, {{d + 4.0f, 0, true}, {d + 5.0f, 1, true}, {d, 2, false}});
    if (i % 3 == 2) addPoint(&hyps, u, v, {{d + 2.5f, 0, i % 2 == 0}});
  }
  ASSERT_TRUE(evaluateSalient(hyps, gt, nullptr, StereoEvalOptions{}, &m).isOk());
  int64_t within_k = 0, best = 0, evaluated_points = 0;
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientOutcome o = classifySalientPoint(hyps, i, gt, StereoEvalOptions{});
    best += o == SalientOutcome::kBestCorrect ? 1 : 0;
    within_k += o == SalientOutcome::kBestCorrect || o == SalientOutcome::kCorrectWithinK ? 1 : 0;
    evaluated_points += o != SalientOutcome::kNotEvaluated ? 1 : 0;
  }
  EXPECT_EQ(m.evaluated, evaluated_points);
  EXPECT_NEAR(m.recall_at_k,
              100.0 * static_cast<double>(within_k) / static_cast<double>(evaluated_points),
              kPercentTol);
  EXPECT_NEAR(m.recall_at_1,
              100.0 * static_cast<double>(best) / static_cast<double>(evaluated_points),
              kPercentTol);
  EXPECT_GT(m.recall_at_k, m.recall_at_1);
  ASSERT_TRUE(renderSalientEvalPicture(left, hyps, gt, 16.0, StereoEvalOptions{}, &picture).isOk());
  EXPECT_TRUE(cv::imwrite(dir + "/salient.png", picture));
}

}  // namespace
}  // namespace twocam::eval
