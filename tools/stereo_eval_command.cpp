#include "stereo_eval_command.h"

#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "eval/disparity_io.h"
#include "eval/stereo_metrics.h"
#include "eval/stereo_pictures.h"
#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "frontend/harris.h"
#include "frontend/maxtree.h"
#include "frontend/ncc_scaled.h"
#include "frontend/salient_sad.h"
#include "frontend/support_value.h"
#include "io/json.h"

namespace twocam::tools {
namespace fs = std::filesystem;

namespace {

/// The matchers' option checks name their fields; the user typed flags. Each field that a
/// flag sets is named by its flag (the value in the message is the one the user gave).
std::string flagWording(std::string message) {
  static const std::pair<const char*, const char*> kFlags[] = {
      {"max_disparity_px", "--max-disp"},
      {"window_width_px", "--window"},
      {"window_size_px", "--window"},
      {"window_px", "--window"},
  };
  for (const auto& [field, flag] : kFlags) {
    for (size_t at = message.find(field); at != std::string::npos;
         at = message.find(field, at + std::string(flag).size())) {
      const bool word_start =
          at == 0 ||
          (!std::isalnum(static_cast<unsigned char>(message[at - 1])) && message[at - 1] != '_');
      const size_t end = at + std::string(field).size();
      const bool word_end =
          end >= message.size() ||
          (!std::isalnum(static_cast<unsigned char>(message[end])) && message[end] != '_');
      if (word_start && word_end) message.replace(at, std::string(field).size(), flag);
    }
  }
  return message;
}

int fail(const std::string& message) {
  std::cerr << "twocam stereo-eval: error: " << flagWording(message) << std::endl;
  return 1;
}

/// Fails early when an output file cannot be created, before any work is done.
Status checkWritable(const std::string& path) {
  if (path.empty()) return Status::ok();
  const std::filesystem::path p(path);
  const std::filesystem::path dir =
      p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(dir)) return Status::error(path + ": folder does not exist");
  if (std::filesystem::is_directory(p)) return Status::error(path + ": is a folder");
  return Status::ok();
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// `--matcher maxtree`: semi-dense (dense), sparse or salient output of frontend/maxtree.h, timed
/// on a second run like the SAD branches.
Status evalMaxTree(const StereoEvalArgs& args,
                   const ImageU8& left,
                   const ImageU8& right,
                   const eval::DisparityGroundTruth& gt,
                   const ImageU8* mask,
                   const eval::StereoEvalOptions& eval_options,
                   eval::StereoMetrics* metrics,
                   cv::Mat* picture) {
  frontend::MaxTreeOptions options;
  options.max_disparity_px = args.max_disp;
  if (Status s = options.validate(); !s) return s;
  frontend::MaxTreeMatcher matcher;
  frontend::MaxTreeResult result;
  if (Status s = matcher.compute(left, right, options, &result); !s) return s;  // warm-up
  if (args.mode == "salient") {
    frontend::HarrisOptions harris;
    harris.target_count = std::max(
        1,
        static_cast<int>(
            args.corners_per_mp * 1e-6 * static_cast<double>(left.width) * left.height + 0.5));
    harris.max_corners = 2 * harris.target_count;
    if (Status s = harris.validate(); !s) return s;
    frontend::HarrisDetector detector(harris);
    std::vector<Corner> corners;
    for (int pass = 0; pass < 4; ++pass) {  // settle the adaptive threshold, as for SAD
      if (Status s = detector.detect(left, &corners); !s) return s;
    }
    StereoHypotheses hyps;
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = detector.detect(left, &corners); !s) return s;
    if (Status s = frontend::matchMaxTreeSalient(left, right, corners, options, &hyps); !s)
      return s;
    const double ms = msSince(t0);
    if (Status s = eval::evaluateSalient(hyps, gt, mask, eval_options, metrics); !s) return s;
    eval::setTiming(ms, left.width, left.height, metrics);
    if (!args.output_image.empty()) {
      return eval::renderSalientEvalPicture(
          left, hyps, gt, args.max_disp, eval_options, picture, mask);
    }
    return Status::ok();
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (Status s = matcher.compute(left, right, options, &result); !s) return s;
  const double ms = msSince(t0);
  const ImageF32& map = args.mode == "sparse" ? result.sparse : result.semi_dense;
  if (Status s = eval::evaluateDense(map, gt, mask, eval_options, metrics); !s) return s;
  eval::setTiming(ms, left.width, left.height, metrics);
  if (!args.output_image.empty()) {
    return eval::renderDenseEvalPicture(left, map, gt, args.max_disp, eval_options, picture, mask);
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
Status runNcc(const StereoEvalArgs& args,
              const ImageU8& left,
              const ImageU8& right,
              const eval::DisparityGroundTruth& gt,
              const ImageU8* mask,
              const eval::StereoEvalOptions& eval_options,
              eval::StereoMetrics* metrics,
              cv::Mat* picture,
              NccScaleReport* report) {
  frontend::NccScaledOptions options;
  options.max_disparity_px = args.max_disp;
  if (args.window_px > 0) options.window_size_px = args.window_px;
  if (Status s = options.validate(); !s) return s;
  const bool want_picture = !args.output_image.empty();
  report->picture = dimmedGrey(left);
  if (args.mode == "dense") {
    frontend::NccScaledMatcher matcher;
    ImageF32 disparity;
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;  // warm-up
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return s;
    const double ms = msSince(t0);
    if (Status s = eval::evaluateDense(disparity, gt, mask, eval_options, metrics); !s) return s;
    eval::setTiming(ms, left.width, left.height, metrics);
    for (int v = 0; v < left.height; ++v) {
      for (int u = 0; u < left.width; ++u) {
        const uint8_t index = matcher.scaleIndex()(u, v);
        if (index >= frontend::kNccScaleCount) continue;
        ++report->counts[index];
        report->picture.at<cv::Vec3b>(v, u) = scaleColour(index);
      }
    }
    if (want_picture) {
      return eval::renderDenseEvalPicture(
          left, disparity, gt, args.max_disp, eval_options, picture, mask);
    }
    return Status::ok();
  }
  frontend::HarrisOptions harris;
  harris.target_count = std::max(
      1,
      static_cast<int>(args.corners_per_mp * 1e-6 * static_cast<double>(left.width) * left.height +
                       0.5));
  harris.max_corners = 2 * harris.target_count;
  if (Status s = harris.validate(); !s) return s;
  frontend::HarrisDetector detector(harris);
  std::vector<Corner> corners;
  StereoHypotheses hyps;
  std::vector<uint8_t> scales;
  constexpr int kSettlingPasses = 4;  // as the SAD branch: let the corner count settle
  for (int pass = 0; pass < kSettlingPasses; ++pass) {
    if (Status s = detector.detect(left, &corners); !s) return s;
  }
  if (Status s = frontend::matchNccSalient(left, right, corners, options, &hyps, &scales); !s)
    return s;
  const auto t0 = std::chrono::steady_clock::now();
  if (Status s = detector.detect(left, &corners); !s) return s;
  if (Status s = frontend::matchNccSalient(left, right, corners, options, &hyps, &scales); !s)
    return s;
  const double ms = msSince(t0);
  if (Status s = eval::evaluateSalient(hyps, gt, mask, eval_options, metrics); !s) return s;
  eval::setTiming(ms, left.width, left.height, metrics);
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
    return eval::renderSalientEvalPicture(
        left, hyps, gt, args.max_disp, eval_options, picture, mask);
  }
  return Status::ok();
}

Status writeText(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::trunc);
  if (!f) return Status::error(path + ": cannot open for writing");
  f << text << '\n';
  f.flush();
  if (!f) return Status::error(path + ": write failed");
  return Status::ok();
}

}  // namespace

int runStereoEval(const StereoEvalArgs& args) {
  const bool opencv = args.matcher == "opencv-bm" || args.matcher == "opencv-sgbm";
  if (args.matcher != "sad" && args.matcher != "support" && args.matcher != "ncc" &&
      args.matcher != "maxtree" && !opencv)
    return fail(
        "--matcher must be one of: sad, support, ncc, maxtree, opencv-bm, opencv-sgbm; got '" +
        args.matcher + "'");
  if (opencv && args.mode != "dense")
    return fail("--matcher " + args.matcher + " is a dense reference: --mode dense only");
  const bool ncc = args.matcher == "ncc";
  if (args.matcher == "maxtree" && args.window_px > 0)
    return fail("--window applies to --matcher sad, support and ncc only");
  if (args.matcher != "support" && !args.fill.empty())
    return fail("--fill applies to --matcher support only");
  if (args.post_given && args.post.find_first_not_of(" \t") == std::string::npos)
    return fail("--post is empty; give the steps in order (e.g. lrc,prop,median) or none");
  if (args.matcher != "sad" && (args.birchfield_tomasi || args.post_given))
    return fail("--birchfield-tomasi and --post apply to --matcher sad only");
  if (!ncc && !args.scale_image.empty()) return fail("--scale-image applies to --matcher ncc only");
  if (Status s = checkWritable(args.scale_image); !s) return fail(s.message());
  if (args.mode == "sparse" && args.matcher != "maxtree")
    return fail("--mode sparse needs --matcher maxtree (the others have dense and salient modes)");
  if (args.mode != "dense" && args.mode != "salient" && args.mode != "sparse")
    return fail("--mode must be dense, salient or sparse (maxtree), got '" + args.mode + "'");
  if (!(args.gt_scale > 0.0)) return fail("--gt-scale must be > 0");
  if (args.birchfield_tomasi && args.mode != "salient") {
    return fail(
        "--birchfield-tomasi applies to --mode salient only (the dense matcher is plain SAD)");
  }
  if (args.border_px < 0) return fail("--border must be >= 0");
  if (Status s = checkWritable(args.output_json); !s) return fail(s.message());
  if (Status s = checkWritable(args.output_image); !s) return fail(s.message());
  for (const std::string* picture_path : {&args.output_image, &args.scale_image}) {
    if (picture_path->empty()) continue;
    // OpenCV picks the format from the extension and throws a multi-line exception for one it
    // does not know; ask it first, before any work is done.
    bool known = false;
    try {
      known = cv::haveImageWriter(*picture_path);
    } catch (const cv::Exception&) {
      known = false;
    }
    if (!known) {
      return fail(std::string(picture_path == &args.output_image ? "--image " : "--scale-image ") +
                  *picture_path + ": unknown picture format '" +
                  fs::path(*picture_path).extension().string() + "' (use .png)");
    }
  }

  ImageU8 left, right;
  if (Status s = frontend::loadGrey(args.left_path, &left); !s) return fail(s.message());
  if (Status s = frontend::loadGrey(args.right_path, &right); !s) return fail(s.message());
  if (left.width != right.width || left.height != right.height) {
    return fail("left (" + std::to_string(left.width) + "x" + std::to_string(left.height) +
                ") and right (" + std::to_string(right.width) + "x" + std::to_string(right.height) +
                ") images differ in size");
  }
  if (args.max_disp <= 0) return fail("--max-disp must be > 0");
  // The 1-D SAD and support-value matchers keep a disparity in 8 bits of their cost tables.
  if ((args.matcher == "sad" || args.matcher == "support") && args.max_disp > 255) {
    return fail("--max-disp " + std::to_string(args.max_disp) + ": --matcher " + args.matcher +
                " searches at most 256 disparities (0..255); ncc and maxtree have no such cap");
  }
  if (args.max_disp >= left.width) {
    return fail("--max-disp " + std::to_string(args.max_disp) +
                " is not smaller than the image width " + std::to_string(left.width));
  }
  eval::DisparityGroundTruth gt;
  if (Status s = eval::loadDisparityGroundTruth(args.gt_path, args.gt_scale, args.gt_invalid, &gt);
      !s) {
    return fail(s.message());
  }
  if (gt.d_px.width != left.width || gt.d_px.height != left.height) {
    return fail(args.gt_path + ": ground truth is " + std::to_string(gt.d_px.width) + "x" +
                std::to_string(gt.d_px.height) + " but the images are " +
                std::to_string(left.width) + "x" + std::to_string(left.height));
  }
  ImageU8 mask;
  if (!args.mask_path.empty()) {
    if (Status s = eval::loadMask(args.mask_path, &mask); !s) return fail(s.message());
    if (mask.width != left.width || mask.height != left.height)
      return fail(args.mask_path + ": mask size differs from the images");
  }
  if (args.exclude_occluded) {
    ImageU8 visible;
    eval::nonOccludedMask(gt, &visible);
    if (mask.empty()) {
      mask = std::move(visible);
    } else {
      for (size_t i = 0; i < mask.data.size(); ++i) {
        if (visible.data[i] != 255) mask.data[i] = 0;
      }
    }
  }
  eval::StereoEvalOptions eval_options;
  eval_options.border_px = args.border_px;
  if (Status s = eval_options.validate(); !s) return fail(s.message());

  eval::StereoMetrics metrics;
  cv::Mat picture;
  // A dense map and its time: metrics, timing and (when asked) the picture.
  auto score_dense = [&](const ImageF32& disparity, double ms) -> Status {
    if (Status s = eval::evaluateDense(
            disparity, gt, mask.empty() ? nullptr : &mask, eval_options, &metrics);
        !s) {
      return s;
    }
    eval::setTiming(ms, left.width, left.height, &metrics);
    if (args.output_image.empty()) return Status::ok();
    return eval::renderDenseEvalPicture(
        left, disparity, gt, args.max_disp, eval_options, &picture, mask.empty() ? nullptr : &mask);
  };
  NccScaleReport ncc_report;
  if (args.matcher == "maxtree") {
    if (Status s = evalMaxTree(args,
                               left,
                               right,
                               gt,
                               mask.empty() ? nullptr : &mask,
                               eval_options,
                               &metrics,
                               &picture);
        !s) {
      return fail(s.message());
    }
  } else if (args.mode == "dense" && args.matcher == "support") {
    frontend::SupportValueOptions options;
    options.max_disparity_px = args.max_disp;
    if (args.window_px > 0) options.window_px = args.window_px;
    if (!args.fill.empty()) {
      if (Status s = frontend::parseSupportFill(args.fill, &options.fill); !s)
        return fail("--fill: " + s.message());
    }
    if (Status s = options.validate(); !s) return fail(s.message());
    frontend::SupportValueMatcher matcher;
    ImageF32 disparity;
    if (Status s = matcher.compute(left, right, options, &disparity); !s)
      return fail(s.message());  // warm-up
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return fail(s.message());
    if (Status s = score_dense(disparity, msSince(t0)); !s) return fail(s.message());
  } else if (ncc) {
    if (Status s = runNcc(args,
                          left,
                          right,
                          gt,
                          mask.empty() ? nullptr : &mask,
                          eval_options,
                          &metrics,
                          &picture,
                          &ncc_report);
        !s) {
      return fail(s.message());
    }
  } else if (opencv) {
    // OpenCV's block matchers as the reference, with the parameters of the frontend benchmark
    // (tests/bench/dense_bench.cpp): disparities rounded up to a multiple of 16, BM block 7
    // (--window), SGBM block 5 with P1 = 8 x 25, P2 = 32 x 25. Their 1/16 px fixed point is
    // converted, negative values (no match) become kNoDisparity.
    const int n = (args.max_disp + 1 + 15) / 16 * 16;
    if (n >= left.width)
      return fail("--max-disp rounded up to " + std::to_string(n) +
                  " disparities (OpenCV wants a multiple of 16) is not smaller "
                  "than the image width");
    cv::Ptr<cv::StereoMatcher> m;
    if (args.matcher == "opencv-bm") {
      const int block = args.window_px > 0 ? args.window_px : 7;
      if (block < 5 || block > 255 || block % 2 == 0)
        return fail("--window " + std::to_string(block) + ": opencv-bm wants an odd block 5..255");
      m = cv::StereoBM::create(n, block);
    } else {
      const int block = args.window_px > 0 ? args.window_px : 5;
      if (block < 1 || block % 2 == 0)
        return fail("--window " + std::to_string(block) + ": opencv-sgbm wants an odd block");
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
    const auto t0 = std::chrono::steady_clock::now();
    m->compute(frontend::asMat(left), frontend::asMat(right), fixed);
    const double ms = msSince(t0);
    ImageF32 disparity(left.width, left.height);
    for (int v = 0; v < left.height; ++v) {
      for (int u = 0; u < left.width; ++u) {
        const int16_t raw = fixed.at<int16_t>(v, u);
        disparity(u, v) = raw < 0 ? frontend::kNoDisparity : static_cast<float>(raw) / 16.0f;
      }
    }
    if (Status s = score_dense(disparity, ms); !s) return fail(s.message());
  } else if (args.mode == "dense") {
    frontend::DenseSadOptions options;
    options.max_disparity_px = args.max_disp;
    if (args.window_px > 0) options.window_width_px = args.window_px;
    if (args.post_given) {
      if (Status s = frontend::parsePostSteps(args.post, &options.steps); !s)
        return fail(s.message());
    }
    if (Status s = options.validate(); !s) return fail(s.message());
    frontend::DenseSadMatcher matcher;
    ImageF32 disparity;
    if (Status s = matcher.compute(left, right, options, &disparity); !s)
      return fail(s.message());  // warm-up
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = matcher.compute(left, right, options, &disparity); !s) return fail(s.message());
    if (Status s = score_dense(disparity, msSince(t0)); !s) return fail(s.message());
  } else {
    frontend::HarrisOptions harris;
    harris.target_count = std::max(
        1,
        static_cast<int>(
            args.corners_per_mp * 1e-6 * static_cast<double>(left.width) * left.height + 0.5));
    harris.max_corners = 2 * harris.target_count;
    frontend::SalientSadOptions sad;
    sad.max_disparity_px = args.max_disp;
    if (args.window_px > 0) sad.window_width_px = args.window_px;
    sad.birchfield_tomasi = args.birchfield_tomasi;
    if (Status s = harris.validate(); !s) return fail(s.message());
    if (Status s = sad.validate(); !s) return fail(s.message());
    if (args.max_disp + sad.window_width_px > left.width)
      return fail("--max-disp plus the window is wider than the image");
    // The detector adapts its threshold from frame to frame; a single image is shown to it a few
    // times so that the count settles near the target, and the last pass is timed.
    frontend::HarrisDetector detector(harris);
    std::vector<Corner> corners;
    StereoHypotheses hyps;
    constexpr int kSettlingPasses = 4;
    for (int pass = 0; pass < kSettlingPasses; ++pass) {
      if (Status s = detector.detect(left, &corners); !s) return fail(s.message());
    }
    frontend::SupportValueOptions support;
    support.max_disparity_px = args.max_disp;
    if (args.window_px > 0) support.window_px = args.window_px;
    if (args.matcher == "support") {
      if (Status s = support.validate(); !s) return fail(s.message());
    }
    auto match = [&]() {
      return args.matcher == "support"
                 ? frontend::matchSupportValueSalient(left, right, corners, support, &hyps)
                 : frontend::matchSalient(left, right, corners, sad, &hyps);
    };
    if (Status s = match(); !s) return fail(s.message());
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = detector.detect(left, &corners); !s) return fail(s.message());
    if (Status s = match(); !s) return fail(s.message());
    const double ms = msSince(t0);
    if (Status s =
            eval::evaluateSalient(hyps, gt, mask.empty() ? nullptr : &mask, eval_options, &metrics);
        !s) {
      return fail(s.message());
    }
    eval::setTiming(ms, left.width, left.height, &metrics);
    if (!args.output_image.empty()) {
      if (Status s = eval::renderSalientEvalPicture(left,
                                                    hyps,
                                                    gt,
                                                    args.max_disp,
                                                    eval_options,
                                                    &picture,
                                                    mask.empty() ? nullptr : &mask);
          !s) {
        return fail(s.message());
      }
    }
  }
  std::string json = eval::toJson(metrics);
  if (ncc) {
    // The share of each window scale among the estimates [percent], after METRICS.md's keys.
    io::Json value = eval::toJsonValue(metrics);
    const int64_t total = ncc_report.counts[0] + ncc_report.counts[1] + ncc_report.counts[2];
    const char* keys[frontend::kNccScaleCount] = {
        "scale_share_0.707", "scale_share_1", "scale_share_1.414"};
    for (int i = 0; i < frontend::kNccScaleCount; ++i) {
      value[keys[i]] = io::numberOrNull(
          total > 0 ? 100.0 * static_cast<double>(ncc_report.counts[i]) / static_cast<double>(total)
                    : std::numeric_limits<double>::quiet_NaN());
    }
    json = io::toJsonText(value, io::kMetricsJsonDigits);
    while (!json.empty() && json.back() == '\n') json.pop_back();
  }
  std::cout << json << std::endl;
  if (!args.output_json.empty()) {
    if (Status s = writeText(args.output_json, json); !s) return fail(s.message());
  }
  if (!args.scale_image.empty()) {
    try {
      if (!cv::imwrite(args.scale_image, ncc_report.picture))
        return fail(args.scale_image + ": cannot write the picture");
    } catch (const cv::Exception& e) {
      return fail(args.scale_image + ": cannot write the picture (" + e.err + ")");
    }
  }
  if (!args.output_image.empty()) {
    try {
      if (!cv::imwrite(args.output_image, picture))
        return fail(args.output_image + ": cannot write the picture");
    } catch (const cv::Exception& e) {
      return fail(args.output_image + ": cannot write the picture (" + e.err + ")");
    }
  }
  return 0;
}

}  // namespace twocam::tools
