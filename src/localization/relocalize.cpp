#include "localization/relocalize.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <random>
#include <unordered_map>

#include "common/options_check.h"

namespace twocam::localization {

namespace {

/// Candidates kept per frame point while matching: the best and enough runners-up to find the
/// best landmark of another place for the ratio test (a map holds a corner a few times).
constexpr size_t kCandidates = 6;
/// Levenberg-Marquardt refinement rounds: solve on the RANSAC inliers, re-select, solve again.
constexpr int kRefineRounds = 2;
/// Gauss-Newton iterations of the stereo refinement; it starts within the PnP's pixel error
/// and converges in 2-3.
constexpr int kStereoIterations = 5;

struct Candidate {
  double distance = std::numeric_limits<double>::infinity();
  uint32_t landmark = 0;
};

/// Keeps `best` (kCandidates entries, nearest first) up to date with landmark j at distance d;
/// on equal distances the earlier landmark stays first.
inline void keepNearest(double d, uint32_t j, Candidate* best) {
  if (d >= best[kCandidates - 1].distance) return;
  size_t k = kCandidates - 1;
  while (k > 0 && best[k - 1].distance > d) {
    best[k] = best[k - 1];
    --k;
  }
  best[k] = {d, j};
}

/// ORB descriptors (256 bits) of the map packed as four 64-bit words each, contiguous, so that
/// a scan over 100 000 landmarks reads 3.2 MB instead of walking MapLandmark records.
using PackedOrb = std::array<uint64_t, 4>;

PackedOrb packOrb(const frontend::Descriptor& d) {
  PackedOrb w{};
  std::memcpy(w.data(), d.bytes.data(), sizeof(w));
  return w;
}

/// The kCandidates map descriptors nearest to q in Hamming distance (bits / 256, the value of
/// frontend::descriptorDistance). The loop body is inlined into two builds: one for the CPU's
/// POPCNT instruction, chosen at run time, and the baseline one (the compiler's bit-counting
/// sequence), which give the same integers.
__attribute__((always_inline)) inline void nearestOrbBody(const PackedOrb& q,
                                                          const PackedOrb* map,
                                                          size_t n,
                                                          Candidate* best) {
  int worst_bits = 257;  // best[kCandidates - 1] in bits; 257 = none yet
  for (size_t j = 0; j < n; ++j) {
    const PackedOrb& m = map[j];
    const int bits = __builtin_popcountll(q[0] ^ m[0]) + __builtin_popcountll(q[1] ^ m[1]) +
                     __builtin_popcountll(q[2] ^ m[2]) + __builtin_popcountll(q[3] ^ m[3]);
    if (bits >= worst_bits) continue;
    keepNearest(bits / 256.0, static_cast<uint32_t>(j), best);
    const double worst = best[kCandidates - 1].distance;
    worst_bits = std::isfinite(worst) ? static_cast<int>(worst * 256.0 + 0.5) : 257;
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("popcnt"))) void nearestOrbPopcnt(const PackedOrb& q,
                                                        const PackedOrb* map,
                                                        size_t n,
                                                        Candidate* best) {
  nearestOrbBody(q, map, n, best);
}
#endif

void nearestOrbBaseline(const PackedOrb& q, const PackedOrb* map, size_t n, Candidate* best) {
  nearestOrbBody(q, map, n, best);
}

void nearestOrb(const PackedOrb& q, const std::vector<PackedOrb>& map, Candidate* best) {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool kHasPopcnt = __builtin_cpu_supports("popcnt") != 0;
  if (kHasPopcnt) {
    nearestOrbPopcnt(q, map.data(), map.size(), best);
    return;
  }
#endif
  nearestOrbBaseline(q, map.data(), map.size(), best);
}

double maxDistance(const RelocalizationOptions& o, frontend::DescriptorKind kind) {
  return kind == frontend::DescriptorKind::kOrb ? o.max_orb_distance : o.max_patch_distance;
}

/// Pixel grid over the frame points for the verification's neighbourhood look-ups.
class PointGrid {
 public:
  PointGrid(const std::vector<RelocalizationPoint>& points, double cell_px) : cell_(cell_px) {
    for (size_t i = 0; i < points.size(); ++i)
      cells_[key(points[i].u_px, points[i].v_px)].push_back(static_cast<uint32_t>(i));
  }
  template <typename F>
  void forNear(double u, double v, F&& f) const {
    const auto cu = static_cast<int64_t>(std::floor(u / cell_));
    const auto cv = static_cast<int64_t>(std::floor(v / cell_));
    for (int64_t dv = -1; dv <= 1; ++dv) {
      for (int64_t du = -1; du <= 1; ++du) {
        const auto it = cells_.find(pack(cu + du, cv + dv));
        if (it == cells_.end()) continue;
        for (uint32_t i : it->second) f(i);
      }
    }
  }

 private:
  static int64_t pack(int64_t cu, int64_t cv) { return cu * 1'000'003 + cv; }
  int64_t key(double u, double v) const {
    return pack(static_cast<int64_t>(std::floor(u / cell_)),
                static_cast<int64_t>(std::floor(v / cell_)));
  }
  double cell_;
  std::unordered_map<int64_t, std::vector<uint32_t>> cells_;
};

/// 1 / |v| of a patch descriptor's int8 vector (0 for a zero vector).
double inversePatchNorm(const frontend::Descriptor& d) {
  int32_t n = 0;
  for (int k = 0; k < frontend::kPatchGrid * frontend::kPatchGrid; ++k) {
    const int32_t x = static_cast<int8_t>(d.bytes[static_cast<size_t>(k)]);
    n += x * x;
  }
  return n > 0 ? 1.0 / std::sqrt(static_cast<double>(n)) : 0.0;
}

Eigen::Isometry3d fromRvecTvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R.at<double>(r, c);
    T.translation()(r) = tvec.at<double>(r);
  }
  return T;
}

/// Projection of p_cl to (u, v, d); false behind the camera.
bool predict(const StereoRig& rig, const Eigen::Vector3d& p_cl, Eigen::Vector3d* uvd) {
  if (p_cl.z() <= 0.0) return false;
  (*uvd) << rig.fx_px * p_cl.x() / p_cl.z() + rig.cx_px,
      rig.fy_px * p_cl.y() / p_cl.z() + rig.cy_px, rig.fx_px * rig.baseline_m / p_cl.z();
  return true;
}

}  // namespace

Status RelocalizationOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "max_orb_distance", max_orb_distance, 0.0, 1.0); !s) return s;
  if (Status s = checkRange(p + "max_patch_distance", max_patch_distance, 0.0, 2.0); !s) return s;
  if (Status s = checkRange(p + "ratio", ratio, 0.0, 1.0); !s) return s;
  if (Status s = checkRange(p + "same_place_m", same_place_m, 0.0, 10.0, "m"); !s) return s;
  if (Status s = checkRange(p + "reprojection_px", reprojection_px, 0.1, 100.0, "px"); !s) return s;
  if (Status s = checkRange(p + "inlier_disparity_px", inlier_disparity_px, 0.01, 100.0, "px"); !s)
    return s;
  if (Status s = checkRange(p + "ransac_iterations", ransac_iterations, 1, 1'000'000); !s) return s;
  if (Status s = checkRange(p + "ransac_confidence", ransac_confidence, 0.5, 1.0); !s) return s;
  if (Status s = checkRange(p + "min_inliers", min_inliers, 4, 100'000); !s) return s;
  if (Status s = checkRange(p + "point_tolerance_m", point_tolerance_m, 0.0, 10.0, "m"); !s)
    return s;
  if (Status s = checkRange(p + "point_disparity_px", point_disparity_px, 0.0, 100.0, "px"); !s)
    return s;
  if (Status s = checkRange(p + "min_point_fraction", min_point_fraction, 0.0, 1.0); !s) return s;
  if (Status s = checkRange(p + "verify_px", verify_px, 0.1, 100.0, "px"); !s) return s;
  if (Status s = checkRange(p + "verify_disparity_px", verify_disparity_px, 0.01, 100.0, "px"); !s)
    return s;
  if (Status s = checkRange(p + "min_depth_m", min_depth_m, 0.0, 1000.0, "m"); !s) return s;
  if (Status s = checkRange(p + "image_margin_px", image_margin_px, 0, 10'000, "px"); !s) return s;
  if (Status s = checkRange(p + "min_verified", min_verified, 0, 100'000); !s) return s;
  if (Status s = checkRange(p + "pose_sigma_px", pose_sigma_px, 0.01, 100.0, "px"); !s) return s;
  if (Status s = checkRange(p + "max_position_sigma_m", max_position_sigma_m, 0.0, 100.0, "m"); !s)
    return s;
  return checkRange(p + "min_verified_fraction", min_verified_fraction, 0.0, 1.0);
}

Status relocalize(const StereoRig& rig,
                  const std::vector<RelocalizationPoint>& frame,
                  const std::vector<MapLandmark>& map,
                  const RelocalizationOptions& options,
                  RelocalizationResult* result) {
  if (Status s = options.validate(); !s) return s;
  *result = RelocalizationResult();
  if (frame.empty() || map.empty()) {
    result->reason = frame.empty() ? "no frame points" : "empty map";
    return Status::ok();
  }
  const frontend::DescriptorKind kind = frame.front().descriptor.kind;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (frame[i].descriptor.kind != kind) {
      return Status::error("relocalize: frame point " + std::to_string(i) + " has a " +
                           frontend::descriptorKindName(frame[i].descriptor.kind) +
                           " descriptor, point 0 a " + frontend::descriptorKindName(kind));
    }
    if (!(frame[i].d_px > 0.0) || !std::isfinite(frame[i].d_px)) {
      return Status::error("relocalize: frame point " + std::to_string(i) + " has disparity " +
                           std::to_string(frame[i].d_px) + "; must be > 0");
    }
  }
  for (size_t j = 0; j < map.size(); ++j) {
    if (map[j].descriptor.kind != kind) {
      return Status::error("relocalize: map landmark " + std::to_string(map[j].id) + " has a " +
                           frontend::descriptorKindName(map[j].descriptor.kind) +
                           " descriptor, the frame " + frontend::descriptorKindName(kind));
    }
  }
  const double max_distance = maxDistance(options, kind);
  const double same_place_sq = options.same_place_m * options.same_place_m;

  // 1. Matching with the ratio test against the best landmark of another place. The patch's
  // 1 - NCC uses norms computed once per descriptor (same value as descriptorDistance).
  std::vector<double> inv_norm;
  std::vector<PackedOrb> packed;
  if (kind == frontend::DescriptorKind::kPatch) {
    inv_norm.reserve(map.size());
    for (const MapLandmark& l : map) inv_norm.push_back(inversePatchNorm(l.descriptor));
  } else {
    packed.reserve(map.size());
    for (const MapLandmark& l : map) packed.push_back(packOrb(l.descriptor));
  }
  std::vector<Candidate> best(kCandidates);
  for (size_t i = 0; i < frame.size(); ++i) {
    std::fill(best.begin(), best.end(), Candidate{});
    const frontend::Descriptor& fd = frame[i].descriptor;
    if (kind == frontend::DescriptorKind::kOrb) {
      nearestOrb(packOrb(fd), packed, best.data());
    } else {
      const double inv_norm_f = inversePatchNorm(fd);
      std::array<int8_t, frontend::kMaxDescriptorBytes> fq{};
      for (size_t k = 0; k < fq.size(); ++k) fq[k] = static_cast<int8_t>(fd.bytes[k]);
      for (size_t j = 0; j < map.size(); ++j) {
        const uint8_t* mb = map[j].descriptor.bytes.data();
        int32_t dot = 0;
        for (int k = 0; k < frontend::kPatchGrid * frontend::kPatchGrid; ++k)
          dot += static_cast<int32_t>(fq[static_cast<size_t>(k)]) * static_cast<int8_t>(mb[k]);
        const double d =
            inv_norm_f > 0.0 && inv_norm[j] > 0.0 ? 1.0 - dot * inv_norm_f * inv_norm[j] : 1.0;
        keepNearest(d, static_cast<uint32_t>(j), best.data());
      }
    }
    if (!(best[0].distance <= max_distance)) continue;
    double second = std::numeric_limits<double>::infinity();
    for (size_t k = 1; k < kCandidates; ++k) {
      if (!std::isfinite(best[k].distance)) break;
      if ((map[best[k].landmark].p_m - map[best[0].landmark].p_m).squaredNorm() > same_place_sq) {
        second = best[k].distance;
        break;
      }
    }
    if (best[0].distance < options.ratio * second || !std::isfinite(second)) {
      result->matches.push_back({static_cast<uint32_t>(i), best[0].landmark, best[0].distance});
    }
  }
  if (static_cast<int>(result->matches.size()) < options.min_inliers) {
    result->reason = "too few descriptor matches (" + std::to_string(result->matches.size()) + ")";
    return Status::ok();
  }

  // 2. PnP RANSAC. The seed permutes the correspondences (OpenCV 4.6's RANSAC draws from its
  // own fixed-seed generator) and seeds OpenCV's RNG, restored afterwards.
  std::vector<size_t> order(result->matches.size());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937_64 rng(options.seed);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (size_t k : order) {
    const RelocalizationMatch& m = result->matches[k];
    const Eigen::Vector3d& p = map[m.landmark].p_m;
    object.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(frame[m.point].u_px, frame[m.point].v_px);
  }
  const cv::Matx33d K(rig.fx_px, 0.0, rig.cx_px, 0.0, rig.fy_px, rig.cy_px, 0.0, 0.0, 1.0);
  cv::Mat rvec, tvec;
  std::vector<int> ransac_inliers;
  const uint64 saved_state = cv::theRNG().state;
  cv::theRNG().state = options.seed;
  bool ok = false;
  try {
    ok = cv::solvePnPRansac(object,
                            image,
                            K,
                            cv::noArray(),
                            rvec,
                            tvec,
                            false,
                            options.ransac_iterations,
                            static_cast<float>(options.reprojection_px),
                            options.ransac_confidence,
                            ransac_inliers,
                            cv::SOLVEPNP_AP3P);
  } catch (const cv::Exception&) {
    ok = false;
  }
  cv::theRNG().state = saved_state;
  if (!ok || static_cast<int>(ransac_inliers.size()) < options.min_inliers) {
    result->inliers = static_cast<int>(ransac_inliers.size());
    result->reason = "PnP RANSAC found " + std::to_string(ransac_inliers.size()) + " inliers";
    return Status::ok();
  }
  rvec.convertTo(rvec, CV_64F);
  tvec.convertTo(tvec, CV_64F);

  // Refinement: Levenberg-Marquardt on the inliers, then the inliers re-selected with the
  // refined pose in (u, v) and disparity.
  std::vector<int> inl = ransac_inliers;
  Eigen::Isometry3d T_cl_m = fromRvecTvec(rvec, tvec);
  for (int round = 0; round < kRefineRounds; ++round) {
    std::vector<cv::Point3d> o;
    std::vector<cv::Point2d> im;
    for (int k : inl) {
      o.push_back(object[static_cast<size_t>(k)]);
      im.push_back(image[static_cast<size_t>(k)]);
    }
    if (o.size() >= 4) cv::solvePnPRefineLM(o, im, K, cv::noArray(), rvec, tvec);
    T_cl_m = fromRvecTvec(rvec, tvec);
    inl.clear();
    for (size_t k = 0; k < order.size(); ++k) {
      const RelocalizationMatch& m = result->matches[order[k]];
      Eigen::Vector3d uvd;
      if (!predict(rig, T_cl_m * map[m.landmark].p_m, &uvd)) continue;
      const RelocalizationPoint& f = frame[m.point];
      if (std::hypot(uvd.x() - f.u_px, uvd.y() - f.v_px) <= options.reprojection_px &&
          std::abs(uvd.z() - f.d_px) <= options.inlier_disparity_px)
        inl.push_back(static_cast<int>(k));
    }
  }
  // Stereo refinement: Gauss-Newton on the inliers' (u, v, d) residuals, which PnP's (u, v)
  // leave out (the disparity is what fixes the range along a far view), then the covariance of
  // the camera position from the same Jacobian with pose_sigma_px per coordinate.
  {
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> obs;  // (p_m, observed u v d)
    for (int k : inl) {
      const RelocalizationMatch& m = result->matches[order[static_cast<size_t>(k)]];
      const RelocalizationPoint& f = frame[m.point];
      obs.emplace_back(map[m.landmark].p_m, Eigen::Vector3d(f.u_px, f.v_px, f.d_px));
    }
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    for (int it = 0; it <= kStereoIterations && obs.size() >= 3; ++it) {
      H.setZero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      for (const auto& [p_m, z] : obs) {
        const Eigen::Vector3d p = T_cl_m * p_m;
        if (p.z() <= 0.0) continue;
        Eigen::Vector3d uvd;
        predict(rig, p, &uvd);
        Eigen::Matrix3d d_uvd_d_p;
        const double iz = 1.0 / p.z(), iz2 = iz * iz;
        d_uvd_d_p << rig.fx_px * iz, 0.0, -rig.fx_px * p.x() * iz2, 0.0, rig.fy_px * iz,
            -rig.fy_px * p.y() * iz2, 0.0, 0.0, -rig.fx_px * rig.baseline_m * iz2;
        // Left perturbation T <- exp(delta) T, delta = (rotation w, translation t):
        // dp = -[p]x w + t.
        Eigen::Matrix<double, 3, 6> d_p_d_delta;
        d_p_d_delta.leftCols<3>() << 0.0, p.z(), -p.y(), -p.z(), 0.0, p.x(), p.y(), -p.x(), 0.0;
        d_p_d_delta.rightCols<3>().setIdentity();
        const Eigen::Matrix<double, 3, 6> J = d_uvd_d_p * d_p_d_delta;
        const Eigen::Vector3d r = uvd - z;
        H += J.transpose() * J;
        g += J.transpose() * r;
      }
      if (it == kStereoIterations) break;  // H at the solution, for the covariance
      const Eigen::Matrix<double, 6, 1> delta = H.ldlt().solve(-g);
      if (!delta.allFinite()) break;
      Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
      const double angle = delta.head<3>().norm();
      if (angle > 0.0)
        step.linear() = Eigen::AngleAxisd(angle, delta.head<3>() / angle).toRotationMatrix();
      step.translation() = delta.tail<3>();
      T_cl_m = step * T_cl_m;
    }
    // Camera centre c_m = -R^T t moves by -R^T dt under the left perturbation.
    const Eigen::Matrix<double, 6, 6> cov = options.pose_sigma_px * options.pose_sigma_px *
                                            H.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
    const Eigen::Matrix3d cov_t = cov.bottomRightCorner<3, 3>();
    const double max_var =
        cov_t.allFinite()
            ? Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov_t).eigenvalues().maxCoeff()
            : std::numeric_limits<double>::infinity();
    result->position_sigma_m = std::sqrt(std::max(0.0, max_var));
    if (!std::isfinite(result->position_sigma_m) || obs.size() < 3)
      result->position_sigma_m = std::numeric_limits<double>::infinity();
  }
  result->pnp_solved = true;
  result->T_m_cl = T_cl_m.inverse();
  result->T_m_b = result->T_m_cl * rig.T_b_cl.inverse();
  for (int k : inl) result->matches[order[static_cast<size_t>(k)]].inlier = true;
  result->inliers = static_cast<int>(inl.size());

  // 3. 3-D check of the inliers.
  const double fb = rig.fx_px * rig.baseline_m;
  std::vector<uint8_t> used(frame.size(), 0);  // frame points that are inliers
  std::vector<uint8_t> landmark_used(map.size(), 0);
  for (const RelocalizationMatch& m : result->matches) {
    if (!m.inlier) continue;
    used[m.point] = 1;
    landmark_used[m.landmark] = 1;
    const RelocalizationPoint& f = frame[m.point];
    const std::optional<Eigen::Vector3d> p_cl =
        triangulateRectified(rig, Eigen::Vector2d(f.u_px, f.v_px), f.d_px);
    if (!p_cl) continue;
    const double z = p_cl->z();
    const double tol = options.point_tolerance_m + z * z / fb * options.point_disparity_px;
    if ((*p_cl - T_cl_m * map[m.landmark].p_m).norm() <= tol) ++result->points_agreeing;
  }

  // 4. Verification by prediction: every landmark not matched as inlier is predicted in the
  // image; each frame point not used as inlier with a predicted landmark near its pixel is
  // checked, and verified when one of them also has its disparity and a similar descriptor.
  // Checking frame points rather than landmarks makes the score independent of how densely
  // the map covers the view (a map holds every corner of many frames, a frame sees a few).
  std::vector<RelocalizationPoint> predicted;
  std::vector<uint32_t> predicted_landmark;
  const double margin = options.image_margin_px;
  for (size_t j = 0; j < map.size(); ++j) {
    if (landmark_used[j]) continue;
    const Eigen::Vector3d p_cl = T_cl_m * map[j].p_m;
    if (p_cl.z() < options.min_depth_m) continue;
    Eigen::Vector3d uvd;
    if (!predict(rig, p_cl, &uvd)) continue;
    if (uvd.x() < margin || uvd.y() < margin || uvd.x() > rig.width_px - 1 - margin ||
        uvd.y() > rig.height_px - 1 - margin)
      continue;
    predicted.push_back({uvd.x(), uvd.y(), uvd.z(), map[j].descriptor});
    predicted_landmark.push_back(static_cast<uint32_t>(j));
  }
  const PointGrid grid(predicted, std::max(options.verify_px, 1.0));
  const double verify_sq = options.verify_px * options.verify_px;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (used[i]) continue;
    const RelocalizationPoint& f = frame[i];
    bool near = false, seen = false;
    grid.forNear(f.u_px, f.v_px, [&](uint32_t k) {
      if (seen) return;
      const RelocalizationPoint& p = predicted[k];
      const double du = p.u_px - f.u_px, dv = p.v_px - f.v_px;
      if (du * du + dv * dv > verify_sq) return;
      near = true;
      seen = std::abs(p.d_px - f.d_px) <= options.verify_disparity_px &&
             frontend::descriptorDistance(f.descriptor, p.descriptor) <= max_distance;
    });
    result->checked += near ? 1 : 0;
    result->verified += seen ? 1 : 0;
  }
  const int denominator = result->inliers + result->checked;
  result->verified_fraction =
      denominator > 0 ? static_cast<double>(result->inliers + result->verified) / denominator : 0.0;

  if (result->inliers < options.min_inliers) {
    result->reason = "too few inliers after refinement (" + std::to_string(result->inliers) + ")";
  } else if (!(result->position_sigma_m <= options.max_position_sigma_m)) {
    result->reason =
        "position poorly constrained (sigma " + std::to_string(result->position_sigma_m) + " m)";
  } else if (result->points_agreeing < options.min_point_fraction * result->inliers) {
    result->reason = "3-D check: " + std::to_string(result->points_agreeing) + " of " +
                     std::to_string(result->inliers) + " inliers agree with the map";
  } else if (result->verified < options.min_verified ||
             result->verified_fraction < options.min_verified_fraction) {
    result->reason = "verification: " + std::to_string(result->verified) + " of " +
                     std::to_string(result->checked) + " checked frame points verified";
  } else {
    result->found = true;
  }
  return Status::ok();
}

}  // namespace twocam::localization
