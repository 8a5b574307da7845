#include "pipeline/map_relocalizer.h"

#include <algorithm>
#include <cstring>

#include "common/frames.h"
#include "common/timer.h"
#include "store/landmark_store.h"

namespace twocam::pipeline {

uint8_t storedDescriptorKind(frontend::DescriptorKind kind) {
  return static_cast<uint8_t>(1 + static_cast<int>(kind));
}

Status MapRelocalizerOptions::validate() const {
  if (every_frame_attempts < 0 || later_attempt_stride < 1) {
    return Status::error("relocalizer: every_frame_attempts " +
                         std::to_string(every_frame_attempts) + " (must be >= 0) and " +
                         "later_attempt_stride " + std::to_string(later_attempt_stride) +
                         " (must be >= 1)");
  }
  if (Status s = relocalization.validate(); !s) return s;
  return descriptors.validate();
}

Status MapRelocalizer::open(const std::string& path,
                            const StereoRig& rig,
                            const MapRelocalizerOptions& options,
                            std::unique_ptr<MapRelocalizer>* out) {
  if (Status s = options.validate(); !s) return s;
  std::unique_ptr<MapRelocalizer> r(new MapRelocalizer());  // starts since_open_
  std::unique_ptr<store::LandmarkStore> st;
  if (Status s = store::LandmarkStore::open(path, store::OpenMode::kReadOnly, &st); !s) return s;
  std::vector<store::StoredLandmark> stored;
  if (Status s = st->loadAll(&stored); !s) return s;
  r->rig_ = rig;
  r->options_ = options;
  const uint8_t kind = storedDescriptorKind(options.descriptors.kind);
  const auto bytes = static_cast<size_t>(frontend::descriptorBytes(options.descriptors.kind));
  for (const store::StoredLandmark& l : stored) {
    if (options.restore_without_descriptor) r->restore_.emplace_back(l.id, l.p_m);
    if (l.descriptor_kind != kind || l.descriptor.size() != bytes) continue;
    localization::MapLandmark m;
    m.id = l.id;
    m.p_m = l.p_m;
    m.descriptor.kind = options.descriptors.kind;
    std::memcpy(m.descriptor.bytes.data(), l.descriptor.data(), bytes);
    r->map_.push_back(m);
  }
  if (r->map_.empty()) {
    return Status::error(
        path + ": none of its " + std::to_string(stored.size()) + " landmarks has a " +
        frontend::descriptorKindName(options.descriptors.kind) + " descriptor to relocalise with");
  }
  r->report_.map_landmarks = static_cast<int64_t>(r->map_.size());
  r->report_.open_ms = r->since_open_.elapsedMs();
  if (!options.restore_without_descriptor) {
    r->restore_.reserve(r->map_.size());
    for (const localization::MapLandmark& m : r->map_) r->restore_.emplace_back(m.id, m.p_m);
  }
  *out = std::move(r);
  return Status::ok();
}

std::vector<Eigen::Vector3d> MapRelocalizer::takeLandmarksToRestore(
    std::vector<uint64_t>* map_ids) {
  std::vector<Eigen::Vector3d> p_o;
  if (map_ids != nullptr) map_ids->clear();
  if (!placed_ || restored_) return p_o;
  restored_ = true;
  const Eigen::Isometry3d T_o_m = T_m_o_.inverse();
  p_o.reserve(restore_.size());
  for (const auto& [id, p_m] : restore_) {
    p_o.push_back(T_o_m * p_m);
    if (map_ids != nullptr) map_ids->push_back(id);
  }
  report_.restored = static_cast<int64_t>(p_o.size());
  return p_o;
}

Status MapRelocalizer::addFrame(const RunFrame& frame) {
  const Eigen::Isometry3d T_o_b = toIsometry(frame.output.pose);
  if (placed_) {
    report_.map_track.push_back({frame.log.stereo.t_ns, T_m_o_ * T_o_b});
    return Status::ok();
  }
  const int seen = frames_seen_++;
  if (seen >= options_.every_frame_attempts &&
      (seen - options_.every_frame_attempts) % options_.later_attempt_stride != 0)
    return Status::ok();
  // The frame's stereo points: each corner's first (cheapest) hypothesis when left-right
  // consistent.
  const StereoHypotheses& hyps = frame.pipeline.hypotheses();
  std::vector<Corner> corners;
  std::vector<float> disparities;
  for (const SalientPoint& p : hyps.points) {
    if (p.num_hypotheses == 0) continue;
    const DisparityHypothesis& h = hyps.hypotheses[p.first_hypothesis];
    if (!h.lr_consistent || !(h.d_px > 0.0f)) continue;
    corners.push_back(p.corner);
    disparities.push_back(h.d_px);
  }
  frontend::DescribedCorners described;
  if (Status s = frontend::describeCorners(
          frame.log.stereo.left, corners, options_.descriptors, &described);
      !s)
    return Status::error("frame " + std::to_string(frame.log.index) + ": " + s.message());
  std::vector<localization::RelocalizationPoint> points;
  points.reserve(described.kept.size());
  for (size_t i = 0; i < described.kept.size(); ++i) {
    const uint32_t k = described.kept[i];
    localization::RelocalizationPoint rp;
    rp.u_px = corners[k].u_px;
    rp.v_px = corners[k].v_px;
    rp.d_px = disparities[k];
    rp.descriptor = described.descriptors[i];
    points.push_back(rp);
  }
  ++report_.attempts;
  localization::RelocalizationResult result;
  const Timer timer;
  if (Status s = localization::relocalize(rig_, points, map_, options_.relocalization, &result); !s)
    return Status::error("frame " + std::to_string(frame.log.index) + ": " + s.message());
  report_.attempt_ms.push_back(timer.elapsedMs());
  if (!result.found) {
    report_.last_reason = result.reason;
    return Status::ok();
  }
  placed_ = true;
  report_.placed_ms = since_open_.elapsedMs();
  report_.frame = frame.log.index;
  report_.T_m_b = result.T_m_b;
  report_.inliers = result.inliers;
  report_.verified = result.verified;
  report_.verified_fraction = result.verified_fraction;
  T_m_o_ = result.T_m_b * T_o_b.inverse();
  report_.map_track.push_back({frame.log.stereo.t_ns, result.T_m_b});
  return Status::ok();
}

}  // namespace twocam::pipeline
