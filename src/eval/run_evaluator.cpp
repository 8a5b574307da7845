#include "eval/run_evaluator.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "common/frames.h"
#include "common/stats.h"
#include "eval/disparity_io.h"
#include "eval/trajectory_metrics.h"
#include "landmarks/landmark_model.h"
#include "sim/slip_truth.h"
#include "sim/world_files.h"

namespace twocam::eval {
namespace {

using io::Json;
using io::numberOrNull;

/// METRICS.md trajectory.rpe_*: pairs of poses this far apart in true travel [m].
constexpr double kRpeSegmentM = 1.0;

/// A hypothesis in sample_frame/hypotheses.csv is true within this disparity error [px].
constexpr float kTruthTolPx = 1.0f;

/// The frame's ground truth when it can be evaluated: a depth image of the frame's size.
const GroundTruthFrame* usableGroundTruth(const io::LogFrame& f) {
  return f.ground_truth && f.ground_truth->depth_left.width == f.stereo.left.width &&
                 f.ground_truth->depth_left.height == f.stereo.left.height
             ? &*f.ground_truth
             : nullptr;
}

std::string voxelsCsv(const std::vector<mapping::Voxel>& voxels) {
  std::ostringstream csv;
  csv << std::setprecision(9) << "x,y,z,size,probability\n";
  for (const mapping::Voxel& v : voxels) {
    csv << v.centre_m.x() << ',' << v.centre_m.y() << ',' << v.centre_m.z() << ',' << v.size_m
        << ',' << v.probability << '\n';
  }
  return csv.str();
}

Json mapMetricsJson(const MapMetrics& m) {
  return {{"occupied", m.occupied},
          {"phantom", m.phantom},
          {"phantom_fraction", numberOrNull(m.phantom_fraction)},
          {"completeness", numberOrNull(m.completeness)},
          {"observable_voxels", m.observable},
          {"held_voxels", m.held}};
}

std::string timingsCsv(const std::vector<pipeline::FrameRecord>& records) {
  std::ostringstream csv;
  csv << std::setprecision(6)
      << "frame,frontend_ms,landmarks_ms,localization_ms,mapping_ms,total_ms,corners,hypotheses,"
         "candidates,confirmed,confirmations,reassociated,fused,reclaimed\n";
  for (const pipeline::FrameRecord& r : records) {
    csv << r.frame << ',' << r.times.frontend_ms << ',' << r.times.landmarks_ms << ','
        << r.times.localization_ms << ',' << r.times.mapping_ms << ',' << r.times.totalMs() << ','
        << r.corners << ',' << r.hypotheses << ',' << r.candidates << ',' << r.confirmed << ','
        << r.confirmations << ',' << r.reassociated << ',' << r.fused << ',' << r.reclaimed << '\n';
  }
  return csv.str();
}

/// Per-stage wall times of the processed frames [ms].
struct StageSamples {
  std::vector<double> frontend, landmarks, localization, mapping, total;
};

StageSamples stageSamples(const std::vector<pipeline::FrameRecord>& records) {
  StageSamples s;
  for (const pipeline::FrameRecord& r : records) {
    s.frontend.push_back(r.times.frontend_ms);
    s.landmarks.push_back(r.times.landmarks_ms);
    s.localization.push_back(r.times.localization_ms);
    s.mapping.push_back(r.times.mapping_ms);
    s.total.push_back(r.times.totalMs());
  }
  return s;
}

Json timingJson(const StageSamples& s, double wall_ms) {
  Json t = Json::object();
  const std::pair<const char*, const std::vector<double>*> stages[] = {
      {"frontend", &s.frontend},
      {"landmarks", &s.landmarks},
      {"localization", &s.localization},
      {"mapping", &s.mapping},
      {"total", &s.total}};
  for (const auto& [name, samples] : stages) {
    t[std::string(name) + "_median"] = numberOrNull(median(*samples));
    t[std::string(name) + "_p95"] = numberOrNull(quantile(*samples, 0.95));
  }
  return {{"timing_ms", t},
          {"frames", static_cast<int64_t>(s.total.size())},
          {"wall_s", wall_ms * 1e-3}};
}

/// Position distance at the last common pose [m] (NaN when a track is empty).
double finalError(const std::vector<io::TimedPose>& est, const std::vector<io::TimedPose>& gt) {
  const size_t n = std::min(est.size(), gt.size());
  if (n == 0) return std::nan("");
  return (est[n - 1].T_w_b.translation() - gt[n - 1].T_w_b.translation()).norm();
}

/// Slip detection against the world's slip events (docs/conventions.md, "Slips"): an event
/// belongs to the first frame at or after its time; it is detected when a flag lies within 2
/// frames; a flag with no event within 2 frames is a false alarm. Over the first `frames`
/// processed frames (those with ground truth).
Json slipsJson(const std::vector<sim::TrueSlip>& slips,
               const pipeline::RunSummary& s,
               size_t frames) {
  constexpr int kWithinFrames = 2;
  const int32_t last_frame = frames == 0 ? -1 : s.records[frames - 1].frame;
  std::vector<int32_t> event_frames;
  std::vector<uint8_t> significant;
  for (const auto& [f, e] : slips) {
    if (f < 0 || f > last_frame) continue;
    event_frames.push_back(f);
    significant.push_back(std::hypot(e.dx_m, e.dy_m) >= 0.03 ||
                          std::abs(e.dyaw_rad) >= M_PI / 180.0);
  }
  std::vector<int32_t> flags;
  for (int32_t f : s.slip_frames) {
    if (f <= last_frame) flags.push_back(f);
  }
  const auto near = [&](int32_t a, int32_t b) { return std::abs(a - b) <= kWithinFrames; };
  int detected = 0, detected_significant = 0, n_significant = 0;
  for (size_t i = 0; i < event_frames.size(); ++i) {
    bool hit = false;
    for (int32_t f : flags) hit = hit || near(f, event_frames[i]);
    detected += hit;
    n_significant += significant[i];
    detected_significant += hit && significant[i];
  }
  int false_alarms = 0;
  for (int32_t f : flags) {
    bool any = false;
    for (int32_t e : event_frames) any = any || near(f, e);
    false_alarms += !any;
  }
  Json flagged = Json::array();
  for (int32_t f : flags) flagged.push_back(f);
  return {{"true", static_cast<int64_t>(event_frames.size())},
          {"detected", detected},
          {"false_alarms", false_alarms},
          {"recall",
           n_significant == 0
               ? Json(nullptr)
               : numberOrNull(static_cast<double>(detected_significant) / n_significant)},
          {"significant", n_significant},
          {"false_alarms_per_1000_frames",
           numberOrNull(frames == 0 ? std::nan("") : 1000.0 * false_alarms / frames)},
          {"flagged_frames", flagged}};
}

/// Per processed frame: the pose source and its errors against the true track (empty cells
/// without ground truth for the frame).
std::string localizationCsv(const pipeline::RunSummary& s, const std::vector<io::TimedPose>& gt) {
  std::ostringstream csv;
  csv << std::setprecision(9)
      << "frame,t_s,visual,landmarks_used,slip_flagged,odometry_error_m,estimate_error_m,searched,"
         "search_accepted,search_reference,search_prediction_score,search_chance_score,"
         "search_best_score,search_best_reference,search_best_chance_score,search_rival_score,"
         "search_dx_m,search_dy_m,search_dyaw_deg,reanchor_"
         "reference,"
         "reanchored,landmarks_observed\n";
  size_t next_flag = 0;
  for (size_t i = 0; i < s.pose_track.size() && i < s.records.size(); ++i) {
    const int32_t frame = s.records[i].frame;
    bool flagged = false;
    while (next_flag < s.slip_frames.size() && s.slip_frames[next_flag] <= frame) {
      flagged = flagged || s.slip_frames[next_flag] == frame;
      ++next_flag;
    }
    csv << frame << ',' << static_cast<double>(s.pose_track[i].t_ns - s.first_t_ns) * 1e-9 << ','
        << static_cast<int>(s.visual[i]) << ',' << s.landmarks_used[i] << ',' << (flagged ? 1 : 0)
        << ',';
    if (i < gt.size()) {
      csv << (s.odom_track[i].T_w_b.translation() - gt[i].T_w_b.translation()).norm() << ','
          << (s.pose_track[i].T_w_b.translation() - gt[i].T_w_b.translation()).norm();
    } else {
      csv << ',';
    }
    const int search = i < s.search.size() ? s.search[i] : 0;
    csv << ',' << (search >= 1 ? 1 : 0) << ',' << (search == 2 ? 1 : 0);
    // The check's figures on every frame it ran; the searched pose's only where it searched.
    const pipeline::RunSummary::SearchFigures f =
        i < s.search_figures.size() ? s.search_figures[i] : pipeline::RunSummary::SearchFigures{};
    csv << ',' << f.reference << ',' << f.prediction_score << ',' << f.chance_score;
    if (search >= 1) {
      csv << ',' << f.best_score << ',' << f.best_reference << ',' << f.best_chance_score << ','
          << f.rival_score << ',' << f.correction.x_m << ',' << f.correction.y_m << ','
          << f.correction.yaw_rad * 180.0 / M_PI;
    } else {
      csv << ",,,,,,,";
    }
    csv << ',' << f.reanchor_reference << ',' << (f.reanchored ? 1 : 0) << ','
        << (i < s.landmarks_observed.size() ? s.landmarks_observed[i] : 0) << '\n';
  }
  return csv.str();
}

std::string duplicatesCsv(const std::vector<DuplicateRecord>& records) {
  std::ostringstream csv;
  csv << "frame,id,first_frame,older_id,older_first_frame,older_confirmed_frame,"
         "older_last_seen_frame\n";
  for (const DuplicateRecord& r : records) {
    csv << r.frame << ',' << r.id << ',' << r.first_frame << ',' << r.older_id << ','
        << r.older_first_frame << ',' << r.older_confirmed_frame << ',' << r.older_last_seen_frame
        << '\n';
  }
  return csv.str();
}

/// Revisits (issue 23: "in a static world already explored, the database stops growing"):
/// laps of the true track, a lap ending where the robot passes within kLapRadiusM of its start
/// after at least kMinLapPathM of travel (the frame nearest the start in that pass), and the
/// confirmations per lap. growth_after_first_lap = confirmations in later laps / confirmed
/// landmarks at the end of lap 1. Absent (with the reason) for a track of less than two laps.
Json revisitsJson(const std::vector<io::TimedPose>& gt, const pipeline::RunSummary& s) {
  constexpr double kLapRadiusM = 0.5;
  constexpr double kMinLapPathM = 2.0;
  std::vector<size_t> lap_ends;
  if (!gt.empty()) {
    const Eigen::Vector3d start = gt.front().T_w_b.translation();
    double path = 0.0, path_at_lap = 0.0;
    bool inside = false;
    size_t best = 0;
    double best_dist = 0.0;
    for (size_t i = 1; i < gt.size(); ++i) {
      path += (gt[i].T_w_b.translation() - gt[i - 1].T_w_b.translation()).norm();
      const double dist = (gt[i].T_w_b.translation() - start).norm();
      if (!inside && dist <= kLapRadiusM && path - path_at_lap >= kMinLapPathM) {
        inside = true;
        best = i;
        best_dist = dist;
      } else if (inside && dist <= kLapRadiusM) {
        if (dist < best_dist) {
          best = i;
          best_dist = dist;
        }
      } else if (inside) {
        inside = false;
        lap_ends.push_back(best);
        path_at_lap = path;
      }
    }
    if (inside) lap_ends.push_back(best);
  }
  if (lap_ends.size() < 2) {
    return {{"absent",
             "the true track does not come back to its start twice (fewer than two "
             "laps)"}};
  }
  Json ends = Json::array(), per_lap = Json::array();
  int64_t lap_count = 0, later = 0, later_fused = 0, later_reclaimed = 0;
  size_t lap = 0;
  int confirmed_after_first = 0;
  for (size_t i = 0; i < s.records.size() && i < gt.size(); ++i) {
    if (lap < lap_ends.size() && i > lap_ends[lap]) {
      per_lap.push_back(lap_count);
      if (lap == 0) confirmed_after_first = s.records[lap_ends[0]].confirmed;
      lap_count = 0;
      ++lap;
    }
    lap_count += s.records[i].confirmations;
    if (lap >= 1) {
      later += s.records[i].confirmations;
      later_fused += s.records[i].fused;
      later_reclaimed += s.records[i].reclaimed;
    }
  }
  per_lap.push_back(lap_count);
  for (size_t e : lap_ends) ends.push_back(s.records[e].frame);
  return {
      {"lap_end_frames", ends},
      {"confirmations_per_lap", per_lap},
      {"confirmed_after_first_lap", confirmed_after_first},
      {"confirmations_after_first_lap", later},
      {"fused_after_first_lap", later_fused},
      {"reclaimed_after_first_lap", later_reclaimed},
      {"growth_after_first_lap",
       confirmed_after_first > 0 ? numberOrNull(static_cast<double>(later) / confirmed_after_first)
                                 : Json(nullptr)}};
}

}  // namespace

RunEvaluator::RunEvaluator(const StereoRig& rig,
                           const pipeline::PipelineConfig& config,
                           Inputs inputs)
    : rig_(rig),
      config_(config),
      inputs_(std::move(inputs)),
      landmarks_(rig),
      pose_consistency_(rig) {
  if (inputs_.world) {
    oracle_map_ = std::make_unique<ReplacedMap>(config_.mapping);
    if (config_.localization.mode != localization::Mode::kOdometry) {
      odometry_map_ = std::make_unique<ReplacedMap>(config_.mapping);
    }
    observable_ = std::make_unique<ObservableVoxels>(
        rig_, config_.mapping.resolution_m, config_.mapping.max_range_m);
  }
}

RunEvaluator::~RunEvaluator() = default;

Status RunEvaluator::addFrame(const pipeline::RunFrame& f) {
  const GroundTruthFrame* gt = usableGroundTruth(f.log);
  if (f.odometry_mode) {
    const bool pose = f.log.ground_truth.has_value() && has_pose_gt_;
    if (pose) {
      if (Status s = checkGroundTruthPose(f.log.ground_truth->T_w_b); !s) {
        return Status::error("frame " + std::to_string(f.log.index) + ": " + s.message());
      }
      gt_track_.push_back({f.log.stereo.t_ns, f.log.ground_truth->T_w_b});
    } else {
      has_pose_gt_ = false;
    }
    if (gt && has_gt_ && pose) {
      const pipeline::Pipeline& pipe = f.pipeline;
      if (Status s = landmarks_.addFrame(pipe.hypotheses(),
                                         f.log.stereo.left,
                                         pipe.report(),
                                         pipe.database(),
                                         gt->depth_left,
                                         gt->T_w_b);
          !s) {
        return s;
      }
      if (oracle_map_) oracle_map_->addFrame(f, gt->T_w_b);
      if (odometry_map_ && f.log.odometry) {
        odometry_map_->addFrame(f, toIsometry(f.log.odometry->pose));
      }
      if (observable_) observable_->addFrame(gt->depth_left, gt->T_w_b);
    } else {
      has_gt_ = false;
      // True poses without true depth: judge the landmarks by the true motion instead.
      if (pose) {
        pose_consistency_.addFrame(
            f.pipeline.hypotheses(), f.pipeline.report(), f.log.ground_truth->T_w_b);
      }
    }
  }
  if (!sample_taken_ && f.log.index >= inputs_.sample_frame) takeSample(f, gt);
  return Status::ok();
}

void RunEvaluator::ReplacedMap::addFrame(const pipeline::RunFrame& f,
                                         const Eigen::Isometry3d& T_w_b_target) {
  const Eigen::Isometry3d T_target_used = T_w_b_target * toIsometry(f.output.pose).inverse();
  const auto index = static_cast<size_t>(f.log.index);
  if (index >= T_target_used_by_frame.size()) {
    T_target_used_by_frame.resize(index + 1, Eigen::Isometry3d::Identity());
  }
  T_target_used_by_frame[index] = T_target_used;
  const pipeline::FrameOutput& fo = f.output;
  const landmarks::LandmarkDatabase& db = f.pipeline.database();
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(fo.mapped_points_w.size());
  for (size_t i = 0; i < fo.mapped_points_w.size(); ++i) {
    const landmarks::Landmark* l = db.find(fo.mapped_ids[i]);
    const int32_t anchor = l != nullptr ? l->anchor.frame : -1;
    const bool known = anchor >= 0 && static_cast<size_t>(anchor) < T_target_used_by_frame.size();
    pts.push_back((known ? T_target_used_by_frame[static_cast<size_t>(anchor)] : T_target_used) *
                  fo.mapped_points_w[i]);
  }
  const Eigen::Vector3d o = T_target_used * fo.camera_origin_w;
  octomap::OcTreeKey key;
  if (mapper.tree().coordToKeyChecked(
          octomap::point3d(
              static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z())),
          key)) {
    mapper.insertFrame(o, pts);
  }
}

void RunEvaluator::takeSample(const pipeline::RunFrame& f, const GroundTruthFrame* gt) {
  sample_taken_ = true;
  sample_index_ = f.log.index;
  sample_left_ = f.log.stereo.left;
  sample_right_ = f.log.stereo.right;
  DisparityGroundTruth d_gt;
  const bool has_gt = gt != nullptr && disparityFromDepth(gt->depth_left, rig_, &d_gt).isOk();
  std::ostringstream csv;
  csv << std::setprecision(7)
      << "frame,corner,u,v,rank,d,cost,lr_consistent,landmark_state,truth\n";
  const pipeline::Pipeline& pipe = f.pipeline;
  const StereoHypotheses& hyps = pipe.hypotheses();
  const landmarks::LandmarkDatabase& db = pipe.database();
  const std::vector<uint64_t>& hypothesis_landmark = pipe.report().hypothesis_landmark_id;
  for (size_t j = 0; j < hyps.hypotheses.size(); ++j) {
    const DisparityHypothesis& h = hyps.hypotheses[j];
    const Corner& c = hyps.points[h.point_index].corner;
    int state = -1;
    if (f.odometry_mode && j < hypothesis_landmark.size()) {
      // A landmark removed later in the same update is no longer found: state -1.
      if (const landmarks::Landmark* l = db.find(hypothesis_landmark[j]); l != nullptr) {
        const auto s = l->state;
        state = s == landmarks::LandmarkState::kConfirmed   ? 1
                : s == landmarks::LandmarkState::kCandidate ? 0
                                                            : -1;
      }
    }
    int truth = -1;
    if (has_gt && d_gt.valid(c.u_px, c.v_px))
      truth = std::abs(h.d_px - d_gt.d_px(c.u_px, c.v_px)) <= kTruthTolPx ? 1 : 0;
    csv << f.log.index << ',' << h.point_index << ',' << c.u_px << ',' << c.v_px << ','
        << static_cast<int>(h.rank) << ',' << h.d_px << ',' << h.cost << ','
        << (h.lr_consistent ? 1 : 0) << ',' << state << ',' << truth << '\n';
  }
  sample_csv_ = csv.str();
}

void RunEvaluator::addPagedOut(std::vector<landmarks::Landmark> records) {
  if (paged_out_.empty()) {
    paged_out_ = std::move(records);
  } else {
    std::move(records.begin(), records.end(), std::back_inserter(paged_out_));
  }
}

std::string RunEvaluator::landmarksCsv(const std::vector<landmarks::Landmark>& slots,
                                       bool has_gt) const {
  // The leading columns, then verdict and errors with ground truth.
  std::ostringstream csv;
  csv << std::setprecision(9);
  csv << "id,x,y,z,confirmed,confidence,n_obs,first_frame,anchor_frame,anchor_u,anchor_v,anchor_d,"
         "confirmed_frame,"
         "verdict,error_m,anchor_d_gt,estimate_anchor_d,anchor_d_gt_near,anchor_d_gt_far,anchor_"
         "texture_grey\n";
  const auto optional_num = [&](double v) {
    if (std::isfinite(v)) csv << v;
  };
  const double nan = std::nan("");
  for (const landmarks::Landmark& l : slots) {  // every record, in storage order
    if (l.state == landmarks::LandmarkState::kFree) continue;
    csv << l.id << ',' << l.p_w.x() << ',' << l.p_w.y() << ',' << l.p_w.z() << ','
        << (l.state == landmarks::LandmarkState::kConfirmed ? 1 : 0) << ',' << l.confidence << ','
        << l.n_obs << ',' << l.first_frame << ',' << l.anchor.frame << ',' << l.anchor.u_px << ','
        << l.anchor.v_px << ',' << l.anchor.d_px << ',' << l.confirmed_frame << ','
        << (has_gt ? landmarks_.verdict(l) : -1) << ',';
    optional_num(has_gt ? landmarks_.errorM(l) : nan);
    csv << ',';
    optional_num(has_gt ? landmarks_.anchorDisparityGt(l) : nan);
    // The estimate's disparity seen from the anchor camera (equals anchor_d until refined).
    const Eigen::Vector3d p_ca =
        landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig_.T_b_cl).inverse() * l.p_w;
    csv << ',' << rig_.fx_px * rig_.baseline_m / p_ca.z() << ',';
    optional_num(has_gt ? landmarks_.anchorDisparityNear(l) : nan);
    csv << ',';
    optional_num(has_gt ? landmarks_.anchorDisparityFar(l) : nan);
    csv << ',';
    optional_num(has_gt ? landmarks_.anchorTextureGrey(l) : nan);
    csv << '\n';
  }
  return csv.str();
}

Status RunEvaluator::finish(const pipeline::Run& run, RunOutputs* out) const {
  const pipeline::RunSummary& s = run.summary();
  const pipeline::Pipeline& pipe = run.pipeline();
  const landmarks::LandmarkDatabase& db = pipe.database();
  // Every landmark the run made: the tracker's, and those its working set paged out.
  std::vector<landmarks::Landmark> with_paged_out;
  if (!paged_out_.empty()) {
    with_paged_out = db.landmarks();
    with_paged_out.insert(with_paged_out.end(), paged_out_.begin(), paged_out_.end());
  }
  const std::vector<landmarks::Landmark>& all_landmarks =
      paged_out_.empty() ? db.landmarks() : with_paged_out;
  const double resolution_m = config_.mapping.resolution_m;
  const bool has_gt = has_gt_ && s.odometry_mode && !gt_track_.empty();
  const bool has_pose_gt = has_pose_gt_ && s.odometry_mode && !gt_track_.empty();
  const bool localizing =
      s.odometry_mode && config_.localization.mode != localization::Mode::kOdometry;
  const std::string mode = localization::modeName(config_.localization.mode);
  *out = RunOutputs{};

  // ---- map: the map as built and, with a world and ground truth, its evaluations ------------
  const std::vector<mapping::Voxel> voxels = pipe.mapper().occupiedVoxels();
  std::optional<MapMetrics> map_built, map_oracle, map_odom;
  std::ostringstream eval_voxels_csv;
  if (inputs_.world && has_gt) {
    std::vector<double> dist;
    map_built = evaluateMap(voxels, *inputs_.world, resolution_m, &dist);
    measureCompleteness(voxels, *observable_, &*map_built);
    const std::vector<mapping::Voxel> oracle = oracle_map_->mapper.occupiedVoxels();
    map_oracle = evaluateMap(oracle, *inputs_.world, resolution_m);
    measureCompleteness(oracle, *observable_, &*map_oracle);
    if (odometry_map_) {
      const std::vector<mapping::Voxel> odom = odometry_map_->mapper.occupiedVoxels();
      map_odom = evaluateMap(odom, *inputs_.world, resolution_m);
      measureCompleteness(odom, *observable_, &*map_odom);
    } else {
      map_odom = map_built;  // odometry mode: the robot's map is the odometry-frame map
    }
    eval_voxels_csv << std::setprecision(9) << "x,y,z,size,distance_m,phantom\n";
    for (size_t i = 0; i < voxels.size(); ++i) {
      eval_voxels_csv << voxels[i].centre_m.x() << ',' << voxels[i].centre_m.y() << ','
                      << voxels[i].centre_m.z() << ',' << voxels[i].size_m << ',' << dist[i] << ','
                      << (dist[i] > 2.0 * resolution_m ? 1 : 0) << '\n';
    }
  }

  // ---- metrics.json --------------------------------------------------------------------------
  Json& m = out->metrics;
  m = Json::object();
  m["log"] = inputs_.log_path;
  m["policy"] = landmarks::policyName(config_.landmarks.policy);
  m["source"] = frontend::hypothesisSourceName(config_.frontend.source);
  m["seed"] = config_.seed;
  m["frames"] = s.frames;
  m["frames_processed"] = s.processed;
  m["frames_skipped"] = s.skipped;
  m["odometry"] = s.odometry_mode;
  m["ground_truth"] = has_gt;
  const auto per_frame = [&](int64_t n) {
    return numberOrNull(static_cast<double>(n) / s.processed);
  };
  m["detections"] = {{"corners_per_frame", per_frame(s.sum_corners)},
                     {"salient_points_per_frame", per_frame(s.sum_salient_points)},
                     {"hypotheses_per_frame", per_frame(s.sum_hypotheses)}};
  const mapping::MappingStats& ms = pipe.mapper().stats();
  m["mapping"] = {{"resolution_m", numberOrNull(resolution_m)},
                  {"occupied_voxels", voxels.size()},
                  {"points_inserted", ms.points_inserted},
                  {"points_beyond_range", ms.points_beyond_range},
                  {"frames_outside_map", s.frames_outside_map}};
  if (map_built) {
    Json octomap = mapMetricsJson(*map_built);
    octomap["resolution_m"] = numberOrNull(resolution_m);
    octomap["frame"] = localizing ? "estimated" : "odometry";
    octomap["oracle_poses"] = mapMetricsJson(*map_oracle);
    octomap["odometry_frame"] = mapMetricsJson(*map_odom);
    m["octomap"] = octomap;
  } else {
    // Said, not omitted: why there is no map evaluation.
    const std::string why = !s.odometry_mode ? "the log has no odometry, so there is no map"
                            : !has_gt ? "the log has no ground truth (true depth and pose) for "
                                        "every frame"
                                      : inputs_.world_absent;
    m["octomap"] = {{"absent", why}};
  }
  std::optional<LandmarkMetrics> lm;
  if (has_pose_gt) {
    double ate = 0.0;
    if (Status st = ateRmseM(s.odom_track, gt_track_, &ate); !st) return st;
    Json ate_json = {{"odometry", numberOrNull(ate)}};
    Json final_json = {{"odometry", numberOrNull(finalError(s.odom_track, gt_track_))}};
    if (localizing) {
      double ate_est = 0.0;
      if (Status st = ateRmseM(s.pose_track, gt_track_, &ate_est); !st) return st;
      ate_json[mode] = numberOrNull(ate_est);
      final_json[mode] = numberOrNull(finalError(s.pose_track, gt_track_));
    }
    Json rpe_t = Json::object(), rpe_r = Json::object(), rpe_n = Json::object();
    const auto add_rpe = [&](const std::string& track,
                             const std::vector<io::TimedPose>& poses) -> Status {
      RelativePoseError rpe;
      if (Status st = relativePoseError(poses, gt_track_, kRpeSegmentM, &rpe); !st) return st;
      rpe_t[track] = numberOrNull(rpe.trans_pct);
      rpe_r[track] = numberOrNull(rpe.rot_deg_per_m);
      rpe_n[track] = rpe.pairs;
      return Status::ok();
    };
    if (Status st = add_rpe("odometry", s.odom_track); !st) return st;
    if (localizing) {
      if (Status st = add_rpe(mode, s.pose_track); !st) return st;
    }
    m["trajectory"] = {{"ate_rmse_m", ate_json},
                       {"final_error_m", final_json},
                       {"rpe_trans_pct", rpe_t},
                       {"rpe_rot_deg_per_m", rpe_r},
                       {"rpe_pairs", rpe_n},
                       {"rpe_segment_m", kRpeSegmentM}};
    if (localizing && inputs_.true_slips) {
      m["slips"] = slipsJson(*inputs_.true_slips, s, gt_track_.size());
      m["slips"]["source"] = inputs_.true_slips_source;
    } else if (localizing) {
      m["slips"] = {{"absent", inputs_.true_slips_absent}};
    }
    m["revisits"] = revisitsJson(gt_track_, s);
  } else {
    const std::string why = !s.odometry_mode ? "the log has no odometry, so there is no trajectory"
                                             : "the log has no true pose for every frame";
    m["trajectory"] = {{"absent", why}};
    m["revisits"] = {{"absent", why}};
    if (localizing) m["slips"] = {{"absent", why}};
  }
  if (has_gt) {
    lm = landmarks_.finish(all_landmarks);
    const Json nested = toJson(*lm);
    for (auto it = nested.begin(); it != nested.end(); ++it) m[it.key()] = *it;
  } else {
    m["landmarks"] = {{"confirmed", db.numConfirmed()}, {"candidates", db.numCandidates()}};
    if (has_pose_gt) {
      const PoseConsistencyMetrics pc = pose_consistency_.finish(all_landmarks);
      m["landmarks"]["true_pose_consistency"] = numberOrNull(pc.fraction);
      m["landmarks"]["true_pose_consistent"] = pc.consistent;
      m["landmarks"]["true_pose_judged"] = pc.judged;
    }
  }
  m["ground_truth_poses"] = has_pose_gt;

  if (localizing) {
    int visual = 0;
    for (uint8_t v : s.visual) visual += v;
    int64_t searches = 0;
    int64_t searches_accepted = 0;
    for (uint8_t v : s.search) {
      searches += v >= 1 ? 1 : 0;
      searches_accepted += v == 2 ? 1 : 0;
    }
    std::vector<double> used;
    for (size_t i = 0; i < s.landmarks_used.size(); ++i) {
      if (s.visual[i]) used.push_back(s.landmarks_used[i]);
    }
    m["localization"] = {
        {"mode", mode},
        {"visual_fraction",
         numberOrNull(s.visual.empty() ? std::nan("")
                                       : static_cast<double>(visual) / s.visual.size())},
        {"landmarks_used_median", used.empty() ? Json(nullptr) : numberOrNull(median(used))},
        {"slips_flagged", static_cast<int64_t>(s.slip_frames.size())},
        {"searches", searches},
        {"searches_accepted", searches_accepted}};
  } else {
    m["localization"] = {{"mode", mode}};
  }

  // ---- timings -------------------------------------------------------------------------------
  const StageSamples stages = stageSamples(s.records);
  out->timing = timingJson(stages, s.wall_ms);

  // ---- files ---------------------------------------------------------------------------------
  auto& files = out->text_files;
  files.emplace_back("landmarks.csv", landmarksCsv(all_landmarks, has_gt));
  if (lm) files.emplace_back("duplicates.csv", duplicatesCsv(landmarks_.duplicateRecords()));
  files.emplace_back("timings.csv", timingsCsv(s.records));
  files.emplace_back("config_used.yaml",
                     "# Effective configuration of twocam run on " + inputs_.log_path + "\n" +
                         pipeline::toYaml(config_));
  if (s.odometry_mode) {
    files.emplace_back(
        "trajectory_odom.tum",
        io::toTum(s.odom_track, "wheel odometry: body pose in the odometry world frame"));
    files.emplace_back("map_voxels.csv", voxelsCsv(voxels));
    if (localizing) {
      files.emplace_back("trajectory_est.tum",
                         io::toTum(s.pose_track,
                                   "localization " + mode +
                                       ": body pose in the robot's world frame (planar part)"));
    }
  }
  if (s.odometry_mode) {
    files.emplace_back("localization.csv",
                       localizationCsv(s, has_pose_gt ? gt_track_ : std::vector<io::TimedPose>{}));
  }
  if (localizing && has_pose_gt && inputs_.true_slips) {
    files.emplace_back("slip_events.csv", sim::slipsCsv(*inputs_.true_slips));
  }
  if (has_pose_gt) {
    files.emplace_back("trajectory_gt.tum",
                       io::toTum(gt_track_, "ground truth: body pose in the world frame"));
  }
  if (map_built) files.emplace_back("map_eval_voxels.csv", eval_voxels_csv.str());
  out->map_evaluated = map_built.has_value();
  if (sample_taken_) {
    out->sample_taken = true;
    out->pngs.push_back({"sample_frame/left.png", sample_left_});
    out->pngs.push_back({"sample_frame/right.png", sample_right_});
    files.emplace_back("sample_frame/hypotheses.csv", sample_csv_);
  }

  // ---- summary lines -------------------------------------------------------------------------
  std::ostringstream sum;
  sum << std::setprecision(4);
  sum << "frames: " << s.processed << " processed, " << s.skipped << " skipped; per frame median "
      << median(stages.total) << " ms (frontend " << median(stages.frontend) << ", landmarks "
      << median(stages.landmarks) << ", mapping " << median(stages.mapping) << ")\n";
  if (lm) {
    sum << "landmarks: " << lm->confirmed << " confirmed, " << lm->correct_confirmed
        << " correct, precision " << lm->precision << " % (strict " << lm->precision_strict
        << " %; " << lm->precision_judged << " % of the " << lm->confirmed - lm->unjudged_confirmed
        << " with ground truth at the anchor), median error " << lm->median_error_m << " m\n";
  } else if (s.odometry_mode) {
    sum << "landmarks: " << db.numConfirmed() << " confirmed, " << db.numCandidates()
        << " candidates (no ground truth)\n";
  }
  if (map_built) {
    sum << "map (" << (localizing ? "estimated" : "odometry") << " poses): " << map_built->occupied
        << " occupied voxels at " << resolution_m << " m, " << map_built->phantom << " phantom ("
        << 100.0 * map_built->phantom_fraction << " %), completeness "
        << 100.0 * map_built->completeness << " %; with the true poses " << map_oracle->phantom
        << " phantom (" << 100.0 * map_oracle->phantom_fraction << " %)\n";
  } else if (s.odometry_mode) {
    sum << "map: " << voxels.size() << " occupied voxels at " << resolution_m << " m\n";
  }
  m["odometry_synthetic"] = inputs_.synthetic_odometry.has_value();
  if (inputs_.synthetic_odometry)
    sum << "odometry: SYNTHETIC (" << *inputs_.synthetic_odometry << ")\n";
  if (map_built) files.emplace_back("world_outline.csv", sim::worldOutlineCsv(*inputs_.world));
  out->summary = sum.str();
  return Status::ok();
}

}  // namespace twocam::eval
