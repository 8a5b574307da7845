#include "sim/renderer.h"

#include <mrpt/img/CImage.h>
#include <mrpt/img/TCamera.h>
#include <mrpt/math/CMatrixDynamic.h>
#include <mrpt/opengl/CFBORender.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CSetOfTexturedTriangles.h>
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "common/options_check.h"
#include "common/timer.h"
#include "yaml/yaml_text.h"

namespace twocam::sim {

namespace {

int nextPow2(int x) {
  int p = 1;
  while (p < x) p <<= 1;
  return p;
}

/// MRPT texture from a grey texture. Resampled to power-of-two sides so texture coordinates
/// in [0, 1] cover exactly the image (MRPT pads other sizes).
mrpt::img::CImage toMrptTexture(const ImageU8& tex) {
  const cv::Mat grey(tex.height, tex.width, CV_8UC1, const_cast<uint8_t*>(tex.data.data()));
  cv::Mat resized;
  cv::resize(
      grey, resized, cv::Size(nextPow2(tex.width), nextPow2(tex.height)), 0, 0, cv::INTER_LINEAR);
  cv::Mat bgr;
  cv::cvtColor(resized, bgr, cv::COLOR_GRAY2BGR);
  return mrpt::img::CImage(bgr, mrpt::img::DEEP_COPY);
}

mrpt::math::TPoint3Df toF(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

mrpt::opengl::TTriangle makeTriangle(const Eigen::Vector3d& a,
                                     const Eigen::Vector3d& b,
                                     const Eigen::Vector3d& c,
                                     const Eigen::Vector2d& ta,
                                     const Eigen::Vector2d& tb,
                                     const Eigen::Vector2d& tc) {
  mrpt::opengl::TTriangle t(toF(a), toF(b), toF(c));
  const Eigen::Vector2d* uv[3] = {&ta, &tb, &tc};
  for (int i = 0; i < 3; ++i) {
    t.vertices[i].uv =
        mrpt::math::TVector2Df(static_cast<float>(uv[i]->x()), static_cast<float>(uv[i]->y()));
    t.vertices[i].setColor(mrpt::img::TColor(255, 255, 255, 255));
  }
  return t;
}

mrpt::poses::CPose3D toMrptPose(const Eigen::Isometry3d& T) {
  mrpt::math::CMatrixDouble44 M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = T.matrix()(r, c);
  return mrpt::poses::CPose3D(M);
}

}  // namespace

Status RendererOptions::validate() const {
  // Near plane up to 10 m (the shipped rigs see from 0.1 m); far margin up to 1 km.
  if (Status s = checkPositive("renderer clip_near_m", clip_near_m, "m"); !s) return s;
  if (Status s = checkRange("renderer clip_near_m", clip_near_m, 0.0, 10.0, "m"); !s) return s;
  return checkRange("renderer clip_far_margin_m", clip_far_margin_m, 0.0, 1000.0, "m");
}

struct StereoRenderer::Impl {
  StereoRig rig;
  RendererOptions options;
  Eigen::AlignedBox3d bounds;
  std::unique_ptr<mrpt::opengl::CFBORender> fbo;
  mrpt::opengl::COpenGLScene::Ptr scene;
  mrpt::img::CImage rgb;
  /// The far clip distance in use [m] (0: not set yet); see setCamera.
  double far_m = 0.0;
  static constexpr double kFarGrowth = 1.25;
  mrpt::math::CMatrixFloat depth;

  void setCamera(const Eigen::Isometry3d& T_w_c) {
    mrpt::img::TCamera cam;
    cam.ncols = static_cast<uint32_t>(rig.width_px);
    cam.nrows = static_cast<uint32_t>(rig.height_px);
    cam.fx(rig.fx_px);
    cam.fy(rig.fy_px);
    // MRPT's pinhole projection puts the continuous window coordinate cx on the left edge of
    // pixel cx, i.e. half a pixel left of our pixel-centre convention (tested in
    // renderer_test: ProjectsTargetsAtPinholeProjection).
    cam.cx(rig.cx_px + 0.5);
    cam.cy(rig.cy_px + 0.5);
    auto& c = fbo->getCamera(*scene);
    c.setProjectiveFromPinhole(cam);
    c.set6DOFMode(true);
    c.setPose(toMrptPose(T_w_c));
    // Far clip: beyond the world's farthest corner seen from this camera; near from the options.
    // MRPT caches a depth-linearisation table (~1 MB) for every distinct (near, far) pair and
    // never frees it, so the far clip takes few values: the world's diagonal plus the margin
    // (enough from anywhere inside its bounding box), raised by kFarGrowth steps only when the
    // camera is outside it. The depth buffer's precision is set by the near plane (z^2 / near),
    // so a far clip beyond the need costs nothing measurable.
    double need = 0.0;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d corner = bounds.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k));
      need = std::max(need, (corner - T_w_c.translation()).norm());
    }
    need += options.clip_far_margin_m;
    if (far_m <= 0.0)
      far_m =
          std::max(bounds.diagonal().norm() + options.clip_far_margin_m, options.clip_near_m * 2);
    while (far_m < need) far_m *= kFarGrowth;
    scene->getViewport()->setViewportClipDistances(static_cast<float>(options.clip_near_m),
                                                   static_cast<float>(far_m));
  }

  void renderGrey(const Eigen::Isometry3d& T_w_c, ImageU8* grey, bool with_depth) {
    setCamera(T_w_c);
    if (with_depth) {
      fbo->render_RGBD(*scene, rgb, depth);
    } else {
      fbo->render_RGB(*scene, rgb);
    }
    const cv::Mat& m = rgb.asCvMatRef();
    *grey = ImageU8(rig.width_px, rig.height_px);
    cv::Mat out(rig.height_px, rig.width_px, CV_8UC1, grey->data.data());
    if (m.channels() == 3) {
      // Textures are grey and lighting is off, so every channel holds the grey level.
      cv::extractChannel(m, out, 1);
    } else {
      m.copyTo(out);
    }
  }
};

StereoRenderer::StereoRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
StereoRenderer::~StereoRenderer() = default;

Status StereoRenderer::create(const World& world,
                              std::vector<TexturedMesh> meshes,
                              const RendererOptions& options,
                              std::unique_ptr<StereoRenderer>* out) {
  if (Status st = options.validate(); !st) return st;
  if (Status st = world.rig.validate(); !st) return st;
  auto impl = std::make_unique<Impl>();
  impl->rig = world.rig;
  impl->options = options;
  impl->bounds = worldBounds(world);
  try {
    mrpt::opengl::CFBORender::Parameters p(static_cast<unsigned>(world.rig.width_px),
                                           static_cast<unsigned>(world.rig.height_px));
    impl->fbo = std::make_unique<mrpt::opengl::CFBORender>(p);
  } catch (const std::exception& e) {
    // MRPT's exception text holds banners and a call stack: its "Message:" line is the news.
    return Status::error(std::string("cannot create an offscreen EGL rendering context for a ") +
                         std::to_string(world.rig.width_px) + "x" +
                         std::to_string(world.rig.height_px) + " rig: " + yaml::mrptMessage(e));
  }
  impl->scene = mrpt::opengl::COpenGLScene::Create();
  const float bg = static_cast<float>(world.background_grey / 255.0);
  impl->scene->getViewport()->setCustomBackgroundColor(mrpt::img::TColorf(bg, bg, bg, 1.0f));
  std::vector<Facet> all;
  for (TexturedMesh& mesh : meshes) {
    auto obj = mrpt::opengl::CSetOfTexturedTriangles::Create();
    obj->enableLight(false);
    obj->enableTextureLinearInterpolation(true);
    for (const Facet& f : mesh.facets) {
      obj->insertTriangle(makeTriangle(f.p0, f.p0 + f.e1, f.p0 + f.e2, f.uv0, f.uv1, f.uv2));
      if (!f.triangle) {
        const Eigen::Vector2d uv3 = f.uv1 + f.uv2 - f.uv0;
        obj->insertTriangle(
            makeTriangle(f.p0 + f.e1, f.p0 + f.e1 + f.e2, f.p0 + f.e2, f.uv1, uv3, f.uv2));
      }
      all.push_back(f);
    }
    obj->assignImage(toMrptTexture(mesh.texture));
    impl->scene->insert(obj);
  }
  out->reset(new StereoRenderer(std::move(impl)));
  (*out)->facets_ = std::move(all);
  return Status::ok();
}

void StereoRenderer::renderView(const Eigen::Isometry3d& T_w_c,
                                ImageU8* grey,
                                ImageF32* rendered_depth) {
  impl_->renderGrey(T_w_c, grey, rendered_depth != nullptr);
  if (rendered_depth != nullptr) {
    const int w = impl_->rig.width_px, h = impl_->rig.height_px;
    *rendered_depth = ImageF32(w, h);
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) (*rendered_depth)(u, v) = impl_->depth(v, u);
  }
}

namespace {

/// Tolerance between the renderer's depth and a facet's analytic depth when deciding that
/// the pixel sees that facet [m]. The software depth buffer's error grows like z^2 / near
/// (measured 0.47 m at 20 m with near = 0.1 m, i.e. 1.2e-4 z^2 / near); 2.5x margin.
double depthTolerance(double z, double near_m) { return 3.0e-4 * z * z / near_m + 0.005; }

/// A facet in the camera frame, arranged so that for the ray p = z * (xn, yn, 1) the depth is
/// z = d / (n . r) and the facet coordinates are a = z (g1 . r) - c1, b = z (g2 . r) - c2.
struct CameraFacet {
  Eigen::Vector3d n, g1, g2;
  double d = 0.0, c1 = 0.0, c2 = 0.0;
  bool triangle = false;

  explicit CameraFacet(const Facet& f, const Eigen::Isometry3d& T_c_w) {
    const Eigen::Vector3d p0 = T_c_w * f.p0;
    const Eigen::Vector3d e1 = T_c_w.linear() * f.e1, e2 = T_c_w.linear() * f.e2;
    n = e1.cross(e2);
    d = n.dot(p0);
    // Dual basis of (e1, e2) within the plane: g_i . e_j = delta_ij, g_i . n = 0.
    const double inv = 1.0 / n.squaredNorm();
    g1 = e2.cross(n) * inv;
    g2 = n.cross(e1) * inv;
    c1 = g1.dot(p0);
    c2 = g2.dot(p0);
    triangle = f.triangle;
  }

  /// Depth z > 0 at which the ray through normalised coordinates r hits the facet, or -1.
  double depth(const Eigen::Vector3d& r) const {
    const double nr = n.dot(r);
    if (nr == 0.0) return -1.0;
    const double z = d / nr;
    if (!(z > 0.0)) return -1.0;
    const double a = z * g1.dot(r) - c1;
    if (a < 0.0 || a > 1.0) return -1.0;
    const double b = z * g2.dot(r) - c2;
    if (b < 0.0 || (triangle ? a + b > 1.0 : b > 1.0)) return -1.0;
    return z;
  }
};

}  // namespace

void StereoRenderer::render(const Eigen::Isometry3d& T_w_cl,
                            ImageU8* left,
                            ImageU8* right,
                            ImageF32* depth_left,
                            RenderStats* stats) {
  RenderStats local;
  const Timer t0;
  const StereoRig& rig = impl_->rig;
  impl_->renderGrey(T_w_cl * rig.T_cl_cr(), right, false);
  impl_->renderGrey(T_w_cl, left, true);
  local.ms_render = t0.elapsedMs();
  local.far_clip_m = impl_->far_m;

  const Timer t1;
  const int w = rig.width_px, h = rig.height_px;
  *depth_left = ImageF32(w, h);
  const double near_m = impl_->options.clip_near_m;

  // Facets that can be seen at all (some corner in front of the camera), in the camera frame.
  std::vector<CameraFacet> cam;
  const Eigen::Isometry3d T_c_w = T_w_cl.inverse();
  for (size_t i = 0; i < facets_.size(); ++i) {
    const Facet& f = facets_[i];
    const Eigen::Vector3d c[4] = {
        T_c_w * f.p0, T_c_w * (f.p0 + f.e1), T_c_w * (f.p0 + f.e2), T_c_w * (f.p0 + f.e1 + f.e2)};
    const int n = f.triangle ? 3 : 4;
    bool any_front = false;
    for (int k = 0; k < n; ++k) any_front |= c[k].z() > near_m * 0.5;
    if (any_front) cam.emplace_back(f, T_c_w);
  }

  std::vector<int> row_prev(static_cast<size_t>(w), -1), row_cur(static_cast<size_t>(w), -1);
  for (int v = 0; v < h; ++v) {
    const double yn = (v - rig.cy_px) / rig.fy_px;
    int left_facet = -1;
    for (int u = 0; u < w; ++u) {
      row_cur[static_cast<size_t>(u)] = -1;
      const double zr = impl_->depth(v, u);
      if (!(zr > 0.0)) {
        (*depth_left)(u, v) = 0.0f;
        left_facet = -1;
        continue;
      }
      const Eigen::Vector3d r((u - rig.cx_px) / rig.fx_px, yn, 1.0);
      const double tol = depthTolerance(zr, near_m);
      double z = -1.0;
      int found = -1;
      const int candidates[2] = {left_facet, row_prev[static_cast<size_t>(u)]};
      for (int cand : candidates) {
        if (cand < 0) continue;
        const double t = cam[static_cast<size_t>(cand)].depth(r);
        if (t > 0.0 && std::abs(t - zr) <= tol) {
          z = t;
          found = cand;
          break;
        }
      }
      if (found >= 0) {
        ++local.pixels_coherent;
      } else {
        ++local.pixels_searched;
        double best = std::numeric_limits<double>::infinity();
        for (size_t idx = 0; idx < cam.size(); ++idx) {
          const double t = cam[idx].depth(r);
          if (t > 0.0 && std::abs(t - zr) <= tol && t < best) {
            best = t;
            found = static_cast<int>(idx);
          }
        }
        if (found >= 0) z = best;
      }
      if (found < 0) {
        ++local.pixels_unresolved;
        (*depth_left)(u, v) = 0.0f;
      } else {
        (*depth_left)(u, v) = static_cast<float>(z);
      }
      left_facet = found;
      row_cur[static_cast<size_t>(u)] = found;
    }
    std::swap(row_prev, row_cur);
  }
  local.ms_depth = t1.elapsedMs();
  if (stats != nullptr) *stats = local;
}

double analyticDepth(const std::vector<Facet>& facets,
                     const StereoRig& rig,
                     const Eigen::Isometry3d& T_w_c,
                     double u,
                     double v) {
  const Eigen::Vector3d dir =
      T_w_c.linear() *
      Eigen::Vector3d((u - rig.cx_px) / rig.fx_px, (v - rig.cy_px) / rig.fy_px, 1.0);
  double best = std::numeric_limits<double>::infinity();
  for (const Facet& f : facets) {
    const double t = intersectFacet(f, T_w_c.translation(), dir);
    if (t > 0.0) best = std::min(best, t);
  }
  return std::isfinite(best) ? best : 0.0;
}

}  // namespace twocam::sim
