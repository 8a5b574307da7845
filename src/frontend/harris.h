#pragma once
/// Harris corner detector for 8-bit images, after the FPGA design of the thesis (Paper A §5.4):
/// 3x3 Sobel derivatives, 5x5 binomial ("Gaussian built from shifts") weighting of the structure
/// tensor, response det(M) - k trace(M)^2, 3x3 non-maximum suppression, and a threshold adapted
/// from frame to frame toward a target corner count. Optional grid bucketing spreads the corners.
///
/// Response scale (fixed, used by thresholds and tests):
///   g_u, g_v  = 3x3 Sobel of the grey levels, unnormalised: [-1 0 1] x [1 2 1]^T and its
///               transpose, so a ramp of s grey levels per pixel gives g = 8 s;
///   M(u, v)   = sum over the 5x5 window of w * [g_u^2, g_u g_v; g_u g_v, g_v^2], with
///               w = b b^T / 256, b = [1 4 6 4 1] (weights sum to 1);
///   R(u, v)   = det(M) - k trace(M)^2                                     [grey level^4].
/// The structure tensor is computed exactly in 32-bit integers; only R is formed in float.
///
/// The hot path is a fused row pipeline (Sobel + products -> vertical binomial -> horizontal
/// binomial + response -> suppression + threshold) over small ring buffers, compiled twice on
/// x86-64 (baseline and AVX2, chosen at run time). Both builds give bit-identical results (a test
/// checks it; a build that lets the compiler contract float multiply-adds into FMA, such as
/// -march=native, could differ in the last bit of R).

#include <cstddef>  // common/image.h uses size_t without including it
#include <cstdint>
#include <limits>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"
#include "frontend/simd.h"

namespace twocam::frontend {

struct HarrisOptions {
  /// Harris sensitivity k in det(M) - k trace(M)^2, in (0, 0.25). 0.04 is the classic value
  /// (Harris & Stephens); larger values reject more edge-like points.
  float k = 0.04f;
  /// No corner closer than this to any image edge [px]. 8 so that an 11-wide SAD window plus a
  /// few rows of vertical search fit around every corner. At least 4: the Sobel (1), binomial (2)
  /// and suppression (1) kernels reach 4 px, so the detector never reads past the image.
  int border_px = 8;
  /// Number of corners per frame the adaptive threshold steers toward (HarrisDetector). 1000 is
  /// the frontend's budget for 640x480 (the thesis extracts about 300 per 320x480 frame).
  int target_count = 1000;
  /// Threshold on R for the first frame [grey level^4, see the file comment]. An ideal step corner
  /// of contrast c gives R ~ 0.37 c^4. 1e8 lies mid-range of what gives ~1000 corners on the shared
  /// images (measured: 640x480 bench texture 3927, graffiti 800x640 879, EuRoC 752x480 436,
  /// Tsukuba 384x288 374); the adaptation corrects it within a few frames.
  float initial_threshold = 1e8f;
  /// Weight in [0, 1] of the latest frame's estimate in the threshold update
  /// log t <- (1 - rate) log t + rate log t_frame (see HarrisDetector); 0 keeps the threshold
  /// fixed, 1 jumps to each frame's estimate. 0.75 cuts the log error 4x per frame on a still
  /// scene (within 10% of the target after ~5 frames from 100x off, measured) while damping
  /// one-frame outliers such as a motion-blurred frame.
  float threshold_adapt_rate = 0.75f;
  /// Lower clamp of the adaptive threshold [grey level^4]. 1e4 is a step corner of about 5 grey
  /// levels, near sensor noise, and stops a blank frame from driving the threshold to 0.
  float threshold_min = 1e4f;
  /// Upper clamp of the adaptive threshold [grey level^4]. 1e12 is 10x a full-contrast (255) step
  /// corner, so it only guards against runaway values.
  float threshold_max = 1e12f;
  /// Hard cap on corners returned per frame, keeping the strongest. 2000 bounds the stereo
  /// matcher's work while the threshold is still converging (2x the target).
  int max_corners = 2000;
  /// Keep at most max_per_cell corners in each cell of a grid_cols x grid_rows grid over the
  /// image, so corners spread instead of piling up on the most textured region. Off by default:
  /// the thesis detector has no bucketing, and the adaptive threshold already bounds the count.
  bool bucketing = false;
  /// Grid columns for bucketing (cells of 80 px on a 640-px-wide image).
  int grid_cols = 8;
  /// Grid rows for bucketing (cells of 80 px on a 480-px-high image).
  int grid_rows = 6;
  /// Corners kept per bucketing cell, strongest first. 40 x 48 cells = 1920, about 2x the
  /// target, so bucketing trims dense cells without starving the frame.
  int max_per_cell = 40;
  /// Which build of the fused pipeline runs (frontend/simd.h): kAvx2 (kAuto on an AVX2 CPU) the
  /// AVX2 build, any other the baseline build. Same results bit for bit; for tests and profiling.
  /// Frontend sets it from FrontendOptions::simd, the config's one SIMD knob (frontend.simd).
  Simd simd = Simd::kAuto;

  /// Names the first broken constraint, e.g. "k = 0.3; must be in (0, 0.25)".
  [[nodiscard]] Status validate() const;
};

/// Smallest image side accepted by detectHarrisCorners / HarrisDetector: 2 * border_px + 1.
/// harrisResponse needs 7 (its valid region starts 3 px from each edge).
int minHarrisImageSide(const HarrisOptions& options);

/// Harris response of every pixel in the fixed scale above (only options.k and simd matter).
/// Pixels closer than 3 px to an edge, where the kernels do not fit, are 0. `response` is resized
/// to the image size. Fails on an empty or inconsistent image, a side below 7 px, invalid
/// options or a null output; `response` is left untouched then.
Status harrisResponse(const ImageU8& image, const HarrisOptions& options, ImageF32* response);

/// The suppression rule shared by the detector and its references: a pixel is a corner when
/// R > threshold, R is greater than its 4 neighbours that precede it in raster order and not
/// smaller than the 4 that follow it (so of a plateau, the first pixel in raster order wins).
/// Selection then keeps, strongest first, at most max_per_cell per grid cell (when bucketing)
/// and max_corners in all. Output sorted by descending response, ties by (v, u).
///
/// This variant works on a precomputed response image (any scale, e.g. cv::cornerHarris); it is
/// the float reference path for tests. Pixels closer than options.border_px to an edge are never
/// corners. `num_candidates`, when given, receives the count before the caps.
Status selectCornersFromResponse(const ImageF32& response,
                                 const HarrisOptions& options,
                                 float threshold,
                                 std::vector<Corner>* corners,
                                 int* num_candidates = nullptr);

/// Stateless Harris detection at a fixed threshold [grey level^4]: response, suppression and
/// selection as above, fused in one pass. Output sorted by descending response, ties by (v, u).
/// Fails (leaving `corners` empty) on an empty or inconsistent image, a side below
/// minHarrisImageSide(options), invalid options, a negative or non-finite threshold or a null
/// output. Allocates its scratch buffers on every call; use HarrisDetector for a stream.
Status detectHarrisCorners(const ImageU8& image,
                           const HarrisOptions& options,
                           float threshold,
                           std::vector<Corner>* corners);

namespace internal {
/// Scratch rows of the fused pipeline; grows to the widest image seen, then is reused.
struct HarrisWorkspace {
  std::vector<int32_t> products;  // 5 ring rows x 3 channels (g_u^2, g_v^2, g_u g_v)
  std::vector<int32_t> vertical;  // 3 channels, one row
  std::vector<float> responses;   // 3 ring rows
  std::vector<uint8_t> flags;     // one row of suppression results
  std::vector<uint64_t> keys;     // candidates: ordered (response, raster index) keys
  std::vector<int32_t> cell_counts;
};
/// What one detection saw besides its corners (for the adaptive threshold).
struct HarrisFrameStats {
  /// Suppressed maxima above the threshold, before bucketing and max_corners.
  int num_candidates = 0;
  /// Response of the target_count-th strongest candidate; NaN when there are fewer.
  float target_rank_response = std::numeric_limits<float>::quiet_NaN();
};
/// detectHarrisCorners with caller-owned scratch; `stats` may be null.
Status detectHarrisCorners(const ImageU8& image,
                           const HarrisOptions& options,
                           float threshold,
                           HarrisWorkspace* workspace,
                           std::vector<Corner>* corners,
                           HarrisFrameStats* stats);
/// True when this build has the AVX2 kernels and the CPU runs them.
bool harrisAvx2Available();
}  // namespace internal

/// Harris detection over a stream of frames (the thesis' threshold adapted to the previous frame's
/// count). After each frame, with n the number of suppressed maxima above the threshold t before
/// the caps, the frame's estimate t_frame is
///   - n >= target_count: the threshold that would have kept exactly target_count of them (read
///     off the sorted candidates, so it does not depend on how the count scales with t);
///   - n <  target_count: t * (max(n, 1) / target_count)^2, a deliberate overshoot downward;
/// and t <- clamp(exp((1 - rate) log t + rate log t_frame), threshold_min, threshold_max).
/// Scratch buffers and
/// the output vector's capacity are reused: after the first frame of a given size, detect() does
/// not allocate unless a frame has more candidates than any before.
class HarrisDetector {
 public:
  explicit HarrisDetector(HarrisOptions options);

  /// Detects corners with the current threshold, then adapts the threshold. Fails, leaving the
  /// threshold unchanged and `corners` empty, for the same reasons as detectHarrisCorners.
  Status detect(const ImageU8& image, std::vector<Corner>* corners);

  /// Threshold the next detect() will use [grey level^4].
  [[nodiscard]] float threshold() const { return threshold_; }
  /// Suppressed maxima above the threshold in the last successful frame, before the caps.
  [[nodiscard]] int lastCandidateCount() const { return last_candidates_; }
  [[nodiscard]] const HarrisOptions& options() const { return options_; }
  /// Back to options.initial_threshold (e.g. after a scene cut).
  void reset();

 private:
  HarrisOptions options_;
  float threshold_;
  int last_candidates_ = 0;
  internal::HarrisWorkspace workspace_;
};

}  // namespace twocam::frontend
