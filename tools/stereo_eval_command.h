#pragma once
#include <optional>
#include <string>

namespace twocam::tools {

/// `twocam stereo-eval`: one rectified pair against a ground-truth disparity map.
struct StereoEvalArgs {
  std::string left_path;
  std::string right_path;
  std::string gt_path;
  double gt_scale = 1.0;
  std::optional<double> gt_invalid;
  std::string mask_path;
  int border_px = 0;
  int max_disp = 0;
  std::string mode;  // dense | salient
  std::string output_json;
  std::string output_image;
  /// Matching window width [px]; 0 = the mode's default (dense 7, salient 11).
  int window_px = 0;
  /// Dense post-processing order, e.g. "lrc,prop,median" (empty = the default order).
  std::string post;
  /// Salient mode: number of corners per megapixel the detector aims for.
  int corners_per_mp = 3255;  // 1000 corners at 640x480
  /// Also drop pixels the right camera cannot see, derived from the ground truth
  /// (eval::nonOccludedMask); combined with --mask when both are given.
  bool exclude_occluded = false;
  /// Salient mode: Birchfield-Tomasi interval cost instead of SAD (SalientSadOptions).
  bool birchfield_tomasi = false;
  /// Matcher: "sad" (1-D SAD, dense_sad.h / salient_sad.h) or "ncc" (scaled-window NCC,
  /// ncc_scaled.h).
  std::string matcher = "sad";
  /// --matcher ncc: write the winning window scale of every pixel (dense) or best hypothesis
  /// (salient) as a picture (PNG).
  std::string scale_image;
};

int runStereoEval(const StereoEvalArgs& args);

}  // namespace twocam::tools
