#include "frontend/rectify.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <random>
#include <vector>

#include "frontend/cv_interop.h"
#include "io/euroc.h"
#include "support/test_paths.h"

namespace twocam::frontend {
namespace {

// Closed-form maths in double on well-conditioned geometry (|p| <= 40 m, pixels <= 1e3).
constexpr double kPixelTol = 1e-6;
constexpr double kRelTol = 1e-7;
// Poses are products of a few rotations: exact to rounding.
constexpr double kPoseTol = 1e-9;

// Raw cameras like EuRoC's VI-Sensor (strong barrel distortion), with a known relative pose:
// the right camera 0.11 m to the right, slightly off the x axis and rotated by 0.02 rad.
CameraCalibration syntheticLeft() {
  CameraCalibration c;
  c.width = 752;
  c.height = 480;
  c.fx = 458.0;
  c.fy = 457.0;
  c.cx = 367.2;
  c.cy = 248.4;
  c.radtan = {-0.28, 0.074, 2e-4, 2e-5};
  c.T_b_c.linear() = opticalRotationFromYawPitch(0.05, 0.1);
  c.T_b_c.translation() = Eigen::Vector3d(0.1, 0.055, 0.3);
  c.rate_hz = 20.0;
  return c;
}

Eigen::Isometry3d syntheticT_cl_cr() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).matrix();
  T.translation() = Eigen::Vector3d(0.11, 0.003, -0.002);
  return T;
}

CameraCalibration syntheticRight() {
  CameraCalibration c = syntheticLeft();
  c.fx = 457.5;
  c.fy = 456.1;
  c.cx = 380.0;
  c.cy = 255.2;
  c.radtan = {-0.283, 0.0745, -1.0e-4, -3.5e-5};
  c.T_b_c = syntheticLeft().T_b_c * syntheticT_cl_cr();
  return c;
}

StereoRectifier makeRectifier(const RectifyOptions& options = RectifyOptions()) {
  StereoRectifier r;
  const Status s = StereoRectifier::create(syntheticLeft(), syntheticRight(), options, &r);
  EXPECT_TRUE(s.isOk()) << s.message();
  return r;
}

// Projects body-frame points into a raw camera with OpenCV's own distortion code (independent
// of the rectifier's).
std::vector<Eigen::Vector2d> projectRaw(const CameraCalibration& c,
                                        const std::vector<Eigen::Vector3d>& p_b) {
  const Eigen::Isometry3d T_c_b = c.T_b_c.inverse();
  cv::Mat R(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = T_c_b.linear()(i, j);
  cv::Mat rvec;
  cv::Rodrigues(R, rvec);
  const cv::Mat tvec = (cv::Mat_<double>(3, 1) << T_c_b.translation().x(),
                        T_c_b.translation().y(),
                        T_c_b.translation().z());
  std::vector<cv::Point3d> object;
  for (const auto& p : p_b) object.emplace_back(p.x(), p.y(), p.z());
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(1, 4) << c.radtan[0], c.radtan[1], c.radtan[2], c.radtan[3]);
  std::vector<cv::Point2d> image;
  cv::projectPoints(object, rvec, tvec, K, D, image);
  std::vector<Eigen::Vector2d> out;
  for (const auto& q : image) out.emplace_back(q.x, q.y);
  return out;
}

bool insideImage(const CameraCalibration& c, const Eigen::Vector2d& uv) {
  return uv.x() >= 0.0 && uv.y() >= 0.0 && uv.x() <= c.width - 1.0 && uv.y() <= c.height - 1.0;
}

TEST(RectifyOptions, Validate) {
  EXPECT_TRUE(RectifyOptions().validate().isOk());
  RectifyOptions o;
  for (double alpha : {-0.1, 1.5, std::nan("")}) {
    o.alpha = alpha;
    EXPECT_FALSE(o.validate().isOk()) << alpha;
  }
  o = RectifyOptions();
  o.output_width_px = 640;
  EXPECT_FALSE(o.validate().isOk());
  o.output_height_px = 8;
  EXPECT_FALSE(o.validate().isOk());
  o.output_height_px = 480;
  EXPECT_TRUE(o.validate().isOk());
}

TEST(StereoRectifier, RigFollowsProjectConventions) {
  const StereoRectifier r = makeRectifier();
  const StereoRig& rig = r.rig();
  EXPECT_TRUE(rig.validate().isOk());
  EXPECT_EQ(rig.width_px, 752);
  EXPECT_EQ(rig.height_px, 480);
  // Rectification rotates the cameras about their centres: the baseline keeps its length.
  EXPECT_NEAR(rig.baseline_m, syntheticT_cl_cr().translation().norm(), kPoseTol);
  // Both rectified cameras share one orientation...
  const Eigen::Matrix3d R_b_rl =
      syntheticLeft().T_b_c.linear() * r.R_rect_raw(StereoSide::kLeft).transpose();
  const Eigen::Matrix3d R_b_rr =
      syntheticRight().T_b_c.linear() * r.R_rect_raw(StereoSide::kRight).transpose();
  EXPECT_LT((R_b_rl - R_b_rr).cwiseAbs().maxCoeff(), kPoseTol);
  EXPECT_LT((rig.T_b_cl.linear() - R_b_rl).cwiseAbs().maxCoeff(), kPoseTol);
  // ...the rectified left camera stays where the raw one was...
  EXPECT_LT((rig.T_b_cl.translation() - syntheticLeft().T_b_c.translation()).norm(), kPoseTol);
  // ...and the right camera's centre is at +baseline along the rectified left x axis.
  const Eigen::Vector3d right_centre_b = rig.T_b_cl * rig.T_cl_cr().translation();
  EXPECT_LT((right_centre_b - syntheticRight().T_b_c.translation()).norm(), kPoseTol);
}

TEST(StereoRectifier, ProjectedPointsShareRowsAndTriangulateToTheirDepth) {
  const StereoRectifier r = makeRectifier();
  const StereoRig& rig = r.rig();
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> u_dist(0.0, rig.width_px - 1.0);
  std::uniform_real_distribution<double> v_dist(0.0, rig.height_px - 1.0);
  std::uniform_real_distribution<double> log_z_dist(std::log(0.3), std::log(40.0));
  constexpr int kTrials = 1000;
  std::vector<Eigen::Vector2d> uv_rect;
  std::vector<Eigen::Vector3d> p_cl;
  std::vector<Eigen::Vector3d> p_b;
  for (int i = 0; i < kTrials; ++i) {
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const double v_draw = v_dist(rng);
    const double u_draw = u_dist(rng);
    const Eigen::Vector2d uv(u_draw, v_draw);
    const double z = std::exp(log_z_dist(rng));
    uv_rect.push_back(uv);
    p_cl.emplace_back(
        (uv.x() - rig.cx_px) / rig.fx_px * z, (uv.y() - rig.cy_px) / rig.fy_px * z, z);
    p_b.push_back(rig.T_b_cl * p_cl.back());
  }
  const std::vector<Eigen::Vector2d> raw_left = projectRaw(syntheticLeft(), p_b);
  const std::vector<Eigen::Vector2d> raw_right = projectRaw(syntheticRight(), p_b);
  int checked = 0;
  for (int i = 0; i < kTrials; ++i) {
    // At alpha = 0 every rectified left pixel comes from inside the raw left image.
    ASSERT_TRUE(insideImage(syntheticLeft(), raw_left[i])) << raw_left[i].transpose();
    const Eigen::Vector3d p_cr = syntheticRight().T_b_c.inverse() * p_b[i];
    if (p_cr.z() <= 0.0 || !insideImage(syntheticRight(), raw_right[i])) continue;
    ++checked;
    Eigen::Vector2d left;
    Eigen::Vector2d right;
    ASSERT_TRUE(r.rectifyPixel(StereoSide::kLeft, raw_left[i], &left));
    ASSERT_TRUE(r.rectifyPixel(StereoSide::kRight, raw_right[i], &right));
    EXPECT_LT((left - uv_rect[i]).norm(), kPixelTol) << "trial " << i;
    EXPECT_NEAR(left.y(), right.y(), kPixelTol) << "trial " << i;
    const double disparity = left.x() - right.x();
    EXPECT_GT(disparity, 0.0);
    EXPECT_NEAR(disparity, rig.fx_px * rig.baseline_m / p_cl[i].z(), kRelTol * disparity);
    const auto p = triangulateRectified(rig, left, disparity);
    ASSERT_TRUE(p.has_value());
    EXPECT_LT((*p - p_cl[i]).norm(), kRelTol * p_cl[i].norm()) << "trial " << i;
  }
  // Near points fall outside the right image; most do not.
  EXPECT_GT(checked, kTrials / 2);
}

TEST(StereoRectifier, RawPixelInvertsRectifyPixel) {
  const StereoRectifier r = makeRectifier();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u_dist(0.0, 751.0);
  std::uniform_real_distribution<double> v_dist(0.0, 479.0);
  for (StereoSide side : {StereoSide::kLeft, StereoSide::kRight}) {
    for (int i = 0; i < 1000; ++i) {
      // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to
      // left, kept)
      const double v_draw = v_dist(rng);
      const double u_draw = u_dist(rng);
      const Eigen::Vector2d raw(u_draw, v_draw);
      Eigen::Vector2d rect;
      Eigen::Vector2d back;
      ASSERT_TRUE(r.rectifyPixel(side, raw, &rect));
      ASSERT_TRUE(r.rawPixel(side, rect, &back));
      EXPECT_LT((back - raw).norm(), kPixelTol) << raw.transpose();
    }
  }
}

// Bilinear interpolation of an 8-bit image in double (the exact version of what remap does).
double bilinear(const ImageU8& img, const Eigen::Vector2d& uv) {
  const int u0 = static_cast<int>(std::floor(uv.x()));
  const int v0 = static_cast<int>(std::floor(uv.y()));
  const double a = uv.x() - u0;
  const double b = uv.y() - v0;
  return (1 - a) * (1 - b) * img(u0, v0) + a * (1 - b) * img(u0 + 1, v0) +
         (1 - a) * b * img(u0, v0 + 1) + a * b * img(u0 + 1, v0 + 1);
}

TEST(StereoRectifier, RectifiedImagesSampleTheRawImagesWhereTheModelSays) {
  const StereoRectifier r = makeRectifier();
  // A smooth pattern with gradients up to ~10 grey levels per pixel: a lookup error of 0.1 px
  // shows as ~1 grey level.
  ImageU8 raw(752, 480);
  for (int v = 0; v < raw.height; ++v)
    for (int u = 0; u < raw.width; ++u)
      raw(u, v) =
          static_cast<uint8_t>(std::lround(128.0 + 100.0 * std::sin(0.1 * u) * std::cos(0.07 * v)));
  ImageU8 left;
  ImageU8 right;
  ASSERT_TRUE(r.rectify(raw, raw, &left, &right).isOk());
  // Budget: 1/64 px lookup rounding (<= 0.22 levels here), 8-bit output rounding (0.5) and
  // OpenCV's 1/1024 fixed-point weights.
  constexpr double kMaxAbsErrLevels = 1.0;
  constexpr double kMeanAbsErrLevels = 0.35;
  for (StereoSide side : {StereoSide::kLeft, StereoSide::kRight}) {
    const ImageU8& out = side == StereoSide::kLeft ? left : right;
    ASSERT_EQ(out.width, r.rig().width_px);
    ASSERT_EQ(out.height, r.rig().height_px);
    double sum = 0.0;
    double worst = 0.0;
    int n = 0;
    for (int v = 0; v < out.height; ++v) {
      for (int u = 0; u < out.width; ++u) {
        Eigen::Vector2d src;
        ASSERT_TRUE(r.rawPixel(side, Eigen::Vector2d(u, v), &src));
        if (src.x() < 0.0 || src.y() < 0.0 || src.x() >= raw.width - 1.0 ||
            src.y() >= raw.height - 1.0)
          continue;
        const double err = std::abs(out(u, v) - bilinear(raw, src));
        sum += err;
        worst = std::max(worst, err);
        ++n;
      }
    }
    ASSERT_GT(n, out.width * out.height * 9 / 10);
    EXPECT_LT(worst, kMaxAbsErrLevels);
    EXPECT_LT(sum / n, kMeanAbsErrLevels);
  }
}

int countZeros(const ImageU8& img) {
  return static_cast<int>(std::count(img.data.begin(), img.data.end(), 0));
}

TEST(StereoRectifier, AlphaZeroLeavesNoBlackBordersAlphaOneDoes) {
  const ImageU8 raw(752, 480, 200);
  ImageU8 left;
  ImageU8 right;
  ASSERT_TRUE(makeRectifier().rectify(raw, raw, &left, &right).isOk());
  EXPECT_EQ(countZeros(left), 0);
  EXPECT_EQ(countZeros(right), 0);
  RectifyOptions keep_all;
  keep_all.alpha = 1.0;
  ASSERT_TRUE(makeRectifier(keep_all).rectify(raw, raw, &left, &right).isOk());
  EXPECT_GT(countZeros(left), 0);
  EXPECT_GT(countZeros(right), 0);
}

TEST(StereoRectifier, OutputSizeAndAliasing) {
  RectifyOptions half;
  half.output_width_px = 376;
  half.output_height_px = 240;
  const StereoRectifier r = makeRectifier(half);
  EXPECT_EQ(r.rig().width_px, 376);
  EXPECT_EQ(r.rig().height_px, 240);
  std::mt19937 rng(3);
  ImageU8 raw_left(752, 480);
  ImageU8 raw_right(752, 480);
  for (auto& p : raw_left.data) p = static_cast<uint8_t>(rng() & 0xFF);
  for (auto& p : raw_right.data) p = static_cast<uint8_t>(rng() & 0xFF);
  ImageU8 left;
  ImageU8 right;
  ASSERT_TRUE(r.rectify(raw_left, raw_right, &left, &right).isOk());
  EXPECT_EQ(left.width, 376);
  EXPECT_EQ(right.height, 240);
  // In place, and with the outputs swapped onto the other input.
  ImageU8 a = raw_left;
  ImageU8 b = raw_right;
  ASSERT_TRUE(r.rectify(a, b, &a, &b).isOk());
  EXPECT_EQ(a.data, left.data);
  EXPECT_EQ(b.data, right.data);
  a = raw_left;
  b = raw_right;
  ASSERT_TRUE(r.rectify(a, b, &b, &a).isOk());
  EXPECT_EQ(b.data, left.data);
  EXPECT_EQ(a.data, right.data);
}

void expectErrorMentions(const Status& s, const std::string& word) {
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find(word), std::string::npos) << s.message();
}

TEST(StereoRectifier, RejectsBadGeometry) {
  StereoRectifier r;
  expectErrorMentions(
      StereoRectifier::create(syntheticRight(), syntheticLeft(), RectifyOptions(), &r), "swap");
  CameraCalibration above = syntheticRight();
  Eigen::Isometry3d T = syntheticT_cl_cr();
  T.translation() = Eigen::Vector3d(0.01, 0.11, 0.0);
  above.T_b_c = syntheticLeft().T_b_c * T;
  expectErrorMentions(StereoRectifier::create(syntheticLeft(), above, RectifyOptions(), &r),
                      "vertical");
  CameraCalibration same_place = syntheticRight();
  same_place.T_b_c.translation() = syntheticLeft().T_b_c.translation();
  expectErrorMentions(StereoRectifier::create(syntheticLeft(), same_place, RectifyOptions(), &r),
                      "apart");
  EXPECT_FALSE(r.valid());
}

TEST(StereoRectifier, RejectsBadInput) {
  StereoRectifier r;
  CameraCalibration small = syntheticRight();
  small.width = 640;
  expectErrorMentions(StereoRectifier::create(syntheticLeft(), small, RectifyOptions(), &r),
                      "differ");
  CameraCalibration no_focal = syntheticLeft();
  no_focal.fx = 0.0;
  expectErrorMentions(StereoRectifier::create(no_focal, syntheticRight(), RectifyOptions(), &r),
                      "left camera");
  RectifyOptions bad;
  bad.alpha = 2.0;
  expectErrorMentions(StereoRectifier::create(syntheticLeft(), syntheticRight(), bad, &r), "alpha");

  ImageU8 left;
  ImageU8 right;
  const ImageU8 raw(752, 480, 100);
  expectErrorMentions(r.rectify(raw, raw, &left, &right), "not created");
  Eigen::Vector2d uv;
  EXPECT_FALSE(r.rectifyPixel(StereoSide::kLeft, Eigen::Vector2d(1, 1), &uv));

  r = makeRectifier();
  expectErrorMentions(r.rectify(ImageU8(640, 480), raw, &left, &right), "640x480");
  expectErrorMentions(r.rectify(raw, ImageU8(), &left, &right), "right raw image");
  ImageU8 corrupt = raw;
  corrupt.data.pop_back();
  expectErrorMentions(r.rectify(raw, corrupt, &left, &right), "pixels stored");
  expectErrorMentions(r.rectify(raw, raw, nullptr, &right), "non-null");
  expectErrorMentions(r.rectify(raw, raw, &left, &left), "distinct");
}

TEST(RadTan, UndistortInvertsDistort) {
  const std::array<double, 4> k = {-0.28, 0.074, 2e-4, 2e-5};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> dist(-0.9, 0.9);
  for (int i = 0; i < 1000; ++i) {
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const double y_draw = 0.7 * dist(rng);
    const double x_draw = dist(rng);
    const Eigen::Vector2d xy(x_draw, y_draw);
    Eigen::Vector2d back;
    ASSERT_TRUE(undistortRadTan(k, distortRadTan(k, xy), &back));
    EXPECT_LT((back - xy).norm(), kPixelTol * 1e-3) << xy.transpose();
  }
}

// --- Real data: EuRoC V1_01_easy excerpt -------------------------------------------------------

struct RowStats {
  double median_abs_dv_px = 0.0;
  double median_disparity_px = 0.0;
  double positive_fraction = 0.0;
  size_t matches = 0;
};

// Tracks Shi-Tomasi corners from left to right with pyramidal Lucas-Kanade, keeping tracks that
// come back to within 0.3 px (forward-backward check), and summarises v_left - v_right and
// u_left - u_right.
RowStats matchRows(const std::vector<std::pair<ImageU8, ImageU8>>& pairs) {
  std::vector<double> abs_dv;
  std::vector<double> disparity;
  for (const auto& [l, r] : pairs) {
    const cv::Mat left = asMat(l);
    const cv::Mat right = asMat(r);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(left, corners, 400, 0.01, 10);
    std::vector<cv::Point2f> tracked;
    std::vector<cv::Point2f> back;
    std::vector<uint8_t> ok_fwd;
    std::vector<uint8_t> ok_bwd;
    std::vector<float> err;
    const cv::Size window(21, 21);
    cv::calcOpticalFlowPyrLK(left, right, corners, tracked, ok_fwd, err, window, 3);
    cv::calcOpticalFlowPyrLK(right, left, tracked, back, ok_bwd, err, window, 3);
    constexpr double kForwardBackwardPx = 0.3;
    for (size_t i = 0; i < corners.size(); ++i) {
      if (!ok_fwd[i] || !ok_bwd[i] || cv::norm(back[i] - corners[i]) > kForwardBackwardPx) continue;
      abs_dv.push_back(std::abs(corners[i].y - tracked[i].y));
      disparity.push_back(corners[i].x - tracked[i].x);
    }
  }
  RowStats s;
  s.matches = abs_dv.size();
  if (abs_dv.empty()) return s;
  auto median = [](std::vector<double> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  s.median_abs_dv_px = median(abs_dv);
  s.median_disparity_px = median(disparity);
  s.positive_fraction = static_cast<double>(std::count_if(
                            disparity.begin(), disparity.end(), [](double d) { return d > 0.0; })) /
                        static_cast<double>(disparity.size());
  return s;
}

TEST(StereoRectifierEuroc, RectifiedRowsAlign) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string mav0 = data + "/euroc_micro/mav0";
  io::CameraCalibration cam0;
  io::CameraCalibration cam1;
  Status s = io::loadEurocStereoCalibration(mav0, &cam0, &cam1);
  ASSERT_TRUE(s.isOk()) << s.message();
  StereoRectifier rectifier;
  s = StereoRectifier::create(cam0, cam1, RectifyOptions(), &rectifier);
  ASSERT_TRUE(s.isOk()) << s.message();
  // README: baseline 0.110 m.
  constexpr double kBaselineTolM = 0.002;
  EXPECT_NEAR(rectifier.rig().baseline_m, 0.110, kBaselineTolM);

  io::EurocStereoIndex index;
  s = io::loadEurocStereoIndex(mav0, &index);
  ASSERT_TRUE(s.isOk()) << s.message();
  std::vector<std::pair<ImageU8, ImageU8>> raw_pairs;
  std::vector<std::pair<ImageU8, ImageU8>> rectified_pairs;
  for (size_t i = 0; i < index.t_ns.size(); i += 6) {
    ImageU8 raw_left;
    ImageU8 raw_right;
    ASSERT_TRUE(loadGrey(index.left_paths[i], &raw_left).isOk());
    ASSERT_TRUE(loadGrey(index.right_paths[i], &raw_right).isOk());
    ImageU8 left;
    ImageU8 right;
    ASSERT_TRUE(rectifier.rectify(raw_left, raw_right, &left, &right).isOk());
    raw_pairs.emplace_back(std::move(raw_left), std::move(raw_right));
    rectified_pairs.emplace_back(std::move(left), std::move(right));
  }
  const RowStats raw = matchRows(raw_pairs);
  const RowStats rect = matchRows(rectified_pairs);
  std::cout << "[ euroc   ] " << raw_pairs.size() << " pairs; raw: " << raw.matches
            << " matches, median |dv| = " << raw.median_abs_dv_px
            << " px; rectified: " << rect.matches
            << " matches, median |dv| = " << rect.median_abs_dv_px
            << " px, median disparity = " << rect.median_disparity_px
            << " px, positive = " << 100.0 * rect.positive_fraction << " %\n";
  ASSERT_GT(rect.matches, 200u);
  // The acceptance threshold for rectified rows.
  constexpr double kMaxMedianRowOffsetPx = 0.3;
  EXPECT_LT(rect.median_abs_dv_px, kMaxMedianRowOffsetPx);
  EXPECT_GT(raw.median_abs_dv_px, rect.median_abs_dv_px);
  EXPECT_GT(rect.median_disparity_px, 0.0);
  // Tracks that survive the forward-backward check are nearly all right; allow a few on
  // repeated texture.
  constexpr double kMinPositiveFraction = 0.95;
  EXPECT_GT(rect.positive_fraction, kMinPositiveFraction);

  // alpha = 0: no black borders on the real calibration either.
  const ImageU8 grey(cam0.width, cam0.height, 200);
  ImageU8 left;
  ImageU8 right;
  ASSERT_TRUE(rectifier.rectify(grey, grey, &left, &right).isOk());
  EXPECT_EQ(countZeros(left), 0);
  EXPECT_EQ(countZeros(right), 0);
}

}  // namespace
}  // namespace twocam::frontend
