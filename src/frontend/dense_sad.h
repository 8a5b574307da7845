#pragma once
/// Dense 1-D SAD stereo on a rectified 8-bit pair, with the post-processing of the thesis's
/// Paper C (left-right consistency check, propagation, median filter, in a configurable order).
///
/// Matching (thesis Paper B): for every left pixel (u, v) and every disparity d in
/// [min_disparity_px, max_disparity_px], the cost is the sum of absolute grey-level differences
/// over a 1 x W window along the row, SAD(u, v, d) = sum_{k=-r..r} |L(u+k, v) - R(u+k-d, v)|
/// with W = 2r + 1; pixels beyond the image edge repeat the edge pixel. The winner is the
/// smallest cost (ties go to the smaller disparity); an optional uniqueness test voids
/// ambiguous winners. Only disparities with u - d >= 0 compete,
/// so the leftmost columns search a shorter range and column u < min_disparity_px has no
/// estimate. The same cost volume gives the right view's winners (for a right pixel u_r, the
/// d minimising SAD(u_r + d, v, d)), so the left-right check costs no second matching pass.
///
/// Disparity maps are ImageF32 in the left view [px], d = u_left - u_right >= 0; a negative
/// value (kNoDisparity) means "no estimate". Values are whole pixels, or multiples of 1/16 px
/// (kDisparityStep) with sub-pixel refinement: the post-processing works in that fixed point,
/// as OpenCV's StereoBM does.
///
/// Speed: the window sums slide along the row (two absolute differences per disparity and
/// pixel), in 16-bit lanes that GCC vectorises, with an AVX2 clone picked at load time; see
/// tests/bench/dense_bench.cpp for the comparison with OpenCV's StereoBM and StereoSGBM.
///
/// Post-processing (thesis Paper C §7.5; the order matters, Table 7.2):
///  - kLeftRightCheck: a left estimate d at u survives when the right view's winner at
///    u_r = u - round(d) is within lr_tolerance_px of d; otherwise it becomes kNoDisparity.
///  - kPropagation: fills every pixel without estimate from its row neighbours (thesis rule,
///    see propagateDisparity()).
///  - kMedian: replaces every estimate by the median of the estimates in a
///    median_width_px x median_height_px window (see medianFilterDisparity()).

#include <cstdint>
#include <string>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "frontend/simd.h"

namespace twocam::frontend {

/// Marks a pixel without disparity estimate in a disparity map.
constexpr float kNoDisparity = -1.0f;
/// Resolution of the disparities this module outputs [px] (fixed point, 4 fractional bits).
constexpr float kDisparityStep = 1.0f / 16.0f;
/// Largest disparity value the post-processing functions accept [px] (16-bit fixed point).
constexpr float kMaxDisparityValuePx = 2047.0f;

/// One post-processing step of Paper C.
enum class PostStep { kLeftRightCheck, kPropagation, kMedian };

/// "lrc", "prop" or "median".
std::string toString(PostStep step);
/// Comma-separated step names, e.g. "lrc,prop,median" ("" for no steps).
std::string formatPostSteps(const std::vector<PostStep>& steps);

/// Parses a comma-separated, case-insensitive list of step names into `steps`: "lrc" (also
/// "lr", "leftright"), "prop" (also "propagation"), "median" (also "med"); spaces around names
/// are ignored; "" and "none" mean no steps. A step may appear more than once. Fails naming the
/// unknown token; `steps` is unchanged on failure.
Status parsePostSteps(const std::string& text, std::vector<PostStep>* steps);

struct DenseSadOptions {
  /// Width W of the 1 x W SAD window along the row [px], odd, 3..21 (the thesis's range).
  /// 7 is Paper C's configuration (Table 7.2).
  int window_width_px = 7;
  /// Smallest disparity searched [px], >= 0. 0: objects at infinity are in range.
  int min_disparity_px = 0;
  /// Largest disparity searched [px], inclusive; must be below the image width and at most
  /// min_disparity_px + 255. 63 gives the thesis's 64 disparities.
  int max_disparity_px = 63;
  /// Post-processing steps in the order they run. Default: Paper C's best order
  /// (LRC, propagation, median; Table 7.2 row "LRC-Prop-Med").
  std::vector<PostStep> steps = {
      PostStep::kLeftRightCheck, PostStep::kPropagation, PostStep::kMedian};
  /// Largest |d_left - d_right| the left-right check accepts [px], >= 0. 1 px lets slanted
  /// surfaces and sub-pixel left values through while occlusions (errors of several px) fail;
  /// 0..2 px score alike on Tsukuba (bad1 8.5..8.8 % with the other defaults).
  float lr_tolerance_px = 1.0f;
  /// Width of the propagation window along the row [px], odd, >= 3. 7, the width of the
  /// thesis's median filter, whose hardware the thesis reuses for propagation; 3..7 score alike
  /// on Tsukuba (8.6..8.8 %), wider windows worse (15: 9.5 %).
  int propagation_width_px = 7;
  /// Median window width [px], odd, >= 1. 7 as in the thesis.
  int median_width_px = 7;
  /// Median window height [px], odd, >= 1. The thesis's filter is 1-D (7x1); a second
  /// dimension helps a 1-D matcher most, because its errors are independent from row to row:
  /// Tsukuba bad1 with the default steps 17.4 % (7x1) -> 8.75 % (7x7). Taller windows gain a
  /// little more (9x9, no uniqueness test: 8.8 vs 9.6 % at 7x7) but round off thin objects.
  int median_height_px = 7;
  /// Sub-pixel refinement of each winner by an equiangular (V) fit to the costs at d - 1, d,
  /// d + 1 (the fit that suits SAD, Shimizu & Okutomi 2001: no pull towards whole pixels).
  /// Off by default because the thesis's yardstick is bad1 on Tsukuba, whose ground truth is
  /// whole pixels: there it raises bad1 from 8.75 to 11.9 % (default steps); on slanted
  /// surfaces (Venus) it lowers avgerr from 0.85 to 0.73 px. Turn it on when depth matters
  /// more than that count.
  bool subpixel = false;
  /// Uniqueness test [percent], >= 0: a winner with cost c is rejected (no estimate) unless
  /// every disparity more than 1 px away costs more than c * (100 + uniqueness_percent) / 100.
  /// 0 turns the test off. A confidence measure as Paper C's conclusion suggests: ambiguous
  /// matches (little texture along the row) are left to propagation instead of being
  /// propagated themselves. 10, inside OpenCV's suggested 5..15: on Tsukuba 5..20 all take
  /// bad1 from 9.6 % (off) to 8.75 % with the other defaults.
  int uniqueness_percent = 10;
  /// Which build of the row matcher runs (frontend/simd.h): kAvx2 (kAuto on an AVX2 CPU) the
  /// AVX2 copy, any other the baseline (SSE2 on x86-64) copy. Same results bit for bit.
  Simd simd = Simd::kAuto;

  /// Names the first broken constraint, e.g. "window_width_px = 8; must be odd".
  [[nodiscard]] Status validate() const;
};

/// Dense SAD matcher that keeps its scratch buffers between calls (one per thread; not
/// thread-safe). Results are a pure function of the inputs: reuse changes only the speed.
class DenseSadMatcher {
 public:
  /// Computes the left-view disparity map of a rectified pair, then runs options.steps.
  /// Fails (leaving *disparity untouched) when the images are empty or differ in size, when
  /// max_disparity_px >= width, or when the options are invalid. `disparity` must not be null.
  Status compute(const ImageU8& left,
                 const ImageU8& right,
                 const DenseSadOptions& options,
                 ImageF32* disparity);

  /// Right-view integer winners of the last successful compute() [px] (kNoDisparity where no
  /// disparity was in range), as the left-right check used them.
  [[nodiscard]] const ImageF32& rightDisparity() const { return right_disparity_; }

 private:
  std::vector<uint8_t> left_row_;
  std::vector<uint8_t> right_row_;
  std::vector<uint16_t> sums_;
  std::vector<int16_t> right_cost_;
  std::vector<uint16_t> right_index_;
  std::vector<int16_t> left_fixed_;
  std::vector<int16_t> right_fixed_;
  std::vector<int16_t> work_fixed_;
  ImageF32 right_disparity_;
};

/// One-shot convenience wrapper around DenseSadMatcher::compute().
Status computeDenseDisparity(const ImageU8& left,
                             const ImageU8& right,
                             const DenseSadOptions& options,
                             ImageF32* disparity);

/// Left-right consistency check (Paper C §7.4.3, §7.5.2): every left estimate d at (u, v) whose
/// right-view value at (u - round(d), v) is missing or differs from d by more than
/// tolerance_px becomes kNoDisparity. Fails when the maps differ in size or tolerance_px < 0.
Status leftRightCheck(const ImageF32& right_disparity, float tolerance_px, ImageF32* disparity);

/// Propagation (Paper C §7.5.3), for every pixel without estimate, scanning each row left to
/// right with a window of window_width_px centred on it (estimates as they were before this
/// step): when most window pixels have an estimate, their median (the upper one for an even
/// count) fills the pixel; when some but not most do, their minimum (the farther surface:
/// holes the check leaves are mostly occlusions of background by foreground); when none do,
/// the row's latest output value to the left. Pixels left of a row's first estimate take the
/// first value produced in that row; rows without any estimate stay empty.
/// Fails when window_width_px is even or < 3, or a value exceeds kMaxDisparityValuePx.
Status propagateDisparity(int window_width_px, ImageF32* disparity);

/// Median filter for disparity maps: every estimate becomes the median (the upper one for an
/// even count) of the estimates in the width_px x height_px window centred on it (the window
/// is clipped at the image border); pixels without estimate stay without. Fails when a size
/// is even or < 1, or a value exceeds kMaxDisparityValuePx.
Status medianFilterDisparity(int width_px, int height_px, ImageF32* disparity);

}  // namespace twocam::frontend
