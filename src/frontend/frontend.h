#pragma once
/// The frontend of one stereo stream: Harris corners in the left image, then disparity
/// hypotheses at those corners, either by 1-D SAD along the scanline (Paper B, the default) or
/// by pairing with the right image's corners (Paper A's spurious matching). Holds the detectors'
/// adaptive thresholds and all scratch buffers, so a frame costs no allocation once warm.

#include <string>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/status.h"
#include "frontend/harris.h"
#include "frontend/maxtree.h"
#include "frontend/ncc_scaled.h"
#include "frontend/salient_sad.h"
#include "frontend/support_value.h"

namespace twocam::frontend {

enum class HypothesisSource {
  kSad,            ///< 1-D SAD cost-curve minima at every left corner (Paper B)
  kCornerPairing,  ///< every right corner in the search window (Paper A)
  kSupport,        ///< support value at every left corner (seed 004, frontend/support_value.h)
  kNcc,            ///< scaled-window NCC at every left corner (Bradley 2008, ncc_scaled.h)
  kMaxTree,        ///< 1-D Max-Tree sparse points, its own salient points (maxtree.h)
};

/// "sad", "pairing", "support", "ncc" or "maxtree".
Status parseHypothesisSource(const std::string& name, HypothesisSource* source);
const char* hypothesisSourceName(HypothesisSource source);

struct FrontendOptions {
  HarrisOptions harris;
  SalientSadOptions sad;
  /// Where hypotheses come from. SAD by default: it measures every disparity of the search range,
  /// while pairing needs the right corner to be detected too (see docs/frontend.md for figures).
  HypothesisSource source = HypothesisSource::kSad;
  /// The one SIMD choice of the frontend (frontend/simd.h, config key frontend.simd): Frontend
  /// runs Harris and the salient kernels with it, overriding harris.simd and sad.simd. Results
  /// are identical for every choice; auto picks the fastest this CPU runs.
  Simd simd = Simd::kAuto;

  [[nodiscard]] Status validate() const;
  /// A copy with harris.simd and sad.simd set to simd (what Frontend runs).
  [[nodiscard]] FrontendOptions applied() const;
  /// The other matchers' options as the frontend runs them: their papers' defaults (see
  /// docs/matchers/) with the SAD matcher's disparity range (sad.min/max_disparity_px), so that
  /// the landmark database's range (pipeline::clampToRig) holds for every source.
  [[nodiscard]] SupportValueOptions supportOptions() const;
  [[nodiscard]] NccScaledOptions nccOptions() const;
  [[nodiscard]] MaxTreeOptions maxTreeOptions() const;
};

/// Per-frame timings [ms] of the last process() call.
struct FrontendTiming {
  double harris_ms = 0.0;
  double matching_ms = 0.0;
  double total_ms = 0.0;
};

class Frontend {
 public:
  /// CHECK-fails on invalid options (validate them first). options() returns options.applied().
  explicit Frontend(const FrontendOptions& options);

  /// Corners and hypotheses of one rectified frame; out->t_ns = frame.t_ns. Errors for empty or
  /// differently sized images, or images too small for the detector and the matcher.
  Status process(const StereoFrame& frame, StereoHypotheses* out);

  /// The matcher (and row support, when on) at given left pixels of `frame`, as process() runs
  /// it on the detected corners but with the centred window only and without the right-to-left
  /// check (lr_consistent stays false): one SalientPoint per pixel whose window fits, in input
  /// order. Always the SAD matcher, whatever options().source says (pairing needs a right corner).
  /// The landmark database uses it to re-measure candidates whose corner was not detected
  /// (LandmarkOptions::probe_unseen). Errors as process(); out->t_ns = frame.t_ns.
  Status measureAt(const StereoFrame& frame,
                   const std::vector<Corner>& pixels,
                   StereoHypotheses* out) const;

  /// Left corners of the last frame (the salient points, before the matcher dropped any; for
  /// kMaxTree the sparse points' end points, no Harris corners).
  [[nodiscard]] const std::vector<Corner>& corners() const { return left_corners_; }
  [[nodiscard]] const FrontendTiming& timing() const { return timing_; }
  [[nodiscard]] const FrontendOptions& options() const { return options_; }

 private:
  FrontendOptions options_;
  HarrisDetector left_detector_;
  HarrisDetector right_detector_;
  std::vector<Corner> left_corners_;
  std::vector<Corner> right_corners_;
  MaxTreeMatcher maxtree_;
  MaxTreeResult maxtree_result_;
  FrontendTiming timing_;
};

}  // namespace twocam::frontend
