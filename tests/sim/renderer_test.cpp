#include "sim/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "common/random.h"
#include "sim/surfaces.h"

namespace twocam::sim {
namespace {

// Ground truth must be exact: a 3D point appears at its pinhole projection within 0.25 px.
// The issue asks for 0.25 px; measured errors are below 0.01 px, so hold it to 0.05 px.
constexpr double kProjectionTolPx = 0.05;
// Refined depth is the analytic intersection, stored as float: relative float precision.
constexpr double kDepthRelTol = 1e-6;
// Share of rendered pixels whose facet must be identified (edge pixels may be ambiguous).
constexpr double kMinResolvedFraction = 0.999;

World makeWorld() {
  World w;
  w.name = "renderer_test";
  w.rig.width_px = 640;
  w.rig.height_px = 480;
  w.rig.fx_px = 500.0;
  w.rig.fy_px = 480.0;
  w.rig.cx_px = 321.3;
  w.rig.cy_px = 238.7;
  w.rig.baseline_m = 0.12;
  w.robot.waypoints = {Eigen::Vector2d(0, 0), Eigen::Vector2d(5, 0)};
  Shape s;
  s.kind = ShapeKind::kPlane;
  s.size_m = Eigen::Vector3d(60, 60, 0);
  w.shapes.push_back(s);  // sets the world bounds (clip range) only; tests build their own meshes
  w.background_grey = 0.0;
  return w;
}

/// Camera at `position` looking along world +x (optical z = world x, x = -y, y = -z).
Eigen::Isometry3d cameraLookingAlongX(const Eigen::Vector3d& position) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = opticalRotationFromYawPitch(0.0, 0.0);
  T.translation() = position;
  return T;
}

/// Fronto-parallel square (facing -x) of side `side_m` centred at `centre` with a texture.
TexturedMesh frontoParallelSquare(const Eigen::Vector3d& centre, double side_m, ImageU8 texture) {
  TexturedMesh m;
  m.texture = std::move(texture);
  Facet f;
  // u along world -y (image right), v along world -z (image down): texture rows map to image rows.
  f.p0 = centre + Eigen::Vector3d(0, 0.5 * side_m, 0.5 * side_m);
  f.e1 = Eigen::Vector3d(0, -side_m, 0);
  f.e2 = Eigen::Vector3d(0, 0, -side_m);
  m.facets.push_back(f);
  return m;
}

/// Radially symmetric blob that fades to 0 well inside the texture, so its intensity
/// centroid is its centre.
ImageU8 gaussianBlobTexture(int size) {
  ImageU8 t(size, size);
  const double c = 0.5 * (size - 1), sigma = size / 7.0;
  for (int v = 0; v < size; ++v)
    for (int u = 0; u < size; ++u) {
      const double r2 = (u - c) * (u - c) + (v - c) * (v - c);
      t(u, v) = static_cast<uint8_t>(std::lround(250.0 * std::exp(-0.5 * r2 / (sigma * sigma))));
    }
  return t;
}

ImageU8 solidTexture(uint8_t grey) { return ImageU8(4, 4, grey); }

/// Intensity-weighted centroid of the pixels in a window around (u0, v0).
Eigen::Vector2d centroid(const ImageU8& img, double u0, double v0, int radius) {
  double su = 0, sv = 0, sw = 0;
  for (int v = static_cast<int>(v0) - radius; v <= static_cast<int>(v0) + radius; ++v)
    for (int u = static_cast<int>(u0) - radius; u <= static_cast<int>(u0) + radius; ++u) {
      if (u < 0 || v < 0 || u >= img.width || v >= img.height) continue;
      const double w = img(u, v);
      su += w * u;
      sv += w * v;
      sw += w;
    }
  return Eigen::Vector2d(su / sw, sv / sw);
}

std::unique_ptr<StereoRenderer> makeRenderer(const World& world, std::vector<TexturedMesh> meshes) {
  std::unique_ptr<StereoRenderer> r;
  const Status st = StereoRenderer::create(world, std::move(meshes), RendererOptions{}, &r);
  EXPECT_TRUE(st.isOk()) << st.message();
  return r;
}

TEST(StereoRenderer, ProjectsTargetsAtPinholeProjection) {
  const World world = makeWorld();
  const Eigen::Isometry3d T_w_c = cameraLookingAlongX(Eigen::Vector3d(0, 0, 1));
  // Targets at several depths and image positions (world points, camera at z = 1).
  const std::vector<Eigen::Vector3d> centres = {
      {1.0, 0.13, 1.07}, {2.0, -0.41, 0.8}, {3.5, -0.9, 1.45}, {1.5, -0.05, 0.93}, {6.0, 1.7, 0.2}};
  std::vector<TexturedMesh> meshes;
  for (const auto& c : centres)
    meshes.push_back(frontoParallelSquare(c, 0.06 * c.x(), gaussianBlobTexture(128)));
  auto renderer = makeRenderer(world, std::move(meshes));
  ASSERT_TRUE(renderer);
  ImageU8 left, right;
  ImageF32 depth;
  renderer->render(T_w_c, &left, &right, &depth);
  const Eigen::Isometry3d T_c_w = T_w_c.inverse();
  for (const auto& c : centres) {
    Eigen::Vector2d uv;
    ASSERT_TRUE(projectLeft(world.rig, T_c_w * c, &uv));
    const Eigen::Vector2d got = centroid(left, uv.x(), uv.y(), 20);
    if (std::getenv("TWOCAM_TEST_VERBOSE"))
      std::printf("target %.2f: left err %.3f %.3f\n", c.x(), got.x() - uv.x(), got.y() - uv.y());
    EXPECT_NEAR(got.x(), uv.x(), kProjectionTolPx) << "target at " << c.transpose();
    EXPECT_NEAR(got.y(), uv.y(), kProjectionTolPx) << "target at " << c.transpose();
    // The right view sees it shifted by the disparity fx * B / Z along the row.
    const double z = (T_c_w * c).z();
    const double d = world.rig.fx_px * world.rig.baseline_m / z;
    const Eigen::Vector2d got_r = centroid(right, uv.x() - d, uv.y(), 20);
    if (std::getenv("TWOCAM_TEST_VERBOSE"))
      std::printf(
          "target %.2f: right err %.3f %.3f\n", c.x(), got_r.x() - uv.x() + d, got_r.y() - uv.y());
    EXPECT_NEAR(got_r.x(), uv.x() - d, kProjectionTolPx) << "target at " << c.transpose();
    EXPECT_NEAR(got_r.y(), uv.y(), kProjectionTolPx) << "target at " << c.transpose();
  }
}

TEST(StereoRenderer, ProjectsTargetsForAPitchedAndYawedCamera) {
  const World world = makeWorld();
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
  T_w_c.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).matrix() *
                   opticalRotationFromYawPitch(0.0, 0.3);
  T_w_c.translation() = Eigen::Vector3d(0.4, -0.3, 0.5);
  // Targets fronto-parallel to this camera, given in its frame (x right, y down, z forward).
  const std::vector<Eigen::Vector3d> p_c = {{0.2, -0.1, 1.2}, {-0.5, 0.3, 2.5}, {0.9, 0.6, 4.0}};
  std::vector<TexturedMesh> meshes;
  for (const auto& p : p_c) {
    TexturedMesh m;
    m.texture = gaussianBlobTexture(128);
    const double side = 0.06 * p.z();
    Facet f;
    f.p0 = T_w_c * (p - Eigen::Vector3d(0.5 * side, 0.5 * side, 0.0));
    f.e1 = T_w_c.linear() * Eigen::Vector3d(side, 0, 0);
    f.e2 = T_w_c.linear() * Eigen::Vector3d(0, side, 0);
    m.facets.push_back(f);
    meshes.push_back(m);
  }
  auto renderer = makeRenderer(world, std::move(meshes));
  ASSERT_TRUE(renderer);
  ImageU8 left, right;
  ImageF32 depth;
  renderer->render(T_w_c, &left, &right, &depth);
  for (const auto& p : p_c) {
    Eigen::Vector2d uv;
    ASSERT_TRUE(projectLeft(world.rig, p, &uv));
    const Eigen::Vector2d got = centroid(left, uv.x(), uv.y(), 20);
    EXPECT_NEAR(got.x(), uv.x(), kProjectionTolPx) << "target at " << p.transpose();
    EXPECT_NEAR(got.y(), uv.y(), kProjectionTolPx) << "target at " << p.transpose();
    const double d = world.rig.fx_px * world.rig.baseline_m / p.z();
    const Eigen::Vector2d got_r = centroid(right, uv.x() - d, uv.y(), 20);
    EXPECT_NEAR(got_r.x(), uv.x() - d, kProjectionTolPx) << "target at " << p.transpose();
    EXPECT_NEAR(got_r.y(), uv.y(), kProjectionTolPx) << "target at " << p.transpose();
    EXPECT_NEAR(depth(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y()))),
                p.z(),
                kDepthRelTol * p.z());
  }
}

TEST(StereoRenderer, DepthMatchesAnalyticDepthOfKnownSurfaces) {
  const World world = makeWorld();
  const Eigen::Isometry3d T_w_c = cameraLookingAlongX(Eigen::Vector3d(0, 0, 1));
  std::vector<TexturedMesh> meshes;
  // A fronto-parallel wall at 2 m (the clip-range trap distance), a slanted plane, a far wall.
  meshes.push_back(frontoParallelSquare({2.0, 0.6, 1.0}, 0.8, solidTexture(200)));
  TexturedMesh slanted;
  slanted.texture = solidTexture(120);
  Facet f;
  f.p0 = Eigen::Vector3d(1.2, -0.2, 0.2);
  f.e1 = Eigen::Vector3d(1.5, -1.0, 0.0);
  f.e2 = Eigen::Vector3d(0.3, 0.0, 1.4);
  slanted.facets.push_back(f);
  meshes.push_back(slanted);
  meshes.push_back(frontoParallelSquare({20.0, 0.0, 1.0}, 30.0, solidTexture(60)));
  auto renderer = makeRenderer(world, std::move(meshes));
  ASSERT_TRUE(renderer);
  ImageU8 left, right;
  ImageF32 depth;
  RenderStats stats;
  renderer->render(T_w_c, &left, &right, &depth, &stats);
  int checked = 0, on_front_wall = 0;
  for (int v = 0; v < depth.height; v += 3) {
    for (int u = 0; u < depth.width; u += 3) {
      const double expected = analyticDepth(renderer->facets(), world.rig, T_w_c, u, v);
      if (expected <= 0.0 || depth(u, v) <= 0.0f) continue;
      EXPECT_NEAR(depth(u, v), expected, kDepthRelTol * expected) << "pixel " << u << "," << v;
      if (std::abs(expected - 2.0) < 1e-9) {
        ++on_front_wall;
        EXPECT_NEAR(depth(u, v), 2.0, kDepthRelTol * 2.0);
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 10000);
  EXPECT_GT(on_front_wall, 500);
  const int rendered = stats.pixels_coherent + stats.pixels_searched + stats.pixels_unresolved;
  EXPECT_GE(static_cast<double>(stats.pixels_coherent + stats.pixels_searched) / rendered,
            kMinResolvedFraction);
}

TEST(StereoRenderer, SameInputSameImages) {
  const World world = makeWorld();
  std::vector<TexturedMesh> meshes;
  meshes.push_back(frontoParallelSquare({2.0, 0.0, 1.0}, 2.0, gaussianBlobTexture(64)));
  auto renderer = makeRenderer(world, meshes);
  ASSERT_TRUE(renderer);
  ImageU8 l1, r1, l2, r2;
  ImageF32 d1, d2;
  const Eigen::Isometry3d T = cameraLookingAlongX(Eigen::Vector3d(0.1, 0.05, 1.0));
  renderer->render(T, &l1, &r1, &d1);
  renderer->render(T, &l2, &r2, &d2);
  EXPECT_EQ(l1.data, l2.data);
  EXPECT_EQ(r1.data, r2.data);
  EXPECT_EQ(d1.data, d2.data);
}

// MRPT keeps a depth table for every distinct clip pair for the life of the process (about
// 1 MB each): a camera moving inside the world must render with one far clip, or a long
// simulation grows by that much per frame.
TEST(StereoRenderer, FarClipStaysConstantInsideTheWorld) {
  const World world = makeWorld();
  std::vector<TexturedMesh> meshes;
  meshes.push_back(frontoParallelSquare({2.0, 0.0, 1.0}, 2.0, gaussianBlobTexture(64)));
  auto renderer = makeRenderer(world, meshes);
  ASSERT_TRUE(renderer);
  ImageU8 l, r;
  ImageF32 d;
  RenderStats stats;
  double first = -1.0;
  for (int k = 0; k < 6; ++k) {
    const Eigen::Vector3d p(-20.0 + 8.0 * k, 3.0 * (k % 3) - 3.0, 1.0);
    renderer->render(cameraLookingAlongX(p), &l, &r, &d, &stats);
    // Beyond the farthest corner of the world's box (60 m x 60 m plane) from any camera in it.
    EXPECT_GT(stats.far_clip_m, std::hypot(60.0, 60.0) * 0.5);
    if (k == 0) first = stats.far_clip_m;
    EXPECT_EQ(stats.far_clip_m, first) << "camera at " << p.transpose();
  }
  // Far outside the box the clip grows to cover the world.
  renderer->render(cameraLookingAlongX(Eigen::Vector3d(-200.0, 0.0, 1.0)), &l, &r, &d, &stats);
  EXPECT_GT(stats.far_clip_m, 230.0);
}

TEST(Surfaces, RayHitsParallelogramAndTriangleInsideOnly) {
  Facet f;
  f.p0 = Eigen::Vector3d(2, -1, -1);
  f.e1 = Eigen::Vector3d(0, 2, 0);
  f.e2 = Eigen::Vector3d(0, 0, 2);
  constexpr double kTol = 1e-12;
  EXPECT_NEAR(intersectFacet(f, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0, 0)), 2.0, kTol);
  EXPECT_NEAR(intersectFacet(f, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0.4, 0.4)), 2.0, kTol);
  EXPECT_LT(intersectFacet(f, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0.6, 0)), 0.0);
  EXPECT_LT(intersectFacet(f, Eigen::Vector3d::Zero(), Eigen::Vector3d(-1, 0, 0)), 0.0);
  f.triangle = true;
  EXPECT_NEAR(
      intersectFacet(f, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, -0.4, -0.4)), 2.0, kTol);
  EXPECT_LT(intersectFacet(f, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0.4, 0.4)), 0.0);
}

TEST(Surfaces, CylinderSegmentsBounded) {
  EXPECT_EQ(cylinderSegments(0.01), 24);
  EXPECT_EQ(cylinderSegments(10.0), 96);
  EXPECT_GT(cylinderSegments(0.3), 24);
}

}  // namespace
}  // namespace twocam::sim
