#include "localization/relocalize.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace twocam::localization {
namespace {

using frontend::Descriptor;
using frontend::DescriptorKind;

/// Targets of the synthetic check: pose within 1 cm and 0.1 degree.
constexpr double kPositionTolM = 0.01;
constexpr double kAngleTolDeg = 0.1;
/// Pixel noise of the simulated corners and disparities [px].
constexpr double kPixelNoisePx = 0.3;
constexpr double kDisparityNoisePx = 0.2;
/// Bits flipped between a landmark's descriptor and its observation (of 256).
constexpr int kFlippedBits = 8;
/// Fraction of the ratio-test matches that are wrong, and of visible landmarks whose
/// descriptor repeats elsewhere in the map (they fail the ratio test and are left to the
/// verification).
constexpr double kOutlierFraction = 0.3;
constexpr double kTwinFraction = 0.25;

StereoRig testRig() {
  StereoRig rig;  // 640 x 480, fx 500, baseline 0.12 m
  rig.T_b_cl.linear() = opticalRotationFromYawPitch(0.0, 0.1);
  rig.T_b_cl.translation() = Eigen::Vector3d(0.1, 0.0, 0.5);
  return rig;
}

Descriptor randomOrb(std::mt19937_64* rng) {
  Descriptor d;
  d.kind = DescriptorKind::kOrb;
  for (int i = 0; i < 32; ++i) d.bytes[static_cast<size_t>(i)] = static_cast<uint8_t>((*rng)());
  return d;
}

Descriptor flipped(Descriptor d, int bits, std::mt19937_64* rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int k = 0; k < bits; ++k) {
    const int b = bit(*rng);
    d.bytes[static_cast<size_t>(b / 8)] ^= static_cast<uint8_t>(1u << (b % 8));
  }
  return d;
}

/// The true pose of the test camera in the map.
Eigen::Isometry3d trueCameraPose() {
  Eigen::Isometry3d T_m_b = Eigen::Isometry3d::Identity();
  T_m_b.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).matrix();
  T_m_b.translation() = Eigen::Vector3d(2.0, -1.0, 0.0);
  return T_m_b * testRig().T_b_cl;
}

struct Scene {
  std::vector<MapLandmark> map;
  std::vector<RelocalizationPoint> frame;
};

/// A random map of `n` landmarks in front of T_m_cl (2-8 m deep by default, in view) plus as many
/// out of view, and the frame that T_m_cl sees of it, with outlier matches and repeated
/// descriptors.
Scene makeScene(uint64_t seed,
                int n,
                const Eigen::Isometry3d& T_m_cl,
                double min_depth_m = 2.0,
                double max_depth_m = 8.0) {
  const StereoRig rig = testRig();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  Scene s;
  // In view: back-project random pixels at random depths.
  for (int i = 0; i < n; ++i) {
    const double u = 20.0 + uni(rng) * (rig.width_px - 40.0);
    const double v = 20.0 + uni(rng) * (rig.height_px - 40.0);
    const double z = min_depth_m + (max_depth_m - min_depth_m) * uni(rng);
    const Eigen::Vector3d p_cl((u - rig.cx_px) / rig.fx_px * z, (v - rig.cy_px) / rig.fy_px * z, z);
    s.map.push_back({static_cast<uint64_t>(i), T_m_cl * p_cl, randomOrb(&rng)});
  }
  // Out of view: behind the camera.
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_cl(uni(rng) * 8.0 - 4.0, uni(rng) * 2.0 - 1.0, -1.0 - 5.0 * uni(rng));
    s.map.push_back({static_cast<uint64_t>(n + i), T_m_cl * p_cl, randomOrb(&rng)});
  }
  for (int i = 0; i < n; ++i) {
    const MapLandmark& l = s.map[static_cast<size_t>(i)];
    const Eigen::Vector3d p_cl = T_m_cl.inverse() * l.p_m;
    RelocalizationPoint f;
    f.u_px = rig.fx_px * p_cl.x() / p_cl.z() + rig.cx_px + kPixelNoisePx * noise(rng);
    f.v_px = rig.fy_px * p_cl.y() / p_cl.z() + rig.cy_px + kPixelNoisePx * noise(rng);
    f.d_px = rig.fx_px * rig.baseline_m / p_cl.z() + kDisparityNoisePx * noise(rng);
    f.descriptor = flipped(l.descriptor, kFlippedBits, &rng);
    const double r = uni(rng);
    if (r < kTwinFraction) {
      // The same descriptor on an out-of-view landmark: ambiguous, no match.
      s.map[static_cast<size_t>(n + i)].descriptor = l.descriptor;
    } else if (r < kTwinFraction + kOutlierFraction * (1.0 - kTwinFraction)) {
      // Looks like an out-of-view landmark: a wrong match.
      f.descriptor = flipped(s.map[static_cast<size_t>(n + i)].descriptor, kFlippedBits, &rng);
    }
    s.frame.push_back(f);
  }
  return s;
}

double angleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

TEST(Relocalize, RecoversThePoseWithThirtyPercentOutlierMatches) {
  const Eigen::Isometry3d T_m_cl = trueCameraPose();
  for (uint64_t seed : {1u, 2u, 3u}) {
    const Scene s = makeScene(seed, 200, T_m_cl);
    RelocalizationResult r;
    ASSERT_TRUE(relocalize(testRig(), s.frame, s.map, RelocalizationOptions(), &r).isOk());
    ASSERT_TRUE(r.found) << "seed " << seed << ": " << r.reason;
    // The outlier matches were made and rejected.
    int wrong = 0;
    for (const RelocalizationMatch& m : r.matches) {
      const bool correct = m.landmark == m.point;
      wrong += correct ? 0 : 1;
      if (!correct) {
        EXPECT_FALSE(m.inlier) << "wrong match " << m.point << " as inlier";
      }
    }
    EXPECT_GE(static_cast<double>(wrong) / r.matches.size(), 0.2) << "seed " << seed;
    EXPECT_LT((r.T_m_cl.translation() - T_m_cl.translation()).norm(), kPositionTolM);
    EXPECT_LT(angleDeg(r.T_m_cl, T_m_cl), kAngleTolDeg);
    const Eigen::Isometry3d T_m_b = T_m_cl * testRig().T_b_cl.inverse();
    EXPECT_LT((r.T_m_b.translation() - T_m_b.translation()).norm(), kPositionTolM);
    EXPECT_GT(r.verified, 0);
    EXPECT_EQ(r.points_agreeing, r.inliers);
  }
}

TEST(Relocalize, RefusesAFrameOfAnotherPlace) {
  const Scene home = makeScene(10, 200, trueCameraPose());
  // Another random map seen from elsewhere, with descriptors that do not occur in `home`.
  Eigen::Isometry3d elsewhere = trueCameraPose();
  elsewhere.translation() += Eigen::Vector3d(5.0, 3.0, 0.0);
  const Scene other = makeScene(11, 200, elsewhere);
  RelocalizationResult r;
  ASSERT_TRUE(relocalize(testRig(), other.frame, home.map, RelocalizationOptions(), &r).isOk());
  EXPECT_FALSE(r.found) << r.inliers << " inliers, " << r.verified << " verified";

  // Harder: the other place looks like this one (its points carry descriptors of home's
  // landmarks, like repeated texture) but its geometry differs.
  std::mt19937_64 rng(12);
  std::uniform_int_distribution<size_t> pick(0, home.map.size() - 1);
  std::vector<RelocalizationPoint> lookalike = other.frame;
  for (RelocalizationPoint& f : lookalike)
    f.descriptor = flipped(home.map[pick(rng)].descriptor, kFlippedBits, &rng);
  ASSERT_TRUE(relocalize(testRig(), lookalike, home.map, RelocalizationOptions(), &r).isOk());
  EXPECT_GE(r.matches.size(), 50u) << "the descriptors match";
  EXPECT_FALSE(r.found) << r.inliers << " inliers, " << r.verified << " verified";
}

TEST(Relocalize, RefusesAViewOfOnlyFarPointsAsPoorlyConstrained) {
  // 40-60 m away (disparities 1-1.5 px): the rotation is fixed, the range is not.
  const Scene s = makeScene(6, 200, trueCameraPose(), 40.0, 60.0);
  RelocalizationResult r;
  ASSERT_TRUE(relocalize(testRig(), s.frame, s.map, RelocalizationOptions(), &r).isOk());
  EXPECT_FALSE(r.found);
  EXPECT_GT(r.position_sigma_m, RelocalizationOptions().max_position_sigma_m);
  EXPECT_NE(r.reason.find("poorly constrained"), std::string::npos) << r.reason;
  // The same scene at 2-8 m: well constrained.
  const Scene near = makeScene(6, 200, trueCameraPose());
  ASSERT_TRUE(relocalize(testRig(), near.frame, near.map, RelocalizationOptions(), &r).isOk());
  EXPECT_TRUE(r.found) << r.reason;
  EXPECT_LT(r.position_sigma_m, RelocalizationOptions().max_position_sigma_m);
}

TEST(Relocalize, SameSeedSameResult) {
  const Scene s = makeScene(4, 150, trueCameraPose());
  RelocalizationOptions o;
  o.seed = 77;
  RelocalizationResult a, b;
  ASSERT_TRUE(relocalize(testRig(), s.frame, s.map, o, &a).isOk());
  ASSERT_TRUE(relocalize(testRig(), s.frame, s.map, o, &b).isOk());
  ASSERT_TRUE(a.found) << a.reason;
  EXPECT_TRUE(a.T_m_cl.matrix() == b.T_m_cl.matrix());
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.verified, b.verified);
  ASSERT_EQ(a.matches.size(), b.matches.size());
  for (size_t k = 0; k < a.matches.size(); ++k) EXPECT_EQ(a.matches[k].inlier, b.matches[k].inlier);
}

TEST(Relocalize, OrbMatchesEqualABruteForceScanWithDescriptorDistance) {
  // The matcher scans packed descriptors with the CPU's popcount; its matches must be exactly
  // those of the rule written plainly: nearest landmark by frontend::descriptorDistance within
  // max_orb_distance, and ratio * (nearest landmark of another place) above it.
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> pos(-5.0, 5.0);
  constexpr int kMap = 3000;
  constexpr int kFrame = 400;
  std::vector<MapLandmark> map(kMap);
  for (int j = 0; j < kMap; ++j) {
    map[j].id = static_cast<uint64_t>(j);
    map[j].p_m = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    map[j].descriptor = randomOrb(&rng);
  }
  // Half the frame points copy a landmark with 0-60 flipped bits (some twins of a nearby
  // landmark, which the same-place rule must skip), half are random.
  for (int j = 1; j < kMap; j += 50) {
    map[j].descriptor = map[j - 1].descriptor;
    map[j].p_m = map[j - 1].p_m + Eigen::Vector3d(0.01, 0.0, 0.0);
  }
  std::vector<RelocalizationPoint> frame(kFrame);
  for (int i = 0; i < kFrame; ++i) {
    frame[i].u_px = 10 + i;
    frame[i].v_px = 20;
    frame[i].d_px = 10.0;
    if (i % 2 == 0) {
      frame[i].descriptor = flipped(map[(i * 7) % kMap].descriptor, (i / 2) % 61, &rng);
    } else {
      frame[i].descriptor = randomOrb(&rng);
    }
  }
  const RelocalizationOptions options;
  RelocalizationResult result;
  ASSERT_TRUE(relocalize(testRig(), frame, map, options, &result).isOk());

  std::vector<std::pair<uint32_t, uint32_t>> expected;
  for (int i = 0; i < kFrame; ++i) {
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (int j = 0; j < kMap; ++j) {
      const double d = frontend::descriptorDistance(frame[i].descriptor, map[j].descriptor);
      if (d < best_d) {
        best_d = d;
        best = j;
      }
    }
    if (!(best_d <= options.max_orb_distance)) continue;
    double second = std::numeric_limits<double>::infinity();
    for (int j = 0; j < kMap; ++j) {
      if ((map[j].p_m - map[best].p_m).norm() <= options.same_place_m) continue;
      second =
          std::min(second, frontend::descriptorDistance(frame[i].descriptor, map[j].descriptor));
    }
    if (best_d < options.ratio * second)
      expected.emplace_back(static_cast<uint32_t>(i), static_cast<uint32_t>(best));
  }
  std::vector<std::pair<uint32_t, uint32_t>> got;
  for (const RelocalizationMatch& m : result.matches) got.emplace_back(m.point, m.landmark);
  ASSERT_GT(expected.size(), 100u);
  EXPECT_EQ(got, expected);
}

TEST(Relocalize, OptionsAndInputErrorsNameTheirKeys) {
  RelocalizationOptions o;
  o.ratio = 1.5;
  Status s = o.validate();
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("relocalization.ratio"), std::string::npos) << s.message();
  o = RelocalizationOptions();
  o.min_inliers = 2;
  s = o.validate();
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("relocalization.min_inliers"), std::string::npos) << s.message();
  o = RelocalizationOptions();
  o.min_verified_fraction = -0.1;
  EXPECT_NE(o.validate().message().find("relocalization.min_verified_fraction"), std::string::npos);
  EXPECT_TRUE(RelocalizationOptions().validate().isOk());

  // Mixed descriptor kinds and bad disparities are errors, not crashes.
  Scene sc = makeScene(5, 50, trueCameraPose());
  RelocalizationResult r;
  sc.map[3].descriptor.kind = DescriptorKind::kPatch;
  s = relocalize(testRig(), sc.frame, sc.map, RelocalizationOptions(), &r);
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("patch"), std::string::npos) << s.message();
  sc = makeScene(5, 50, trueCameraPose());
  sc.frame[2].d_px = 0.0;
  EXPECT_FALSE(relocalize(testRig(), sc.frame, sc.map, RelocalizationOptions(), &r).isOk());
  // Empty inputs: not found, no error.
  ASSERT_TRUE(relocalize(testRig(), {}, sc.map, RelocalizationOptions(), &r).isOk());
  EXPECT_FALSE(r.found);
}

}  // namespace
}  // namespace twocam::localization
