#include "eval/matcher_eval.h"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "common/timer.h"
#include "eval/stereo_pictures.h"
#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "frontend/harris.h"
#include "frontend/maxtree.h"
#include "frontend/ncc_scaled.h"
#include "frontend/salient_sad.h"
#include "frontend/support_value.h"

namespace twocam::eval {
namespace {

/// The salient modes' corners: Harris aiming at corners_per_mp, shown the image
/// kSettlingPasses times so that its adaptive threshold (tuned from frame to frame) settles near
/// the target; the caller times the next detect().
constexpr int kSettlingPasses = 4;
Status settledDetector(const ImageU8& left,
                       int corners_per_mp,
                       std::optional<frontend::HarrisDetector>* detector,
                       std::vector<Corner>* corners) {
  frontend::HarrisOptions harris;
  harris.target_count =
      std::max(1,
               static_cast<int>(
                   corners_per_mp * 1e-6 * static_cast<double>(left.width) * left.height + 0.5));
  harris.max_corners = 2 * harris.target_count;
  if (Status s = harris.validate(); !s) return s;
  detector->emplace(harris);
  for (int pass = 0; pass < kSettlingPasses; ++pass) {
    if (Status s = (*detector)->detect(left, corners); !s) return s;
  }
  return Status::ok();
}

/// `--matcher maxtree`: semi-dense (dense), sparse or salient output of frontend/maxtree.h, timed
/// on a second run like the SAD branches.
Status evalMaxTree(const MatcherRun& args,
                   const ImageU8& left,
                   const ImageU8& right,
                   const DisparityGroundTruth& gt,
                   const ImageU8* mask,
                   const StereoEvalOptions& eval_options,
                   StereoMetrics* metrics,
                   cv::Mat* picture) {
  frontend::MaxTreeOptions options;
  options.max_disparity_px = args.max_disparity_px;
  if (Status s = options.validate(); !s) return s;
  frontend::MaxTreeMatcher matcher;
  frontend::MaxTreeResult result;
  if (Status s = matcher.compute(left, right, options, &result); !s) return s;  // warm-up
  if (args.mode == "salient") {
    std::optional<frontend::HarrisDetector> detector;
    std::vector<Corner> corners;
    if (Status s = settledDetector(left, args.corners_per_mp, &detector, &corners); !s) return s;
    StereoHypotheses hyps;
    const Timer t0;
    if (Status s = detector->detect(left, &corners); !s) return s;
    if (Status s = frontend::matchMaxTreeSalient(left, right, corners, options, &hyps); !s)
      return s;
    const double ms = t0.elapsedMs();
    if (Status s = evaluateSalient(hyps, gt, mask, eval_options, metrics); !s) return s;
    setTiming(ms, left.width, left.height, metrics);
    if (args.picture) {
      return renderSalientEvalPicture(
          left, hyps, gt, args.max_disparity_px, eval_options, picture, mask);
    }
    return Status::ok();
  }
  const Timer t0;
  if (Status s = matcher.compute(left, right, options, &result); !s) return s;
  const double ms = t0.elapsedMs();
  const ImageF32& map = args.mode == "sparse" ? result.sparse : result.semi_dense;
  if (Status s = evaluateDense(map, gt, mask, eval_options, metrics); !s) return s;
  setTiming(ms, left.width, left.height, metrics);
  if (args.picture) {
    return renderDenseEvalPicture(
        left, map, gt, args.max_disparity_px, eval_options, picture, mask);
  }
  return Status::ok();
}

/// --matcher ncc: what the scaled-window NCC adds to the metrics (winning scale per item).
struct NccScaleReport {
  /// Items (final dense estimates, or salient points with a best hypothesis) per scale index.
  int64_t counts[frontend::kNccScaleCount] = {0, 0, 0};
  cv::Mat picture;  // BGR: red 1/sqrt(2), green 1, blue sqrt(2); grey where none
};

cv::Vec3b scaleColour(int index) {
  static const cv::Vec3b kColours[frontend::kNccScaleCount] = {
      cv::Vec3b(40, 40, 230), cv::Vec3b(40, 200, 40), cv::Vec3b(230, 80, 40)};
  return kColours[index];
}

cv::Mat dimmedGrey(const ImageU8& left) {
  cv::Mat grey = frontend::asMat(left).clone();
  grey = grey / 3;
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/// Dense or salient scaled-window NCC (frontend/ncc_scaled.h) at the paper's defaults, timed and
/// evaluated like the SAD branches below.
Status runNcc(const MatcherRun& args,
              const ImageU8& left,
              const ImageU8& right,
              const DisparityGroundTruth& gt,
              const ImageU8* mask,
              const StereoEvalOptions& eval_options,
              StereoMetrics* metrics,
              cv::Mat* picture,
              NccScaleReport* report) {
  frontend::NccScaledOptions options;
  options.max_disparity_px = args.max_disparity_px;
  if (args.window_px > 0) options.window_size_px = args.window_px;
  if (Status s = options.validate(); !s) return s;
  const bool want_picture = args.picture;
  report->picture = dimmedGrey(left);
  if (args.mode == "dense") {
    frontend::NccScaledMatcher matcher;
    ImageF32 disparity;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;  // warm-up
    const Timer t0;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;
    const double ms = t0.elapsedMs();
    if (Status s = evaluateDense(disparity, gt, mask, eval_options, metrics); !s) return s;
    setTiming(ms, left.width, left.height, metrics);
    for (int v = 0; v < left.height; ++v) {
      for (int u = 0; u < left.width; ++u) {
        const uint8_t index = matcher.scaleIndex()(u, v);
        if (index >= frontend::kNccScaleCount) continue;
        ++report->counts[index];
        report->picture.at<cv::Vec3b>(v, u) = scaleColour(index);
      }
    }
    if (want_picture) {
      return renderDenseEvalPicture(
          left, disparity, gt, args.max_disparity_px, eval_options, picture, mask);
    }
    return Status::ok();
  }
  std::optional<frontend::HarrisDetector> detector;
  std::vector<Corner> corners;
  if (Status s = settledDetector(left, args.corners_per_mp, &detector, &corners); !s) return s;
  StereoHypotheses hyps;
  std::vector<uint8_t> scales;
  if (Status s = frontend::matchNccSalient(left, right, corners, options, &hyps, &scales); !s)
    return s;
  const Timer t0;
  if (Status s = detector->detect(left, &corners); !s) return s;
  if (Status s = frontend::matchNccSalient(left, right, corners, options, &hyps, &scales); !s)
    return s;
  const double ms = t0.elapsedMs();
  if (Status s = evaluateSalient(hyps, gt, mask, eval_options, metrics); !s) return s;
  setTiming(ms, left.width, left.height, metrics);
  for (const SalientPoint& p : hyps.points) {
    if (p.num_hypotheses == 0) continue;
    const uint8_t index = scales[p.first_hypothesis];  // rank 0 comes first
    ++report->counts[index];
    cv::circle(report->picture,
               cv::Point(p.corner.u_px, p.corner.v_px),
               2,
               cv::Scalar(scaleColour(index)),
               cv::FILLED);
  }
  if (want_picture) {
    return renderSalientEvalPicture(
        left, hyps, gt, args.max_disparity_px, eval_options, picture, mask);
  }
  return Status::ok();
}

}  // namespace

Status runMatcher(const ImageU8& left,
                  const ImageU8& right,
                  const DisparityGroundTruth& gt,
                  const ImageU8* mask,
                  const StereoEvalOptions& eval_options,
                  const MatcherRun& args,
                  MatcherRunResult* out) {
  TWOCAM_CHECK(out != nullptr);
  const bool opencv = args.matcher == "opencv-bm" || args.matcher == "opencv-sgbm";
  if (args.matcher != "sad" && args.matcher != "support" && args.matcher != "ncc" &&
      args.matcher != "maxtree" && !opencv) {
    return Status::error("matcher '" + args.matcher +
                         "': expected sad, support, ncc, maxtree, opencv-bm or opencv-sgbm");
  }
  if (args.mode == "sparse" && args.matcher != "maxtree")
    return Status::error("mode sparse is maxtree's only");
  if (opencv && args.mode != "dense") return Status::error(args.matcher + " is dense only");
  // A dense map and its time: metrics, timing and (when asked) the picture.
  auto score_dense = [&](const ImageF32& disparity, double ms) -> Status {
    if (Status s = evaluateDense(disparity, gt, mask, eval_options, &out->metrics); !s) {
      return s;
    }
    setTiming(ms, left.width, left.height, &out->metrics);
    if (!args.picture) return Status::ok();
    return renderDenseEvalPicture(
        left, disparity, gt, args.max_disparity_px, eval_options, &out->picture, mask);
  };
  NccScaleReport ncc_report;
  if (args.matcher == "maxtree") {
    if (Status s =
            evalMaxTree(args, left, right, gt, mask, eval_options, &out->metrics, &out->picture);
        !s) {
      return s;
    }
  } else if (args.mode == "dense" && args.matcher == "support") {
    frontend::SupportValueOptions options;
    options.max_disparity_px = args.max_disparity_px;
    if (args.window_px > 0) options.window_px = args.window_px;
    if (!args.fill.empty()) {
      if (Status s = frontend::parseSupportFill(args.fill, &options.fill); !s) return s;
    }
    if (Status s = options.validate(); !s) return s;
    frontend::SupportValueMatcher matcher;
    ImageF32 disparity;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;  // warm-up
    const Timer t0;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;
    if (Status s = score_dense(disparity, t0.elapsedMs()); !s) return s;
  } else if (args.matcher == "ncc") {
    if (Status s = runNcc(
            args, left, right, gt, mask, eval_options, &out->metrics, &out->picture, &ncc_report);
        !s) {
      return s;
    }
  } else if (args.matcher == "opencv-bm" || args.matcher == "opencv-sgbm") {
    // OpenCV's block matchers as the reference, with the parameters of the frontend benchmark
    // (tests/bench/dense_bench.cpp): disparities rounded up to a multiple of 16, BM block 7
    // (--window), SGBM block 5 with P1 = 8 x 25, P2 = 32 x 25. Their 1/16 px fixed point is
    // converted, negative values (no match) become kNoDisparity.
    const int n = (args.max_disparity_px + 1 + 15) / 16 * 16;
    if (n >= left.width)
      return Status::error("max_disparity_px rounded up to " + std::to_string(n) +
                           " disparities (OpenCV wants a multiple of 16) is not smaller than "
                           "the image width");
    cv::Ptr<cv::StereoMatcher> m;
    if (args.matcher == "opencv-bm") {
      const int block = args.window_px > 0 ? args.window_px : 7;
      if (block < 5 || block > 255 || block % 2 == 0)
        return Status::error("window_px = " + std::to_string(block) +
                             ": opencv-bm wants an odd block in [5, 255]");
      m = cv::StereoBM::create(n, block);
    } else {
      const int block = args.window_px > 0 ? args.window_px : 5;
      if (block < 1 || block % 2 == 0)
        return Status::error("window_px = " + std::to_string(block) +
                             ": opencv-sgbm wants an odd block");
      m = cv::StereoSGBM::create(0,
                                 n,
                                 block,
                                 8 * block * block,
                                 32 * block * block,
                                 1,
                                 0,
                                 10,
                                 100,
                                 1,
                                 cv::StereoSGBM::MODE_SGBM);
    }
    cv::Mat fixed;
    m->compute(frontend::asMat(left), frontend::asMat(right), fixed);  // warm-up
    const Timer t0;
    m->compute(frontend::asMat(left), frontend::asMat(right), fixed);
    const double ms = t0.elapsedMs();
    ImageF32 disparity(left.width, left.height);
    for (int v = 0; v < left.height; ++v) {
      for (int u = 0; u < left.width; ++u) {
        const int16_t raw = fixed.at<int16_t>(v, u);
        disparity(u, v) = raw < 0 ? frontend::kNoDisparity : static_cast<float>(raw) / 16.0f;
      }
    }
    if (Status s = score_dense(disparity, ms); !s) return s;
  } else if (args.mode == "dense") {
    frontend::DenseSadOptions options;
    options.max_disparity_px = args.max_disparity_px;
    if (args.window_px > 0) options.window_width_px = args.window_px;
    if (args.post.has_value()) {
      if (Status s = frontend::parsePostSteps(*args.post, &options.steps); !s) return s;
    }
    if (Status s = options.validate(); !s) return s;
    frontend::DenseSadMatcher matcher;
    ImageF32 disparity;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;  // warm-up
    const Timer t0;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;
    if (Status s = score_dense(disparity, t0.elapsedMs()); !s) return s;
  } else {
    frontend::SalientSadOptions sad;
    sad.max_disparity_px = args.max_disparity_px;
    if (args.window_px > 0) sad.window_width_px = args.window_px;
    sad.birchfield_tomasi = args.birchfield_tomasi;
    if (Status s = sad.validate(); !s) return s;
    if (args.max_disparity_px + sad.window_width_px > left.width)
      return Status::error("max_disparity_px plus the window is wider than the image");
    std::optional<frontend::HarrisDetector> detector;
    std::vector<Corner> corners;
    if (Status s = settledDetector(left, args.corners_per_mp, &detector, &corners); !s) return s;
    StereoHypotheses hyps;
    frontend::SupportValueOptions support;
    support.max_disparity_px = args.max_disparity_px;
    if (args.window_px > 0) support.window_px = args.window_px;
    if (args.matcher == "support") {
      if (Status s = support.validate(); !s) return s;
    }
    auto match = [&]() {
      return args.matcher == "support"
                 ? frontend::matchSupportValueSalient(left, right, corners, support, &hyps)
                 : frontend::matchSalient(left, right, corners, sad, &hyps);
    };
    if (Status s = match(); !s) return s;
    const Timer t0;
    if (Status s = detector->detect(left, &corners); !s) return s;
    if (Status s = match(); !s) return s;
    const double ms = t0.elapsedMs();
    if (Status s = evaluateSalient(hyps, gt, mask, eval_options, &out->metrics); !s) {
      return s;
    }
    setTiming(ms, left.width, left.height, &out->metrics);
    if (args.picture) {
      if (Status s = renderSalientEvalPicture(
              left, hyps, gt, args.max_disparity_px, eval_options, &out->picture, mask);
          !s) {
        return s;
      }
    }
  }
  if (args.matcher == "ncc") {
    out->scale_counts.assign(std::begin(ncc_report.counts), std::end(ncc_report.counts));
    out->scale_picture = ncc_report.picture;
  }
  return Status::ok();
}

}  // namespace twocam::eval
