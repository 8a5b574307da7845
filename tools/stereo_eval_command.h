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
  std::string mode;  // dense | salient | sparse (maxtree only)
  /// Matcher: "sad" (1-D SAD, the default: dense_sad.h / salient_sad.h), "support" (support
  /// value, support_value.h), "ncc" (scaled-window NCC, ncc_scaled.h) or "maxtree" (1-D Max-Trees,
  /// maxtree.h: dense = its semi-dense map, sparse = its sparse points, salient = its nodes at
  /// corners).
  std::string matcher = "sad";
  /// Support matcher, dense mode: how holes are filled ("none", "linear", "farther"; empty =
  /// the matcher's default).
  std::string fill;
  std::string output_json;
  std::string output_image;
  /// Matching window width [px]; 0 = the mode's default (dense 7, salient 11).
  int window_px = 0;
  /// Dense post-processing order, e.g. "lrc,prop,median" or "none" (not given = the default
  /// order); post_given: the flag was on the command line (an empty value is then an error,
  /// not the default).
  std::string post;
  bool post_given = false;
  /// Salient mode: number of corners per megapixel the detector aims for.
  int corners_per_mp = 3255;  // 1000 corners at 640x480
  /// Also drop pixels the right camera cannot see, derived from the ground truth
  /// (eval::nonOccludedMask); combined with --mask when both are given.
  bool exclude_occluded = false;
  /// Salient mode: Birchfield-Tomasi interval cost instead of SAD (SalientSadOptions).
  bool birchfield_tomasi = false;
  /// --matcher ncc: write the winning window scale of every pixel (dense) or best hypothesis
  /// (salient) as a picture (PNG).
  std::string scale_image;
};

int runStereoEval(const StereoEvalArgs& args);

}  // namespace twocam::tools
