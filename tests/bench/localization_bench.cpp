// Visual pose correction per frame: localization::updatePose (Ceres, robust, with the odometry
// prior) against OpenCV's solvePnPRansac on the same observations, in one binary. The
// observations are synthetic landmarks in front of the camera with 0.3 px noise and 10 %
// outliers at random pixels; the prediction is off by 3 cm and 1 degree.
// Relocalisation's descriptor matching (localization::relocalize, ORB) against OpenCV's
// BFMatcher (Hamming, k = 2 nearest) on the same random descriptors: 1000 frame points against
// maps of 10 000 and 100 000 landmarks. Random descriptors pass no distance bound, so relocalize
// stops after matching ("too few descriptor matches"): the figure is the matching step alone.

#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <random>
#include <vector>

#include "localization/pose_update.h"
#include "localization/relocalize.h"
#include "support/synthetic_stream.h"

namespace {

using twocam::Pose2;
using twocam::StereoRig;
using twocam::localization::LandmarkObservation;
using twocam::localization::PoseWithCovariance;

StereoRig benchRig() { return twocam::test::SyntheticStream::defaultRig(); }

std::vector<LandmarkObservation> observations(const StereoRig& rig,
                                              const Eigen::Isometry3d& T_w_b,
                                              int n) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(-2.0, 2.0), y(-1.0, 1.0), z(1.5, 6.0), unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  const Eigen::Isometry3d T_w_cl = T_w_b * rig.T_b_cl;
  std::vector<LandmarkObservation> out;
  while (static_cast<int>(out.size()) < n) {
    const Eigen::Vector3d p(x(rng), y(rng), z(rng));
    LandmarkObservation o;
    o.p_w = T_w_cl * p;
    o.u_px = rig.cx_px + rig.fx_px * p.x() / p.z() + noise(rng);
    o.v_px = rig.cy_px + rig.fy_px * p.y() / p.z() + noise(rng);
    o.d_px = rig.fx_px * rig.baseline_m / p.z() + noise(rng);
    if (o.u_px < 0 || o.u_px >= rig.width_px || o.v_px < 0 || o.v_px >= rig.height_px) continue;
    if (unit(rng) < 0.1) {
      o.u_px = unit(rng) * rig.width_px;
      o.v_px = unit(rng) * rig.height_px;
    }
    out.push_back(o);
  }
  return out;
}

PoseWithCovariance prediction() {
  PoseWithCovariance p;
  p.T_w_b = twocam::toIsometry(Pose2{1.03, 0.0, 1.0 * M_PI / 180.0});
  p.cov = Eigen::Vector3d(2.5e-5, 2.5e-5, 3e-5).asDiagonal();
  return p;
}

void updatePoseBench(benchmark::State& state, twocam::localization::StereoCostLayout layout) {
  const StereoRig rig = benchRig();
  const auto obs = observations(rig, twocam::toIsometry(Pose2{1.0, 0.0, 0.0}), state.range(0));
  const PoseWithCovariance pred = prediction();
  const twocam::localization::PoseUpdateOptions options;
  int inliers = 0;
  for (auto _ : state) {
    const auto r = twocam::localization::updatePose(rig, pred, obs, options, layout);
    inliers = r.inliers;
    benchmark::DoNotOptimize(r.estimate.T_w_b);
  }
  state.counters["inliers"] = inliers;
}

/// The pose update as the pipeline runs it: TinySolver's steps on normal equations summed per
/// observation.
void BM_UpdatePoseNormalEquations(benchmark::State& state) {
  updatePoseBench(state, twocam::localization::StereoCostLayout::kNormalEquations);
}

/// The same on Ceres' TinySolver (the pipeline's solve from 2026-12-06 to 2026-12-07).
void BM_UpdatePoseTinySolver(benchmark::State& state) {
  updatePoseBench(state, twocam::localization::StereoCostLayout::kTinySolver);
}

/// The same minimisation as a ceres::Problem with the stereo residuals in one cost function (the
/// layout from 2026-12-05 to 2026-12-06).
void BM_UpdatePoseCeres(benchmark::State& state) {
  updatePoseBench(state, twocam::localization::StereoCostLayout::kOneBlock);
}

/// The same with one Ceres residual block per observation (the layout before 2026-12-05).
void BM_UpdatePoseCeresPerObservation(benchmark::State& state) {
  updatePoseBench(state, twocam::localization::StereoCostLayout::kPerObservation);
}

void BM_SolvePnPRansacOpenCV(benchmark::State& state) {
  const StereoRig rig = benchRig();
  const auto obs = observations(rig, twocam::toIsometry(Pose2{1.0, 0.0, 0.0}), state.range(0));
  const Eigen::Isometry3d T_cl_w = (prediction().T_w_b * rig.T_b_cl).inverse();
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (const LandmarkObservation& o : obs) {
    object.emplace_back(o.p_w.x(), o.p_w.y(), o.p_w.z());
    image.emplace_back(o.u_px, o.v_px);
  }
  const cv::Matx33d K(rig.fx_px, 0, rig.cx_px, 0, rig.fy_px, rig.cy_px, 0, 0, 1);
  int inliers = 0;
  for (auto _ : state) {
    cv::Mat rvec, tvec, inlier_idx;
    const Eigen::AngleAxisd aa(T_cl_w.linear());
    const Eigen::Vector3d r0 = aa.angle() * aa.axis();
    rvec = (cv::Mat_<double>(3, 1) << r0.x(), r0.y(), r0.z());
    tvec = (cv::Mat_<double>(3, 1) << T_cl_w.translation().x(),
            T_cl_w.translation().y(),
            T_cl_w.translation().z());
    cv::solvePnPRansac(object,
                       image,
                       K,
                       cv::noArray(),
                       rvec,
                       tvec,
                       true,
                       100,
                       2.0f,
                       0.99,
                       inlier_idx,
                       cv::SOLVEPNP_ITERATIVE);
    inliers = inlier_idx.rows;
    benchmark::DoNotOptimize(tvec.data);
  }
  state.counters["inliers"] = inliers;
}

struct RandomOrbSet {
  std::vector<twocam::localization::RelocalizationPoint> frame;
  std::vector<twocam::localization::MapLandmark> map;
  cv::Mat frame_desc, map_desc;  // the same bytes as OpenCV descriptor matrices (CV_8U, 32 cols)
};

RandomOrbSet randomOrbSet(int frame_points, int map_landmarks) {
  constexpr int kOrbBytes = 32;
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<double> pos(-10.0, 10.0);
  RandomOrbSet set;
  set.frame_desc.create(frame_points, kOrbBytes, CV_8U);
  set.map_desc.create(map_landmarks, kOrbBytes, CV_8U);
  for (int i = 0; i < frame_points; ++i) {
    twocam::localization::RelocalizationPoint p;
    p.u_px = 100 + i % 400;
    p.v_px = 100 + i % 200;
    p.d_px = 20.0;
    for (int k = 0; k < kOrbBytes; ++k) {
      p.descriptor.bytes[static_cast<size_t>(k)] = static_cast<uint8_t>(byte(rng));
      set.frame_desc.at<uint8_t>(i, k) = p.descriptor.bytes[static_cast<size_t>(k)];
    }
    set.frame.push_back(p);
  }
  for (int j = 0; j < map_landmarks; ++j) {
    twocam::localization::MapLandmark l;
    l.id = static_cast<uint64_t>(j);
    l.p_m = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    for (int k = 0; k < kOrbBytes; ++k) {
      l.descriptor.bytes[static_cast<size_t>(k)] = static_cast<uint8_t>(byte(rng));
      set.map_desc.at<uint8_t>(j, k) = l.descriptor.bytes[static_cast<size_t>(k)];
    }
    set.map.push_back(l);
  }
  return set;
}

constexpr int kRelocFramePoints = 1000;

void BM_RelocalizeMatchOrb(benchmark::State& state) {
  const RandomOrbSet set = randomOrbSet(kRelocFramePoints, static_cast<int>(state.range(0)));
  const twocam::localization::RelocalizationOptions options;
  size_t matches = 0;
  for (auto _ : state) {
    twocam::localization::RelocalizationResult r;
    const twocam::Status s =
        twocam::localization::relocalize(benchRig(), set.frame, set.map, options, &r);
    if (!s) state.SkipWithError(s.message().c_str());
    matches = r.matches.size();
    benchmark::DoNotOptimize(r.matches.data());
  }
  state.counters["matches"] = static_cast<double>(matches);
}

void BM_BFMatcherHammingOpenCV(benchmark::State& state) {
  const RandomOrbSet set = randomOrbSet(kRelocFramePoints, static_cast<int>(state.range(0)));
  const cv::BFMatcher matcher(cv::NORM_HAMMING);
  for (auto _ : state) {
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(set.frame_desc, set.map_desc, knn, 2);
    benchmark::DoNotOptimize(knn.data());
  }
}

BENCHMARK(BM_UpdatePoseNormalEquations)
    ->Arg(50)
    ->Arg(150)
    ->Arg(400)
    ->Arg(1000)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_UpdatePoseTinySolver)
    ->Arg(50)
    ->Arg(150)
    ->Arg(400)
    ->Arg(1000)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_UpdatePoseCeres)
    ->Arg(50)
    ->Arg(150)
    ->Arg(400)
    ->Arg(1000)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_UpdatePoseCeresPerObservation)
    ->Arg(50)
    ->Arg(150)
    ->Arg(400)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SolvePnPRansacOpenCV)->Arg(50)->Arg(150)->Arg(400)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RelocalizeMatchOrb)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BFMatcherHammingOpenCV)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace
