#include "pipeline/map_recorder.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "common/frames.h"
#include "landmarks/landmark_database.h"
#include "landmarks/landmark_model.h"
#include "pipeline/map_relocalizer.h"

namespace twocam::pipeline {

Status MapRecorderOptions::validate() const {
  if (frames_per_commit < 1 || frames_per_commit > 100000) {
    return Status::error("map.frames_per_commit: " + std::to_string(frames_per_commit) +
                         " (must be in [1, 100000])");
  }
  if (!(merge_radius_m >= 0.0 && merge_radius_m <= 1.0)) {
    return Status::error("map.merge_radius_m: " + std::to_string(merge_radius_m) +
                         " (must be in [0, 1])");
  }
  if (!(merge_map_sigma_m >= 0.0 && merge_map_sigma_m <= 1.0) || !(merge_gate_chi2 > 0.0)) {
    return Status::error("map.merge_map_sigma_m: " + std::to_string(merge_map_sigma_m) +
                         " (must be in [0, 1]) and map.merge_gate_chi2: " +
                         std::to_string(merge_gate_chi2) + " (must be > 0)");
  }
  if (!(merge_max_descriptor_distance >= 0.0 && merge_max_descriptor_distance <= 2.0)) {
    return Status::error("map.merge_max_descriptor_distance: " +
                         std::to_string(merge_max_descriptor_distance) + " (must be in [0, 2])");
  }
  if (Status s = descriptors.validate("map.descriptors."); !s) return s;
  return store.validate();
}

std::string rigText(const StereoRig& rig) {
  std::ostringstream o;
  o.precision(17);
  const Eigen::Vector3d t = rig.T_b_cl.translation();
  const Eigen::Quaterniond q(rig.T_b_cl.linear());
  o << "rig:\n  width_px: " << rig.width_px << "\n  height_px: " << rig.height_px
    << "\n  fx_px: " << rig.fx_px << "\n  fy_px: " << rig.fy_px << "\n  cx_px: " << rig.cx_px
    << "\n  cy_px: " << rig.cy_px << "\n  baseline_m: " << rig.baseline_m
    << "\n  T_b_cl: {x_m: " << t.x() << ", y_m: " << t.y() << ", z_m: " << t.z()
    << ", qw: " << q.w() << ", qx: " << q.x() << ", qy: " << q.y() << ", qz: " << q.z() << "}\n";
  return o.str();
}

bool stereoPointCovariance(const StereoRig& rig,
                           const Eigen::Isometry3d& T_w_cl,
                           double u_px,
                           double v_px,
                           double d_px,
                           double sigma_px,
                           double sigma_d_px,
                           Eigen::Matrix3d* cov_w) {
  if (!(d_px > 0.0)) return false;
  // p = b / d (u - cx, (v - cy) fx / fy, fx): the rectified triangulation.
  const double b = rig.baseline_m;
  const double x = (u_px - rig.cx_px) * b / d_px;
  const double y = (v_px - rig.cy_px) * rig.fx_px / rig.fy_px * b / d_px;
  const double z = rig.fx_px * b / d_px;
  Eigen::Matrix3d J;  // d p / d (u, v, d)
  J << b / d_px, 0.0, -x / d_px, 0.0, rig.fx_px / rig.fy_px * b / d_px, -y / d_px, 0.0, 0.0,
      -z / d_px;
  const Eigen::Vector3d var(sigma_px * sigma_px, sigma_px * sigma_px, sigma_d_px * sigma_d_px);
  const Eigen::Matrix3d cov_cl = J * var.asDiagonal() * J.transpose();
  const Eigen::Matrix3d R = T_w_cl.linear();
  *cov_w = R * cov_cl * R.transpose();
  return true;
}

Status MapRecorder::openStore(const std::string& path,
                              const MapRecorderOptions& options,
                              std::unique_ptr<store::LandmarkStore>* st,
                              store::StoreInfo* info) {
  if (Status s = options.validate(); !s) return s;
  if (Status s =
          store::LandmarkStore::open(path, store::OpenMode::kCreateOrExtend, st, options.store);
      !s)
    return s;
  return (*st)->info(info);
}

Status MapRecorder::open(const std::string& path,
                         const std::string& rig_text,
                         const std::string& config_text,
                         const std::string& log_path,
                         const MapRecorderOptions& options,
                         std::unique_ptr<MapRecorder>* out) {
  std::unique_ptr<store::LandmarkStore> st;
  store::StoreInfo info;
  if (Status s = openStore(path, options, &st, &info); !s) return s;
  if (info.landmark_count > 0) {
    return Status::error(path + ": the map already holds " + std::to_string(info.landmark_count) +
                         " landmarks; a run is recorded into it only once placed in it "
                         "(MapRecorder::extend)");
  }
  std::unique_ptr<MapRecorder> r(new MapRecorder());
  r->options_ = options;
  if (Status s = st->beginSession(rig_text, config_text, log_path, &r->session_); !s) return s;
  r->store_ = std::move(st);
  *out = std::move(r);
  return Status::ok();
}

Status MapRecorder::extend(const std::string& path,
                           const std::string& rig_text,
                           const std::string& config_text,
                           const std::string& log_path,
                           const Eigen::Isometry3d& T_m_o,
                           int32_t placed_frame,
                           const MapRecorderOptions& options,
                           std::unique_ptr<MapRecorder>* out) {
  std::unique_ptr<store::LandmarkStore> st;
  store::StoreInfo info;
  if (Status s = openStore(path, options, &st, &info); !s) return s;
  std::vector<store::StoredLandmark> stored;
  if (Status s = st->loadAll(&stored); !s) return s;
  std::unique_ptr<MapRecorder> r(new MapRecorder());
  r->options_ = options;
  r->extending_ = true;
  r->T_m_o_ = T_m_o;
  r->placed_frame_ = placed_frame;
  r->first_new_id_ = r->next_id_ = info.next_landmark_id;
  r->earlier_.reserve(stored.size());
  const uint8_t kind = storedDescriptorKind(options.descriptors.kind);
  for (store::StoredLandmark& l : stored) {
    const uint64_t id = l.id;
    if (options.merge_radius_m > 0.0 && l.descriptor_kind == kind)
      r->earlier_cells_[r->cellKey(l.p_m, 0, 0, 0)].push_back(id);
    r->earlier_.emplace(id, std::move(l));
  }
  if (Status s = st->beginSession(rig_text, config_text, log_path, &r->session_); !s) return s;
  r->store_ = std::move(st);
  *out = std::move(r);
  return Status::ok();
}

uint64_t MapRecorder::cellKey(const Eigen::Vector3d& p_m, int dx, int dy, int dz) const {
  // 21 bits per axis around the origin: +-1 M cells (+-50 km at 5 cm).
  const auto cell = [&](double x, int d) {
    const auto c = static_cast<int64_t>(std::floor(x / options_.merge_radius_m)) + d;
    return static_cast<uint64_t>(c + (int64_t{1} << 20)) & 0x1FFFFF;
  };
  return (cell(p_m.x(), dx) << 42) | (cell(p_m.y(), dy) << 21) | cell(p_m.z(), dz);
}

uint64_t MapRecorder::mergeTarget(const Eigen::Vector3d& p_m,
                                  const Eigen::Matrix3d& cov_m,
                                  const frontend::Descriptor& d) const {
  if (options_.merge_radius_m <= 0.0) return 0;
  const auto bytes = static_cast<size_t>(frontend::descriptorBytes(d.kind));
  uint64_t best = 0;
  double best_distance = options_.merge_max_descriptor_distance;
  frontend::Descriptor other;
  other.kind = d.kind;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        const auto cell = earlier_cells_.find(cellKey(p_m, dx, dy, dz));
        if (cell == earlier_cells_.end()) continue;
        for (uint64_t id : cell->second) {
          const store::StoredLandmark& l = earlier_.at(id);
          const Eigen::Vector3d e = l.p_m - p_m;
          if (e.norm() > options_.merge_radius_m || l.descriptor.size() != bytes) continue;
          const double s2 = options_.merge_map_sigma_m * options_.merge_map_sigma_m;
          const Eigen::Matrix3d S = l.cov_m + cov_m + 2.0 * s2 * Eigen::Matrix3d::Identity();
          if (!(e.dot(S.ldlt().solve(e)) <= options_.merge_gate_chi2)) continue;
          std::copy(l.descriptor.begin(), l.descriptor.end(), other.bytes.begin());
          const double dist = frontend::descriptorDistance(d, other);
          if (dist <= best_distance) {
            best_distance = dist;
            best = id;
          }
        }
      }
    }
  }
  return best;
}

Status MapRecorder::adoptRestored(const std::vector<uint64_t>& tracker_ids,
                                  const std::vector<uint64_t>& map_ids) {
  if (!extending_) return Status::error("adoptRestored: the recorder is not extending a map");
  if (tracker_ids.size() != map_ids.size()) {
    return Status::error("adoptRestored: " + std::to_string(tracker_ids.size()) +
                         " tracker ids for " + std::to_string(map_ids.size()) + " map landmarks");
  }
  for (size_t i = 0; i < map_ids.size(); ++i) {
    if (earlier_.count(map_ids[i]) == 0) {
      return Status::error("adoptRestored: landmark " + std::to_string(map_ids[i]) +
                           " is not in the map");
    }
    store_id_[tracker_ids[i]] = map_ids[i];
    restored_.insert(tracker_ids[i]);
    seen_as_[map_ids[i]].push_back(tracker_ids[i]);
  }
  return Status::ok();
}

Status MapRecorder::addFrame(const RunFrame& frame) {
  const landmarks::LandmarkDatabase& db = frame.pipeline.database();
  const landmarks::FrameReport& report = frame.pipeline.report();
  const int64_t t_ns = frame.log.stereo.t_ns;
  store::StoredKeyframe kf;
  kf.session = session_;
  kf.frame = frame.log.index;
  kf.t_ns = t_ns;
  kf.T_m_b = extending_ ? T_m_o_ * toIsometry(frame.output.pose) : toIsometry(frame.output.pose);
  batch_.keyframes.push_back(kf);
  ++keyframes_written_;

  // Each landmark once per batch, with its state after the batch's last frame that saw it.
  std::unordered_map<uint64_t, size_t> queued;
  for (size_t i = 0; i < batch_.upserts.size(); ++i) queued[batch_.upserts[i].id] = i;
  const double sigma_px = db.options().tracker.pixel_sigma_px;
  const double sigma_d_px = db.options().tracker.disparity_sigma_px;
  const auto update = [&](const landmarks::Landmark& l, uint64_t sid) {
    return updatedRow(db, l, sid, t_ns);
  };
  // A new landmark's position covariance in the map frame (zero when its anchor has none).
  const auto covariance = [&](const landmarks::Landmark& l) {
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    const Eigen::Isometry3d T_w_cl =
        landmarks::cameraPoseInWorld(l.anchor.odom_pose, db.rig().T_b_cl);
    if (!stereoPointCovariance(db.rig(),
                               T_w_cl,
                               l.anchor.u_px,
                               l.anchor.v_px,
                               l.anchor.d_px,
                               sigma_px,
                               sigma_d_px,
                               &cov))
      return Eigen::Matrix3d::Zero().eval();
    if (extending_) cov = T_m_o_.linear() * cov * T_m_o_.linear().transpose();
    return cov;
  };
  const auto record = [&](uint64_t id) {
    const landmarks::Landmark* l = db.find(id);
    if (l == nullptr || l->state != landmarks::LandmarkState::kConfirmed) return;
    uint64_t sid = id;
    std::optional<Eigen::Matrix3d> cov_m;
    if (const auto known = store_id_.find(id); known != store_id_.end()) {
      sid = known->second;
    } else if (extending_) {
      if (l->confirmed_frame <= placed_frame_)
        return;  // confirmed before the map's landmarks joined: may be one of theirs
      cov_m = covariance(*l);
      const auto d = descriptors_.find(id);
      const uint64_t target =
          d != descriptors_.end() ? mergeTarget(T_m_o_ * l->p_w, *cov_m, d->second) : 0;
      if (target != 0) {
        sid = target;  // an earlier session's landmark the tracker missed
        restored_.insert(id);
        seen_as_[sid].push_back(id);
        ++merged_;
      } else {
        sid = next_id_++;
        own_tracker_of_.emplace(sid, id);
      }
      store_id_.emplace(id, sid);
    }
    store::StoredLandmark s;
    if (restored_.count(id) > 0) {
      s = update(*l, sid);
    } else {
      s.id = sid;
      s.p_m = extending_ ? T_m_o_ * l->p_w : l->p_w;
      s.cov_m = cov_m ? *cov_m : covariance(*l);
      s.confidence = l->confidence;
      s.observations = l->n_obs;
      s.session = session_;
      s.first_seen_frame = l->first_frame;
      s.last_seen_frame = l->last_seen_frame;
      s.first_seen_t_ns = l->first_t_ns;
      s.last_seen_t_ns = t_ns;
      if (const auto d = descriptors_.find(id); d != descriptors_.end()) {
        s.descriptor_kind = storedDescriptorKind(d->second.kind);
        const auto n = static_cast<size_t>(frontend::descriptorBytes(d->second.kind));
        s.descriptor.assign(d->second.bytes.begin(), d->second.bytes.begin() + n);
      }
      if (in_store_.insert(id).second) ++own_written_;
    }
    const auto it = queued.find(sid);
    if (it != queued.end()) {
      s.first_seen_t_ns = batch_.upserts[it->second].first_seen_t_ns;
      batch_.upserts[it->second] = s;
    } else {
      queued[sid] = batch_.upserts.size();
      batch_.upserts.push_back(s);
    }
  };
  // Descriptors of the landmarks confirmed in this frame, at their projection in its left image.
  if (!report.confirmed_ids.empty()) {
    const Eigen::Isometry3d T_cl_w =
        landmarks::cameraPoseInWorld(frame.output.pose, db.rig().T_b_cl).inverse();
    std::vector<Corner> corners;
    std::vector<uint64_t> ids;
    for (uint64_t id : report.confirmed_ids) {
      const landmarks::Landmark* l = db.find(id);
      Eigen::Vector3d uvd;
      if (l == nullptr || !landmarks::projectStereo(db.rig(), T_cl_w * l->p_w, &uvd)) continue;
      Corner c;
      c.u_px = static_cast<int>(std::lround(uvd.x()));
      c.v_px = static_cast<int>(std::lround(uvd.y()));
      if (c.u_px < 0 || c.v_px < 0 || c.u_px >= db.rig().width_px || c.v_px >= db.rig().height_px)
        continue;
      corners.push_back(c);
      ids.push_back(id);
    }
    frontend::DescribedCorners described;
    if (Status s = frontend::describeCorners(
            frame.log.stereo.left, corners, options_.descriptors, &described);
        !s)
      return Status::error("frame " + std::to_string(frame.log.index) + ": " + s.message());
    for (size_t i = 0; i < described.kept.size(); ++i)
      descriptors_[ids[described.kept[i]]] = described.descriptors[i];
  }
  for (uint64_t id : report.confirmed_ids) record(id);
  for (uint64_t id : report.associated_ids) record(id);
  for (uint64_t id : report.removed_ids) {
    descriptors_.erase(id);
    // Only the session's own landmarks leave the map; a restored one stays (the run's tracker
    // dropping it says nothing against the earlier session's evidence).
    if (in_store_.erase(id) > 0) {
      --own_written_;
      const auto known = store_id_.find(id);
      batch_.removed.push_back(known != store_id_.end() ? known->second : id);
      if (known != store_id_.end()) own_tracker_of_.erase(known->second);
    } else if (restored_.erase(id) > 0) {
      // Its row keeps what was last written; the recorder forgets the tracker landmark, so that
      // a long run's bookkeeping holds only live landmarks.
      if (const auto known = store_id_.find(id); known != store_id_.end()) {
        const uint64_t sid = known->second;
        if (const auto seen = seen_as_.find(sid); seen != seen_as_.end()) {
          std::vector<uint64_t>& tids = seen->second;
          tids.erase(std::remove(tids.begin(), tids.end(), id), tids.end());
          if (tids.empty()) {
            seen_as_.erase(seen);
            paged_base_.erase(sid);
          }
        }
      }
    }
    store_id_.erase(id);
  }
  if (++frames_in_batch_ >= options_.frames_per_commit) return flush();
  return Status::ok();
}

const store::StoredLandmark& MapRecorder::baseRow(uint64_t sid) const {
  const auto paged = paged_base_.find(sid);
  return paged != paged_base_.end() ? paged->second : earlier_.at(sid);
}

store::StoredLandmark MapRecorder::updatedRow(const landmarks::LandmarkDatabase& db,
                                              const landmarks::Landmark& l,
                                              uint64_t sid,
                                              int64_t t_ns) {
  // The stored row with the observations of every live tracker landmark that is this one.
  store::StoredLandmark s = baseRow(sid);
  for (uint64_t tid : seen_as_[sid]) {
    if (const landmarks::Landmark* seen = db.find(tid)) s.observations += seen->n_obs;
  }
  s.confidence = l.confidence;
  s.last_seen_frame = l.last_seen_frame;
  s.last_seen_t_ns = t_ns;
  if (earlier_.count(sid) > 0) updated_.insert(sid);
  return s;
}

uint64_t MapRecorder::storeIdOf(uint64_t tracker_id) const {
  if (const auto known = store_id_.find(tracker_id); known != store_id_.end()) return known->second;
  return !extending_ && in_store_.count(tracker_id) > 0 ? tracker_id : 0;
}

Status MapRecorder::pageOut(const landmarks::LandmarkDatabase& db,
                            const std::vector<uint64_t>& tracker_ids) {
  if (!committed()) return Status::error("pageOut: recorded rows are still queued");
  for (uint64_t tid : tracker_ids) {
    const uint64_t sid = storeIdOf(tid);
    const landmarks::Landmark* l = db.find(tid);
    if (sid == 0 || l == nullptr) {
      return Status::error("pageOut: landmark " + std::to_string(tid) +
                           " is not a live landmark of the map");
    }
    if (restored_.erase(tid) > 0) {
      // Fold this tracker landmark's observations into the row's base (its row in the store
      // already holds them: it was written when they were made; the next update sets the time).
      store::StoredLandmark row = updatedRow(db, *l, sid, baseRow(sid).last_seen_t_ns);
      std::vector<uint64_t>& seen = seen_as_[sid];
      seen.erase(std::remove(seen.begin(), seen.end(), tid), seen.end());
      if (seen.empty()) {
        seen_as_.erase(sid);
        paged_base_.erase(sid);
        if (const auto e = earlier_.find(sid); e != earlier_.end()) e->second = std::move(row);
      } else {
        paged_base_[sid] = std::move(row);
      }
    }
    in_store_.erase(tid);
    if (const auto own = own_tracker_of_.find(sid);
        own != own_tracker_of_.end() && own->second == tid)
      own_tracker_of_.erase(own);
    store_id_.erase(tid);
    descriptors_.erase(tid);
  }
  return Status::ok();
}

bool MapRecorder::trackerHolds(uint64_t sid, const landmarks::LandmarkDatabase& db) const {
  const auto live = [&](uint64_t tid) {
    const landmarks::Landmark* l = db.find(tid);
    return l != nullptr && l->state == landmarks::LandmarkState::kConfirmed;
  };
  if (!extending_) {
    if (in_store_.count(sid) > 0 && live(sid)) return true;  // its own, under its tracker id
  } else if (const auto own = own_tracker_of_.find(sid);
             own != own_tracker_of_.end() && live(own->second)) {
    return true;
  }
  if (const auto seen = seen_as_.find(sid); seen != seen_as_.end()) {
    for (uint64_t tid : seen->second) {
      if (live(tid)) return true;
    }
  }
  return false;
}

Status MapRecorder::adoptPagedIn(const std::vector<uint64_t>& tracker_ids,
                                 std::vector<store::StoredLandmark> rows) {
  if (tracker_ids.size() != rows.size()) {
    return Status::error("adoptPagedIn: " + std::to_string(tracker_ids.size()) +
                         " tracker ids for " + std::to_string(rows.size()) + " map landmarks");
  }
  for (size_t i = 0; i < rows.size(); ++i) {
    const uint64_t sid = rows[i].id;
    store_id_[tracker_ids[i]] = sid;
    restored_.insert(tracker_ids[i]);
    seen_as_[sid].push_back(tracker_ids[i]);
    paged_base_[sid] = std::move(rows[i]);
  }
  return Status::ok();
}

Status MapRecorder::flush() {
  frames_in_batch_ = 0;
  if (batch_.upserts.empty() && batch_.removed.empty() && batch_.keyframes.empty())
    return Status::ok();
  // A landmark removed after it was queued in this batch: the removal wins (applied after the
  // upserts).
  const Status s = store_->writeBatch(batch_);
  if (s && !batch_.keyframes.empty()) {
    keyframes_committed_ += static_cast<int64_t>(batch_.keyframes.size());
    if (on_commit_) on_commit_({session_, batch_.keyframes.back().frame, keyframes_committed_});
  }
  batch_ = store::StoreBatch();
  return s;
}

Status MapRecorder::finish() { return flush(); }

}  // namespace twocam::pipeline
