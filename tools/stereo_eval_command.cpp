#include "stereo_eval_command.h"

#include <cctype>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "eval/disparity_io.h"
#include "eval/matcher_eval.h"
#include "eval/stereo_metrics.h"
#include "frontend/cv_interop.h"
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
      {"fill", "--fill"},
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

  eval::MatcherRun run;
  run.matcher = args.matcher;
  run.mode = args.mode;
  run.max_disparity_px = args.max_disp;
  run.window_px = args.window_px;
  if (args.post_given) run.post = args.post;
  run.fill = args.fill;
  run.birchfield_tomasi = args.birchfield_tomasi;
  run.corners_per_mp = args.corners_per_mp;
  run.picture = !args.output_image.empty();
  eval::MatcherRunResult result;
  if (Status s = eval::runMatcher(
          left, right, gt, mask.empty() ? nullptr : &mask, eval_options, run, &result);
      !s) {
    return fail(s.message());
  }
  const eval::StereoMetrics& metrics = result.metrics;
  std::string json = eval::toJson(metrics);
  if (ncc) {
    // The share of each window scale among the estimates [percent], after METRICS.md's keys.
    io::Json value = eval::toJsonValue(metrics);
    int64_t total = 0;
    for (int64_t c : result.scale_counts) total += c;
    const char* keys[] = {"scale_share_0.707", "scale_share_1", "scale_share_1.414"};
    for (size_t i = 0; i < result.scale_counts.size() && i < 3; ++i) {
      value[keys[i]] =
          io::numberOrNull(total > 0 ? 100.0 * static_cast<double>(result.scale_counts[i]) /
                                           static_cast<double>(total)
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
      if (!cv::imwrite(args.scale_image, result.scale_picture))
        return fail(args.scale_image + ": cannot write the picture");
    } catch (const cv::Exception& e) {
      return fail(args.scale_image + ": cannot write the picture (" + e.err + ")");
    }
  }
  if (!args.output_image.empty()) {
    try {
      if (!cv::imwrite(args.output_image, result.picture))
        return fail(args.output_image + ": cannot write the picture");
    } catch (const cv::Exception& e) {
      return fail(args.output_image + ": cannot write the picture (" + e.err + ")");
    }
  }
  return 0;
}

}  // namespace twocam::tools
