#pragma once
/// `twocam stereo-eval`'s core: one matcher on one rectified pair, timed on a second run (the
/// first warms it up), scored against the ground truth (stereo_metrics.h) and drawn when asked
/// (stereo_pictures.h). The matchers: sad (frontend/dense_sad.h, salient_sad.h), support
/// (support_value.h), ncc (ncc_scaled.h), maxtree (maxtree.h), and OpenCV's StereoBM and
/// StereoSGBM as dense references with the frontend benchmark's parameters.

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "eval/disparity_io.h"
#include "eval/stereo_metrics.h"

namespace twocam::eval {

struct MatcherRun {
  /// sad | support | ncc | maxtree | opencv-bm | opencv-sgbm.
  std::string matcher = "sad";
  /// dense | salient | sparse (maxtree's node end points scored as a map).
  std::string mode = "dense";
  /// Largest disparity searched [px].
  int max_disparity_px = 0;
  /// Window width [px]; 0 = the matcher's default (sad dense 7, salient 11; support 13; ncc 5;
  /// opencv-bm 7, opencv-sgbm 5).
  int window_px = 0;
  /// sad dense: post-processing steps ("lrc,prop,median", "none"); nullopt = the default order.
  std::optional<std::string> post;
  /// support dense: hole filling ("none", "linear", "farther"); empty = its default.
  std::string fill;
  /// sad salient: Birchfield-Tomasi interval cost instead of SAD.
  bool birchfield_tomasi = false;
  /// Salient modes: Harris corners per megapixel the detector aims for.
  int corners_per_mp = 3255;
  /// Render the evaluation picture.
  bool picture = false;
};

struct MatcherRunResult {
  StereoMetrics metrics;
  cv::Mat picture;  ///< when MatcherRun::picture
  /// ncc: estimates (dense) or best hypotheses (salient) per window scale 1/sqrt(2), 1,
  /// sqrt(2), and the scale picture (red, green, blue; dimmed grey where none). Empty for the
  /// other matchers.
  std::vector<int64_t> scale_counts;
  cv::Mat scale_picture;
};

/// Runs `run` on the pair and scores it over the pixels (or points) with valid ground truth,
/// inside options.border_px and, when given, where `mask` is 255. Errors name the option
/// (max_disparity_px, window_px, fill, ...) and leave *out unspecified: the matchers' option
/// checks, a mode the matcher does not have, images of the wrong size.
Status runMatcher(const ImageU8& left,
                  const ImageU8& right,
                  const DisparityGroundTruth& gt,
                  const ImageU8* mask,
                  const StereoEvalOptions& options,
                  const MatcherRun& run,
                  MatcherRunResult* out);

}  // namespace twocam::eval
