#include "frontend/frontend.h"

#include <chrono>

#include "frontend/corner_pairing.h"
#include "frontend/row_support.h"

namespace twocam::frontend {
namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Status parseHypothesisSource(const std::string& name, HypothesisSource* source) {
  if (name == "sad") {
    *source = HypothesisSource::kSad;
  } else if (name == "pairing") {
    *source = HypothesisSource::kCornerPairing;
  } else {
    return Status::error("unknown hypothesis source '" + name + "'; expected sad or pairing");
  }
  return Status::ok();
}

const char* hypothesisSourceName(HypothesisSource source) {
  return source == HypothesisSource::kSad ? "sad" : "pairing";
}

Status FrontendOptions::validate() const {
  if (Status s = checkSimd("frontend.simd", simd); !s) return s;
  // The components' messages start with the field name: "frontend.harris.border_px = ...".
  if (Status s = harris.validate(); !s) return Status::error("frontend.harris." + s.message());
  if (Status s = sad.validate(); !s) return Status::error("frontend.sad." + s.message());
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
  const auto t0 = std::chrono::steady_clock::now();
  if (Status s = left_detector_.detect(frame.left, &left_corners_); !s) return s;
  if (options_.source == HypothesisSource::kCornerPairing) {
    if (Status s = right_detector_.detect(frame.right, &right_corners_); !s) return s;
  }
  timing_.harris_ms = msSince(t0);
  const auto t1 = std::chrono::steady_clock::now();
  Status s =
      options_.source == HypothesisSource::kSad
          ? matchSalient(frame.left, frame.right, left_corners_, options_.sad, out)
          : pairCorners(frame.left, frame.right, left_corners_, right_corners_, options_.sad, out);
  if (!s) return s;
  if (options_.sad.row_support) {
    if (Status r = measureRowSupport(frame.left, frame.right, options_.sad, out); !r) return r;
  }
  out->t_ns = frame.t_ns;
  timing_.matching_ms = msSince(t1);
  timing_.total_ms = msSince(t0);
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
