#include "frontend/frontend.h"

#include "common/timer.h"
#include "frontend/corner_pairing.h"
#include "frontend/row_support.h"

namespace twocam::frontend {

Status parseHypothesisSource(const std::string& name, HypothesisSource* source) {
  for (HypothesisSource s : {HypothesisSource::kSad,
                             HypothesisSource::kCornerPairing,
                             HypothesisSource::kSupport,
                             HypothesisSource::kNcc,
                             HypothesisSource::kMaxTree}) {
    if (name == hypothesisSourceName(s)) {
      *source = s;
      return Status::ok();
    }
  }
  return Status::error("unknown hypothesis source '" + name +
                       "'; expected sad, pairing, support, ncc or maxtree");
}

const char* hypothesisSourceName(HypothesisSource source) {
  switch (source) {
    case HypothesisSource::kSad:
      return "sad";
    case HypothesisSource::kCornerPairing:
      return "pairing";
    case HypothesisSource::kSupport:
      return "support";
    case HypothesisSource::kNcc:
      return "ncc";
    case HypothesisSource::kMaxTree:
      return "maxtree";
  }
  return "?";
}

SupportValueOptions FrontendOptions::supportOptions() const {
  SupportValueOptions o;
  o.min_disparity_px = sad.min_disparity_px;
  o.max_disparity_px = sad.max_disparity_px;
  o.simd = simd;
  return o;
}

NccScaledOptions FrontendOptions::nccOptions() const {
  NccScaledOptions o;
  o.min_disparity_px = sad.min_disparity_px;
  o.max_disparity_px = sad.max_disparity_px;
  return o;
}

MaxTreeOptions FrontendOptions::maxTreeOptions() const {
  MaxTreeOptions o;
  o.max_disparity_px = sad.max_disparity_px;
  return o;
}

Status FrontendOptions::validate() const {
  if (Status s = checkSimd("frontend.simd", simd); !s) return s;
  // The components' messages start with the field name: "frontend.harris.border_px = ...".
  if (Status s = harris.validate(); !s) return Status::error("frontend.harris." + s.message());
  if (Status s = sad.validate(); !s) return Status::error("frontend.sad." + s.message());
  // The other sources run with the SAD range: say so when it does not suit them.
  const char* name = hypothesisSourceName(source);
  Status s = Status::ok();
  if (source == HypothesisSource::kSupport) s = supportOptions().validate();
  if (source == HypothesisSource::kNcc) s = nccOptions().validate();
  if (source == HypothesisSource::kMaxTree) s = maxTreeOptions().validate();
  if (!s) {
    return Status::error(std::string("frontend.source = ") + name +
                         " with frontend.sad's disparity range: " + s.message());
  }
  return Status::ok();
}

FrontendOptions FrontendOptions::applied() const {
  FrontendOptions out = *this;
  out.harris.simd = simd;
  out.sad.simd = simd;
  return out;
}

Frontend::Frontend(const FrontendOptions& options)
    : options_(options.applied()),
      left_detector_(options_.harris),
      right_detector_(options_.harris) {
  const Status s = options.validate();
  TWOCAM_CHECK(s.isOk()) << s.message();
}

Status Frontend::process(const StereoFrame& frame, StereoHypotheses* out) {
  TWOCAM_CHECK(out != nullptr);
  if (frame.left.empty() || frame.right.empty())
    return Status::error("stereo frame has an empty image");
  if (frame.left.width != frame.right.width || frame.left.height != frame.right.height) {
    return Status::error(
        "left and right images differ in size (" + std::to_string(frame.left.width) + "x" +
        std::to_string(frame.left.height) + " vs " + std::to_string(frame.right.width) + "x" +
        std::to_string(frame.right.height) + ")");
  }
  const Timer t0;
  const HypothesisSource source = options_.source;
  if (source != HypothesisSource::kMaxTree) {
    if (Status s = left_detector_.detect(frame.left, &left_corners_); !s) return s;
  }
  if (source == HypothesisSource::kCornerPairing) {
    if (Status s = right_detector_.detect(frame.right, &right_corners_); !s) return s;
  }
  timing_.harris_ms = t0.elapsedMs();
  const Timer t1;
  Status s = Status::ok();
  switch (source) {
    case HypothesisSource::kSad:
      s = matchSalient(frame.left, frame.right, left_corners_, options_.sad, out);
      break;
    case HypothesisSource::kCornerPairing:
      s = pairCorners(frame.left, frame.right, left_corners_, right_corners_, options_.sad, out);
      break;
    case HypothesisSource::kSupport:
      s = matchSupportValueSalient(
          frame.left, frame.right, left_corners_, options_.supportOptions(), out);
      break;
    case HypothesisSource::kNcc:
      s = matchNccSalient(frame.left, frame.right, left_corners_, options_.nccOptions(), out);
      break;
    case HypothesisSource::kMaxTree:
      // Its own salient points: Harris corners lie on texture, the trees' nodes on the uniform
      // runs between edges (docs/matchers/maxtree.md: recall@4 at corners 21-23 %).
      s = maxtree_.compute(frame.left, frame.right, options_.maxTreeOptions(), &maxtree_result_);
      if (s) {
        sparseHypotheses(maxtree_result_, out);
        left_corners_.clear();
        for (const SalientPoint& p : out->points) left_corners_.push_back(p.corner);
      }
      break;
  }
  if (!s) return s;
  if (options_.sad.row_support) {
    if (Status r = measureRowSupport(frame.left, frame.right, options_.sad, out); !r) return r;
  }
  out->t_ns = frame.t_ns;
  timing_.matching_ms = t1.elapsedMs();
  timing_.total_ms = t0.elapsedMs();
  return Status::ok();
}

Status Frontend::measureAt(const StereoFrame& frame,
                           const std::vector<Corner>& pixels,
                           StereoHypotheses* out) const {
  TWOCAM_CHECK(out != nullptr);
  // The right-to-left check is left out: its flag serves seeding, and re-measurement does not
  // seed. So are the shifted windows: a pixel placed by a prediction is not a corner on a
  // depth edge (those are not seeded), and windows off it add the neighbouring surface's
  // disparity as a second answer (measured: docs/landmarks.md, "Probing unseen candidates").
  SalientSadOptions sad = options_.sad;
  sad.lr_check = false;
  sad.shiftable_windows = false;
  if (Status s = matchSalient(frame.left, frame.right, pixels, sad, out); !s) return s;
  if (sad.row_support) {
    if (Status r = measureRowSupport(frame.left, frame.right, sad, out); !r) return r;
  }
  out->t_ns = frame.t_ns;
  return Status::ok();
}

}  // namespace twocam::frontend
