#pragma once
/// Ground-truth disparity for stereo evaluation (docs/conventions.md, "Stereo pairs" and
/// "Simulated runs"): readers for the files benchmark suites ship (Middlebury v2 PGM/PNG with
/// an integer scale, 16-bit PNG as KITTI uses, Middlebury 2014 PFM), a PFM writer, evaluation
/// masks, and ground truth from a simulator depth image. Only `eval` reads ground truth
/// (STYLE.md §2), which is why these readers live here rather than in `io`.
///
/// Convention: disparity maps are ImageF32 in pixels for the LEFT view,
/// d = u_left - u_right >= 0; pixel (0, 0) is the top-left pixel.

#include <optional>
#include <string>

#include "common/image.h"
#include "common/rig.h"
#include "common/status.h"

namespace twocam::eval {

/// A left-view ground-truth disparity map and where it is defined.
struct DisparityGroundTruth {
  /// Ground-truth disparity [px]; meaningful only where valid != 0 (0 elsewhere).
  ImageF32 d_px;
  /// 1 = pixel has ground truth, 0 = unknown (occluded-without-GT, border, discontinuity...).
  /// Same size as d_px.
  ImageU8 valid;
};

/// Relative depth span over a 3x3 neighbourhood above which ground-truth disparity is
/// undefined: (Z_max - Z_min) > kDepthDiscontinuityRelSpan * Z_min. METRICS.md ("Simulated
/// runs") fixes it at 5 %: a window straddling a depth edge has no single true disparity, while
/// a plane keeps its ground truth up to steep slants (the span over two pixel steps is about
/// 2 tan(incidence) / fx, below 5 % up to ~85 deg incidence at fx = 500 px).
constexpr double kDepthDiscontinuityRelSpan = 0.05;

/// Loads a ground-truth disparity map, detecting the format from the file's first bytes:
/// - PFM ("Pf", single-channel float, Middlebury 2014): d = value / scale; non-finite values
///   (Middlebury writes inf) are invalid. Pass scale 1. A three-channel "PF" file is an error
///   (a colour PFM is not a disparity map; taking one channel would hide a wrong file).
/// - 8- or 16-bit single-channel PNG/PGM (Middlebury v2, KITTI): d = value / scale.
///   Pixels whose raw integer value equals `invalid_value` are invalid, and raw 0 always is
///   (Middlebury v2 and KITTI both mark unknown disparity with 0; a further `invalid_value`
///   such as 255 adds to it, it does not replace it).
/// For every format, a given `invalid_value` is compared with the raw stored value, and a
/// resulting disparity that is negative or non-finite is invalid (d >= 0 by convention).
/// Errors (message names the path): missing file, unreadable or truncated image, multi-channel
/// or unsupported depth, bad PFM header, scale not finite and > 0.
Status loadDisparityGroundTruth(const std::string& path,
                                double scale,
                                std::optional<double> invalid_value,
                                DisparityGroundTruth* gt);

/// Reads a single-channel PFM ("Pf") into top-row-first order, values as stored (the header's
/// scale magnitude is not applied; its sign gives the byte order). Strict: the header must be
/// "Pf", positive width and height, a non-zero finite scale, one whitespace byte, then exactly
/// width*height*4 bytes. "PF" (three channels) is rejected.
Status readPfm(const std::string& path, ImageF32* image);

/// Writes a single-channel little-endian PFM (scale -1, rows bottom to top as the format wants).
/// Fails on an empty or inconsistent image or when the file cannot be written.
Status writePfm(const std::string& path, const ImageF32& image);

/// Loads an 8-bit single-channel evaluation mask (e.g. Middlebury nonocc.png). Values are kept
/// as stored; the evaluators keep pixels whose mask value is 255 and drop all others (Middlebury
/// masks use 128 for occluded and 0 for unknown). Errors name the path.
Status loadMask(const std::string& path, ImageU8* mask);

/// Middlebury-style non-occlusion mask derived from the left ground truth alone, for data sets
/// that ship no nonocc.png: 255 where the pixel has ground truth and the right camera sees it,
/// 128 where it has ground truth but is occluded, 0 where it has none (Middlebury's coding, so
/// the evaluators keep only the 255s). A pixel (u, v) with disparity d is occluded when it lands
/// outside the right image (u - d < 0) or when a pixel further right on the row, nearer to the
/// camera, lands at or left of it in the right view: min_{u2 > u} (u2 - d(u2)) <= u - d - 0.5.
/// Pixels without ground truth cannot hide others (their depth is unknown).
void nonOccludedMask(const DisparityGroundTruth& gt, ImageU8* mask);

/// Ground-truth disparity from a simulator's left depth image (METRICS.md "Simulated runs"):
/// d_gt = fx * B / Z. Invalid where Z is not a finite positive number (0 = no surface) and where
/// the 3x3 neighbourhood is a depth discontinuity: it contains a pixel without surface, or its
/// depths span more than kDepthDiscontinuityRelSpan (relative to the nearest depth). At the
/// image edge only the neighbours inside the image count.
/// Errors: empty or inconsistent depth image, rig with fx or baseline not finite and > 0.
/// The rig's image size is not compared with the depth image's (only fx and B are used).
Status disparityFromDepth(const ImageF32& depth_m, const StereoRig& rig, DisparityGroundTruth* gt);

}  // namespace twocam::eval
