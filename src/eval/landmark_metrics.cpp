#include "eval/landmark_metrics.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "common/stats.h"
#include "landmarks/landmark_model.h"

namespace twocam::eval {
namespace {

/// A hypothesis or landmark is true within this disparity error [px] (METRICS.md).
constexpr double kTruthTolPx = 1.0;
/// Confidence thresholds of the calibration table.
constexpr double kCalibrationThresholds[] = {0.0, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99};

double percent(int64_t num, int64_t den) {
  return den > 0 ? 100.0 * static_cast<double>(num) / static_cast<double>(den)
                 : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

int64_t countDistinctPoints(const std::vector<Eigen::Vector3f>& points, double radius_m) {
  // Greedy in the given order: a point within radius_m of a kept representative joins it. A hash
  // grid of cell radius_m finds the candidates in the 27 neighbouring cells.
  // Cell indices are clamped before the conversion (a float beyond int's range converts with
  // undefined behaviour): far points share the border cell and are still told apart by distance.
  constexpr double kMaxCell = 1 << 30;
  const auto index = [&](float x) {
    return static_cast<int>(
        std::clamp(std::floor(static_cast<double>(x) / radius_m), -kMaxCell, kMaxCell));
  };
  const auto cell = [&](const Eigen::Vector3f& p) {
    return Eigen::Vector3i(index(p.x()), index(p.y()), index(p.z()));
  };
  const auto key = [](const Eigen::Vector3i& c) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(c.x())) * 73856093u) ^
           (static_cast<uint64_t>(static_cast<uint32_t>(c.y())) * 19349663u) ^
           (static_cast<uint64_t>(static_cast<uint32_t>(c.z())) * 83492791u);
  };
  std::unordered_multimap<uint64_t, Eigen::Vector3f> reps;
  const double r2 = radius_m * radius_m;
  int64_t count = 0;
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;  // documented skip: no place, no point
    const Eigen::Vector3i c = cell(p);
    bool found = false;
    for (int dx = -1; dx <= 1 && !found; ++dx) {
      for (int dy = -1; dy <= 1 && !found; ++dy) {
        for (int dz = -1; dz <= 1 && !found; ++dz) {
          const auto range = reps.equal_range(key(c + Eigen::Vector3i(dx, dy, dz)));
          for (auto it = range.first; it != range.second && !found; ++it) {
            found = (it->second - p).squaredNorm() <= r2;
          }
        }
      }
    }
    if (!found) {
      reps.emplace(key(c), p);
      ++count;
    }
  }
  return count;
}

double patchStdDevGrey(const ImageU8& image, double u_px, double v_px, int radius) {
  const long u0 = std::lround(u_px), v0 = std::lround(v_px);
  if (!(u0 >= 0 && v0 >= 0 && u0 < image.width && v0 < image.height))
    return std::numeric_limits<double>::quiet_NaN();
  const int ua = static_cast<int>(std::max<long>(0, u0 - radius)),
            ub = static_cast<int>(std::min<long>(image.width - 1, u0 + radius));
  const int va = static_cast<int>(std::max<long>(0, v0 - radius)),
            vb = static_cast<int>(std::min<long>(image.height - 1, v0 + radius));
  double sum = 0.0, sum2 = 0.0;
  for (int v = va; v <= vb; ++v) {
    for (int u = ua; u <= ub; ++u) {
      const double g = image(u, v);
      sum += g;
      sum2 += g * g;
    }
  }
  const double n = static_cast<double>(ub - ua + 1) * static_cast<double>(vb - va + 1);
  const double mean = sum / n;
  return std::sqrt(std::max(0.0, sum2 / n - mean * mean));
}

Status LandmarkEvaluator::addFrame(const StereoHypotheses& hyps,
                                   const ImageU8& left,
                                   const landmarks::FrameReport& report,
                                   const landmarks::LandmarkDatabase& db,
                                   const ImageF32& gt_depth,
                                   const Eigen::Isometry3d& T_w_b_true) {
  return addFrame(
      hyps, left, report, [&db](uint64_t id) { return db.find(id); }, gt_depth, T_w_b_true);
}

Status LandmarkEvaluator::addFrame(const StereoHypotheses& hyps,
                                   const ImageU8& left,
                                   const landmarks::FrameReport& report,
                                   const std::function<const landmarks::Landmark*(uint64_t)>& find,
                                   const ImageF32& gt_depth,
                                   const Eigen::Isometry3d& T_w_b_true) {
  if (Status s = checkGroundTruthPose(T_w_b_true); !s) {
    return Status::error("frame " + std::to_string(report.frame) + ": " + s.message());
  }
  if (Status s = disparityFromDepth(gt_depth, rig_, &gt_); !s) return s;
  const auto gt_at = [&](int u, int v, float* d, float* z) {
    if (u < 0 || v < 0 || u >= gt_.d_px.width || v >= gt_.d_px.height || !gt_.valid(u, v))
      return false;
    *d = gt_.d_px(u, v);
    *z = gt_depth(u, v);
    return true;
  };
  if (Status s = tallySalient(hyps, gt_, nullptr, StereoEvalOptions{}, &frontend_); !s) return s;
  for (const SalientPoint& p : hyps.points) {
    float d_gt, z_gt;
    const bool judged = gt_at(p.corner.u_px, p.corner.v_px, &d_gt, &z_gt);
    hyp_total_ += p.num_hypotheses;
    if (!judged) continue;
    hyp_judged_ += p.num_hypotheses;
    for (uint32_t k = 0; k < p.num_hypotheses; ++k) {
      const DisparityHypothesis& h = hyps.hypotheses[p.first_hypothesis + k];
      hyp_true_ += std::abs(h.d_px - d_gt) <= kTruthTolPx ? 1 : 0;
    }
  }
  for (uint64_t id : report.removed_ids) {
    anchors_.erase(id);
    confirmed_true_w_.erase(id);
  }
  for (uint64_t id : report.created_ids) {
    const landmarks::Landmark* created = find(id);
    // Seeded and removed in the same frame (the candidate cap, enforced after seeding).
    if (created == nullptr && std::find(report.removed_ids.begin(), report.removed_ids.end(), id) !=
                                  report.removed_ids.end())
      continue;
    if (created == nullptr) {
      return Status::error("frame " + std::to_string(report.frame) + ": created landmark " +
                           std::to_string(id) + " is unknown");
    }
    const landmarks::Landmark& l = *created;
    AnchorTruth t;
    const int u0 = static_cast<int>(l.anchor.u_px), v0 = static_cast<int>(l.anchor.v_px);
    t.valid = gt_at(u0, v0, &t.d_gt, &t.z_gt);
    float z_min = std::numeric_limits<float>::infinity(), z_max = 0.0f;
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        const int uu = u0 + du, vv = v0 + dv;
        const float z = (uu >= 0 && vv >= 0 && uu < gt_depth.width && vv < gt_depth.height)
                            ? gt_depth(uu, vv)
                            : 0.0f;
        if (!(std::isfinite(z) && z > 0.0f)) {
          z_min = std::numeric_limits<float>::quiet_NaN();
          break;
        }
        z_min = std::min(z_min, z);
        z_max = std::max(z_max, z);
      }
      if (std::isnan(z_min)) break;
    }
    const double fx_b = rig_.fx_px * rig_.baseline_m;
    t.d_near = std::isnan(z_min) ? std::numeric_limits<float>::quiet_NaN()
                                 : static_cast<float>(fx_b / z_min);
    t.d_far = std::isnan(z_min) ? std::numeric_limits<float>::quiet_NaN()
                                : static_cast<float>(fx_b / z_max);
    if (t.valid) {
      const Eigen::Vector3d ray((l.anchor.u_px - rig_.cx_px) / rig_.fx_px,
                                (l.anchor.v_px - rig_.cy_px) / rig_.fy_px,
                                1.0);
      t.p_true_w = (T_w_b_true * rig_.T_b_cl * (ray * static_cast<double>(t.z_gt))).cast<float>();
    }
    t.texture_grey = static_cast<float>(
        patchStdDevGrey(left, l.anchor.u_px, l.anchor.v_px, kTexturePatchRadius));
    anchors_[l.id] = t;
  }
  tallyDuplicates(report, find, T_w_b_true);
  return Status::ok();
}

void LandmarkEvaluator::tallyDuplicates(
    const landmarks::FrameReport& report,
    const std::function<const landmarks::Landmark*(uint64_t id)>& find,
    const Eigen::Isometry3d& T_w_b_true) {
  std::vector<std::pair<uint64_t, Eigen::Vector3f>> fresh;
  for (uint64_t id : report.confirmed_ids) {
    const auto it = anchors_.find(id);
    if (it != anchors_.end() && it->second.valid) fresh.emplace_back(id, it->second.p_true_w);
  }
  if (fresh.empty()) return;
  const Eigen::Isometry3d T_cl_w = (T_w_b_true * rig_.T_b_cl).inverse();
  const auto project = [&](const Eigen::Vector3f& p_w, Eigen::Vector3d* uvd) {
    return landmarks::projectStereo(rig_, T_cl_w * p_w.cast<double>(), uvd) && uvd->x() >= -1.0 &&
           uvd->y() >= -1.0 && uvd->x() <= rig_.width_px + 1.0 && uvd->y() <= rig_.height_px + 1.0;
  };
  // The older confirmed landmarks' true points in this frame's true camera, binned by pixel.
  std::unordered_map<uint64_t, std::vector<std::pair<Eigen::Vector3d, uint64_t>>> bins;
  // Rows and columns offset into [0, 2^20) (projections lie within a pixel of the image), packed
  // unsigned: a shift of a negative value is undefined.
  const auto bin_key = [](int64_t u, int64_t v) {
    constexpr int64_t kOffset = int64_t{1} << 19;
    return (static_cast<uint64_t>(v + kOffset) << 20) |
           static_cast<uint64_t>((u + kOffset) & 0xFFFFF);
  };
  Eigen::Vector3d uvd;
  for (const auto& [id, p_w] : confirmed_true_w_) {
    if (project(p_w, &uvd)) {
      bins[bin_key(std::lround(uvd.x()), std::lround(uvd.y()))].emplace_back(uvd, id);
    }
  }
  for (const auto& [id, p_w] : fresh) {
    ++confirmations_judged_;
    if (!project(p_w, &uvd)) continue;
    // The older landmark whose true point is nearest (largest of the three offsets) within the
    // tolerance, if any.
    uint64_t older = 0;
    double older_offset = kTruthTolPx;
    const int64_t u0 = std::lround(uvd.x()), v0 = std::lround(uvd.y());
    for (int64_t dv = -2; dv <= 2; ++dv) {
      for (int64_t du = -2; du <= 2; ++du) {
        const auto b = bins.find(bin_key(u0 + du, v0 + dv));
        if (b == bins.end()) continue;
        for (const auto& [o, older_id] : b->second) {
          const double offset = (o - uvd).cwiseAbs().maxCoeff();
          if (offset <= older_offset && (older == 0 || offset < older_offset)) {
            older = older_id;
            older_offset = offset;
          }
        }
      }
    }
    if (older == 0) continue;
    ++duplicates_;
    DuplicateRecord r;
    r.frame = report.frame;
    r.id = id;
    r.older_id = older;
    if (const landmarks::Landmark* l = find(id)) r.first_frame = l->first_frame;
    if (const landmarks::Landmark* l = find(older)) {
      r.older_first_frame = l->first_frame;
      r.older_confirmed_frame = l->confirmed_frame;
      r.older_last_seen_frame = l->last_seen_frame;
    }
    duplicate_records_.push_back(r);
  }
  // Added after the check: landmarks confirmed in the same frame are not older than each other.
  for (const auto& [id, p_w] : fresh) confirmed_true_w_[id] = p_w;
}

int LandmarkEvaluator::verdict(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  if (it == anchors_.end() || !it->second.valid) return -1;
  const Eigen::Isometry3d T_cl_w =
      landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig_.T_b_cl).inverse();
  Eigen::Vector3d uvd;
  if (!landmarks::projectStereo(rig_, T_cl_w * l.p_w, &uvd)) return 0;
  const double reproj = std::hypot(uvd.x() - l.anchor.u_px, uvd.y() - l.anchor.v_px);
  return reproj <= kTruthTolPx && std::abs(uvd.z() - it->second.d_gt) <= kTruthTolPx ? 1 : 0;
}

double LandmarkEvaluator::anchorDisparityGt(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  if (it == anchors_.end() || !it->second.valid) return std::numeric_limits<double>::quiet_NaN();
  return it->second.d_gt;
}

double LandmarkEvaluator::anchorDisparityNear(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  return it == anchors_.end() ? std::numeric_limits<double>::quiet_NaN() : it->second.d_near;
}

double LandmarkEvaluator::anchorDisparityFar(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  return it == anchors_.end() ? std::numeric_limits<double>::quiet_NaN() : it->second.d_far;
}

double LandmarkEvaluator::anchorTextureGrey(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  return it == anchors_.end() ? std::numeric_limits<double>::quiet_NaN() : it->second.texture_grey;
}

double LandmarkEvaluator::errorM(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  if (it == anchors_.end() || !it->second.valid) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d p_cl =
      landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig_.T_b_cl).inverse() * l.p_w;
  const Eigen::Vector3d ray(
      (l.anchor.u_px - rig_.cx_px) / rig_.fx_px, (l.anchor.v_px - rig_.cy_px) / rig_.fy_px, 1.0);
  return (p_cl - ray * static_cast<double>(it->second.z_gt)).norm();
}

LandmarkEvaluator::EdgeSide LandmarkEvaluator::edgeSide(const landmarks::Landmark& l) const {
  const auto it = anchors_.find(l.id);
  if (it == anchors_.end()) return EdgeSide::kNeither;
  const Eigen::Isometry3d T_cl_w =
      landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig_.T_b_cl).inverse();
  Eigen::Vector3d uvd;
  const bool projects = landmarks::projectStereo(rig_, T_cl_w * l.p_w, &uvd) &&
                        std::hypot(uvd.x() - l.anchor.u_px, uvd.y() - l.anchor.v_px) <= kTruthTolPx;
  if (projects && std::abs(uvd.z() - it->second.d_near) <= kTruthTolPx) return EdgeSide::kNear;
  if (projects && std::abs(uvd.z() - it->second.d_far) <= kTruthTolPx) return EdgeSide::kFar;
  return EdgeSide::kNeither;
}

LandmarkMetrics LandmarkEvaluator::finish(const landmarks::LandmarkDatabase& db) const {
  return finish(db.landmarks());
}

LandmarkMetrics LandmarkEvaluator::finish(const std::vector<landmarks::Landmark>& slots) const {
  LandmarkMetrics m;
  m.hypotheses_total = hyp_total_;
  m.hypotheses_judged = hyp_judged_;
  m.hypotheses_true_fraction =
      hyp_judged_ > 0 ? static_cast<double>(hyp_true_) / static_cast<double>(hyp_judged_)
                      : std::numeric_limits<double>::quiet_NaN();
  m.frontend = frontend_.metrics();
  std::vector<double> errors, map_errors;
  std::vector<double> frames_to_confirm;
  std::vector<Eigen::Vector3f> correct_points;
  std::vector<CalibrationRow> rows;
  for (double t : kCalibrationThresholds) rows.push_back({t, 0, 0, 0.0});
  constexpr double kInf = std::numeric_limits<double>::infinity();
  m.by_texture = {{"plain", 0.0, kPlainTextureGrey},
                  {"faint", kPlainTextureGrey, kFaintTextureGrey},
                  {"textured", kFaintTextureGrey, kInf}};
  for (const landmarks::Landmark& l : slots) {
    if (l.state == landmarks::LandmarkState::kFree) continue;
    // Not created in this run (a saved map's, LandmarkDatabase::restoreConfirmed): no anchor
    // to judge it at; counted apart.
    if (anchors_.find(l.id) == anchors_.end()) {
      ++m.restored;
      continue;
    }
    const int v = verdict(l);
    if (v >= 0) {
      for (CalibrationRow& r : rows) {
        if (l.confidence >= r.threshold) {
          ++r.landmarks;
          r.correct += v;
        }
      }
    }
    if (l.state != landmarks::LandmarkState::kConfirmed) {
      ++m.candidates;
      continue;
    }
    ++m.confirmed;
    const double texture = anchorTextureGrey(l);
    for (TextureRow& r : m.by_texture) {
      if (texture >= r.min_grey && texture < r.max_grey) {
        ++r.confirmed;
        r.correct += v > 0 ? 1 : 0;
        r.unjudged += v < 0 ? 1 : 0;
      }
    }
    frames_to_confirm.push_back(static_cast<double>(l.confirmed_frame - l.first_frame));
    if (v < 0) {
      ++m.unjudged_confirmed;
      switch (edgeSide(l)) {
        case EdgeSide::kNear:
          ++m.unjudged_near_side;
          break;
        case EdgeSide::kFar:
          ++m.unjudged_far_side;
          break;
        case EdgeSide::kNeither:
          ++m.unjudged_neither;
          break;
      }
      continue;
    }
    m.correct_confirmed_strict += v;
    if (v == 1) correct_points.push_back(anchors_.at(l.id).p_true_w);
    errors.push_back(errorM(l));
    map_errors.push_back((l.p_w - anchors_.at(l.id).p_true_w.cast<double>()).norm());
  }
  m.correct_distinct_points = countDistinctPoints(correct_points, kSamePointM);
  // METRICS.md "Depth edges": an unjudged landmark on the near or the far surface is correct.
  m.correct_confirmed = m.correct_confirmed_strict + m.unjudged_near_side + m.unjudged_far_side;
  m.precision = percent(m.correct_confirmed, m.confirmed);
  m.precision_strict = percent(m.correct_confirmed_strict, m.confirmed);
  m.precision_judged = percent(m.correct_confirmed_strict, m.confirmed - m.unjudged_confirmed);
  m.median_error_m = quantile(errors, 0.5);
  m.p90_error_m = quantile(errors, 0.9);
  m.map_error_median_m = quantile(map_errors, 0.5);
  m.map_error_p90_m = quantile(map_errors, 0.9);
  m.confirmations_judged = confirmations_judged_;
  m.duplicates = duplicates_;
  m.duplicate_fraction = confirmations_judged_ > 0 ? static_cast<double>(duplicates_) /
                                                         static_cast<double>(confirmations_judged_)
                                                   : std::numeric_limits<double>::quiet_NaN();
  m.frames_to_confirm_median = quantile(frames_to_confirm, 0.5);
  for (CalibrationRow& r : rows) r.precision = percent(r.correct, r.landmarks);
  m.calibration = rows;
  return m;
}

io::Json toJson(const LandmarkMetrics& m) {
  using io::Json;
  using io::numberOrNull;
  Json j = Json::object();
  j["hypotheses"] = {{"total", m.hypotheses_total},
                     {"judged", m.hypotheses_judged},
                     {"true_fraction", numberOrNull(m.hypotheses_true_fraction)}};
  const StereoMetrics& f = m.frontend;
  j["frontend"] = {{"recall_at_k", numberOrNull(f.recall_at_k)},
                   {"recall_at_1", numberOrNull(f.recall_at_1)},
                   {"bad1", numberOrNull(f.bad1)},
                   {"bad2", numberOrNull(f.bad2)},
                   {"avgerr", numberOrNull(f.avgerr)},
                   {"density", numberOrNull(f.density)},
                   {"k", f.k},
                   {"mean_hypotheses", numberOrNull(f.mean_hypotheses)},
                   {"points", f.points},
                   {"evaluated", f.evaluated},
                   {"one_answer_fraction", numberOrNull(f.one_answer_fraction)},
                   {"one_answer_precision", numberOrNull(f.one_answer_precision)}};
  j["landmarks"] = {{"precision", numberOrNull(m.precision)},
                    {"precision_strict", numberOrNull(m.precision_strict)},
                    {"precision_judged", numberOrNull(m.precision_judged)},
                    {"correct_confirmed", m.correct_confirmed},
                    {"correct_confirmed_strict", m.correct_confirmed_strict},
                    {"correct_distinct_points", m.correct_distinct_points},
                    {"confirmed", m.confirmed},
                    {"unjudged_confirmed", m.unjudged_confirmed},
                    {"unjudged_near_side", m.unjudged_near_side},
                    {"unjudged_far_side", m.unjudged_far_side},
                    {"unjudged_neither", m.unjudged_neither},
                    {"candidates", m.candidates},
                    {"median_error_m", numberOrNull(m.median_error_m)},
                    {"p90_error_m", numberOrNull(m.p90_error_m)},
                    {"map_error_median_m", numberOrNull(m.map_error_median_m)},
                    {"map_error_p90_m", numberOrNull(m.map_error_p90_m)},
                    {"duplicate_fraction", numberOrNull(m.duplicate_fraction)},
                    {"restored", m.restored},
                    {"duplicates", m.duplicates},
                    {"confirmations_judged", m.confirmations_judged},
                    {"frames_to_confirm_median", numberOrNull(m.frames_to_confirm_median)}};
  Json calibration = Json::array();
  for (const CalibrationRow& r : m.calibration) {
    calibration.push_back({{"threshold", numberOrNull(r.threshold)},
                           {"landmarks", r.landmarks},
                           {"correct", r.correct},
                           {"precision", numberOrNull(r.precision)}});
  }
  j["calibration"] = calibration;
  Json by_texture = Json::array();
  for (const TextureRow& r : m.by_texture) {
    by_texture.push_back({{"class", r.name},
                          {"min_grey", numberOrNull(r.min_grey)},
                          {"max_grey", numberOrNull(r.max_grey)},
                          {"confirmed", r.confirmed},
                          {"correct", r.correct},
                          {"unjudged", r.unjudged}});
  }
  j["by_texture"] = by_texture;
  return j;
}

Status checkGroundTruthPose(const Eigen::Isometry3d& T_w_b_true) {
  const Eigen::Matrix4d& M = T_w_b_true.matrix();
  if (!M.allFinite()) return Status::error("the ground-truth pose is not finite (NaN or infinite)");
  if (M.topRightCorner<3, 1>().cwiseAbs().maxCoeff() > kMaxGroundTruthCoordM) {
    return Status::error("the ground-truth pose is more than " +
                         std::to_string(static_cast<int64_t>(kMaxGroundTruthCoordM)) +
                         " m from the origin");
  }
  return Status::ok();
}

}  // namespace twocam::eval
