#include "pipeline/working_set.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_set>

#include "common/timer.h"
#include "pipeline/map_recorder.h"
#include "pipeline/pipeline.h"
#include "store/landmark_store.h"

namespace twocam::pipeline {

Status WorkingSetOptions::validate() const {
  if (!(radius_m >= 0.0 && radius_m <= 1e5)) {
    return Status::error("--working-set-radius: " + std::to_string(radius_m) +
                         " (must be in [0, 100000] m; 0: no radius)");
  }
  if (!(hysteresis_m >= 0.0 && hysteresis_m <= 1e3)) {
    return Status::error("--working-set-hysteresis: " + std::to_string(hysteresis_m) +
                         " (must be in [0, 1000] m)");
  }
  if (max_landmarks < 0 || max_landmarks > 100'000'000) {
    return Status::error("--working-set-max: " + std::to_string(max_landmarks) +
                         " (must be in [0, 100000000]; 0: no cap)");
  }
  return Status::ok();
}

WorkingSet::WorkingSet(const WorkingSetOptions& options)
    : options_(options), radius_m_(options.radius_m) {}

Status WorkingSet::update(const Eigen::Vector3d& robot_o,
                          int32_t frame,
                          MapRecorder* recorder,
                          Pipeline* pipeline,
                          std::vector<landmarks::Landmark>* paged_out) {
  if (!options_.enabled()) return Status::ok();
  if (!recorder->committed()) return Status::error("working set: the map has queued rows");
  const Timer timer;
  ++stats_.checks;
  const Eigen::Isometry3d& T_m_o = recorder->T_m_o();
  const Eigen::Vector3d robot_m = T_m_o * robot_o;
  // Distance on the floor, in the maximum norm: the set is a square round the robot, so that
  // what a check must look up in the store is the strip the square swept since the last one.
  const auto distance = [&](const Eigen::Vector3d& p_m) {
    return std::max(std::abs(p_m.x() - robot_m.x()), std::abs(p_m.y() - robot_m.y()));
  };

  // 1. Out: the map's landmarks in the tracker beyond the radius (plus hysteresis), then the
  // farthest above the cap. The map lookup (storeIdOf) is made only for a landmark that may
  // leave: the scan runs over the whole tracker at every check.
  struct Live {
    double distance_m;
    uint64_t tracker_id;
    uint64_t store_id;
  };
  const bool capped = options_.max_landmarks > 0;
  std::vector<Live> stay;  // with a cap only: the map's landmarks that may leave by it
  std::vector<uint64_t> out;
  std::unordered_set<uint64_t> held;  // store ids leaving the tracker at this check
  const landmarks::LandmarkDatabase& db = pipeline->database();
  for (const landmarks::Landmark& l : db.landmarks()) {
    if (l.state != landmarks::LandmarkState::kConfirmed) continue;
    // Predicted in view since the last check (seen or not): in view, stays.
    if (std::max(l.last_seen_frame, l.last_visible_frame) > last_check_frame_) continue;
    const double d = distance(T_m_o * l.p_w);
    const bool beyond = radius_m_ > 0.0 && d > radius_m_ + options_.hysteresis_m;
    if (!beyond && !capped) continue;
    const uint64_t sid = recorder->storeIdOf(l.id);
    if (sid == 0) continue;  // not in the map (yet): never leaves
    if (beyond) {
      out.push_back(l.id);
      held.insert(sid);
    } else {
      stay.push_back({d, l.id, sid});
    }
  }
  last_check_frame_ = frame;
  stats_.scan_ms += timer.elapsedMs();
  const Timer out_timer;
  // In the tracker and never leaving at this check: not in the map yet, or in view.
  const int unpaged = db.numConfirmed() - static_cast<int>(stay.size() + out.size());
  if (capped && static_cast<int64_t>(stay.size()) + unpaged > options_.max_landmarks) {
    const auto keep = static_cast<size_t>(std::max<int64_t>(
        0, static_cast<int64_t>(std::floor(kCapRefill * options_.max_landmarks)) - unpaged));
    std::sort(stay.begin(), stay.end(), [](const Live& a, const Live& b) {
      return a.distance_m < b.distance_m ||
             (a.distance_m == b.distance_m && a.tracker_id < b.tracker_id);
    });
    for (size_t i = keep; i < stay.size(); ++i) {
      out.push_back(stay[i].tracker_id);
      held.insert(stay[i].store_id);
    }
    // The set shrinks round the robot: what is kept is what lies within the new radius.
    radius_m_ = keep > 0 ? stay[keep - 1].distance_m : 0.0;
    stay.resize(std::min(keep, stay.size()));
  }
  if (!out.empty()) {
    if (paged_out != nullptr) {
      for (uint64_t id : out) paged_out->push_back(*db.find(id));
    }
    if (Status s = recorder->pageOut(db, out); !s) return s;
    const int left = pipeline->pageOutLandmarks(out);
    if (left != static_cast<int>(out.size())) {
      return Status::error("working set: " + std::to_string(left) + " of " +
                           std::to_string(out.size()) + " landmarks left the tracker");
    }
    stats_.paged_out += left;
  }
  stats_.out_ms += out_timer.elapsedMs();

  // 2. In: the store's landmarks within the radius that the tracker does not hold, nearest first,
  // up to the cap.
  if (radius_m_ > 0.0) {
    const int64_t room =
        options_.max_landmarks > 0
            ? options_.max_landmarks - static_cast<int64_t>(pipeline->database().numConfirmed())
            : std::numeric_limits<int64_t>::max();
    const Timer query_timer;
    std::vector<store::StoredLandmark> rows;
    if (room > 0) {
      // Every row in the square of the last complete check is held already (none of them left
      // at this one: what leaves lies beyond radius + hysteresis): only the newly swept strips
      // are read, or the whole square when there is no such check.
      const double r = radius_m_;
      const double big = 1e9;
      std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> boxes;
      const Eigen::Vector3d lo(robot_m.x() - r, robot_m.y() - r, -big);
      const Eigen::Vector3d hi(robot_m.x() + r, robot_m.y() + r, big);
      if (complete_ && complete_radius_m_ == r &&
          std::abs(complete_center_m_.x() - robot_m.x()) < 2.0 * r &&
          std::abs(complete_center_m_.y() - robot_m.y()) < 2.0 * r) {
        const Eigen::Vector2d& o = complete_center_m_;
        // x strip: the new square's columns outside the old one, over the new square's rows.
        if (robot_m.x() > o.x()) {
          boxes.emplace_back(Eigen::Vector3d(o.x() + r, lo.y(), -big), hi);
        } else if (robot_m.x() < o.x()) {
          boxes.emplace_back(lo, Eigen::Vector3d(o.x() - r, hi.y(), big));
        }
        // y strip: the rows outside the old square, over the columns both share.
        const double x0 = std::max(lo.x(), o.x() - r);
        const double x1 = std::min(hi.x(), o.x() + r);
        if (robot_m.y() > o.y()) {
          boxes.emplace_back(Eigen::Vector3d(x0, o.y() + r, -big),
                             Eigen::Vector3d(x1, hi.y(), big));
        } else if (robot_m.y() < o.y()) {
          boxes.emplace_back(Eigen::Vector3d(x0, lo.y(), -big),
                             Eigen::Vector3d(x1, o.y() - r, big));
        }
      } else {
        boxes.emplace_back(lo, hi);
      }
      // The index first (ids only), then the rows the tracker lacks: most of a strip is held.
      std::vector<uint64_t> ids;
      for (const auto& [bmin, bmax] : boxes) {
        std::vector<uint64_t> part;
        if (Status s = recorder->store().queryBoxIds(bmin, bmax, &part); !s)
          return Status::error("working set: " + s.message());
        ids.insert(ids.end(), part.begin(), part.end());
      }
      std::sort(ids.begin(), ids.end());
      ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
      stats_.ids_read += static_cast<int64_t>(ids.size());
      // Which of them the tracker holds (or lets go at this check): asked of the recorder per
      // id, so the cost follows the strips, not the tracker's size.
      if (!ids.empty()) {
        std::vector<uint64_t> lacking;
        for (uint64_t id : ids) {
          if (held.count(id) == 0 && !recorder->trackerHolds(id, pipeline->database()))
            lacking.push_back(id);
        }
        if (Status s = recorder->store().loadByIds(lacking, &rows); !s)
          return Status::error("working set: " + s.message());
        stats_.rows_read += static_cast<int64_t>(rows.size());
      }
    }
    stats_.query_ms += query_timer.elapsedMs();
    const Timer in_timer;
    std::vector<std::pair<double, size_t>> order;
    for (size_t i = 0; i < rows.size(); ++i) {
      const double d = distance(rows[i].p_m);
      if (d <= radius_m_ && held.count(rows[i].id) == 0) order.emplace_back(d, i);
    }
    const bool all_fit = static_cast<int64_t>(order.size()) <= room;
    // Complete: every row within the square is now held (none left out by the cap).
    complete_ = room > 0 && all_fit;
    complete_center_m_ = robot_m.head<2>();
    complete_radius_m_ = radius_m_;
    if (!all_fit) {
      std::sort(order.begin(), order.end());
      order.resize(static_cast<size_t>(room));
    }
    if (!order.empty()) {
      const Eigen::Isometry3d T_o_m = T_m_o.inverse();
      std::vector<Eigen::Vector3d> p_o;
      std::vector<store::StoredLandmark> in;
      p_o.reserve(order.size());
      in.reserve(order.size());
      for (const auto& [d, i] : order) {
        p_o.push_back(T_o_m * rows[i].p_m);
        in.push_back(std::move(rows[i]));
      }
      const std::vector<uint64_t> ids = pipeline->restoreLandmarks(p_o);
      if (ids.size() != in.size()) {
        return Status::error("working set: " + std::to_string(ids.size()) + " of " +
                             std::to_string(in.size()) + " landmarks joined the tracker");
      }
      stats_.paged_in += static_cast<int64_t>(ids.size());
      if (Status s = recorder->adoptPagedIn(ids, std::move(in)); !s) return s;
    }
    // Well under the cap (below kCapRefill^2 of it) with everything in reach taken: the set may
    // grow again, by the hysteresis per check, up to the configured radius (none: no bound).
    const double low = kCapRefill * kCapRefill * options_.max_landmarks;
    if (options_.max_landmarks > 0 && all_fit && pipeline->database().numConfirmed() < low &&
        (options_.radius_m <= 0.0 || radius_m_ < options_.radius_m)) {
      radius_m_ += options_.hysteresis_m;
      if (options_.radius_m > 0.0) radius_m_ = std::min(radius_m_, options_.radius_m);
    }
    stats_.in_ms += in_timer.elapsedMs();
  }
  stats_.max_confirmed = std::max(stats_.max_confirmed, pipeline->database().numConfirmed());
  stats_.radius_m = radius_m_;
  stats_.check_ms.push_back(static_cast<float>(timer.elapsedMs()));
  return Status::ok();
}

}  // namespace twocam::pipeline
