#pragma once
/// Headless stereo rendering of a world with MRPT's CFBORender (EGL on Mesa's software
/// renderer: no display, no GPU) and exact ground-truth depth.
///
/// Images: each view is rendered with a pinhole projection equal to the rig's intrinsics
/// (pixel-centre convention); lighting is off, so a pixel's grey is its texture's grey.
/// Depth: the depth buffer of a software renderer is too coarse for ground truth (measured:
/// errors of 0.2 % at 2 m and 2 % at 20 m with a 0.1-50 m clip range), so the rendered depth
/// only tells which facet a pixel sees; the depth stored is the analytic intersection of the
/// pixel's ray with that facet, in double precision (docs/simulator.md, "Ground-truth depth").

#include <Eigen/Geometry>
#include <memory>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "sim/surfaces.h"
#include "sim/world.h"

namespace twocam::sim {

struct RendererOptions {
  /// Near clip distance [m]; surfaces closer than this are not drawn. 0.1 m: the robot never
  /// gets that close to an obstacle, and a larger near plane means finer rendered depth.
  double clip_near_m = 0.1;
  /// Margin added to the world's bounding-box diagonal for the far clip distance [m] (the far
  /// clip grows in steps when the camera leaves the box; renderer.cpp, setCamera).
  double clip_far_margin_m = 1.0;
  [[nodiscard]] Status validate() const;
};

/// Per-frame counters of the depth refinement.
struct RenderStats {
  /// Pixels whose facet was found from a neighbour (fast path) or by searching all facets.
  int pixels_coherent = 0;
  int pixels_searched = 0;
  /// Pixels with rendered depth but no facet within tolerance (set to 0 = no depth).
  int pixels_unresolved = 0;
  double ms_render = 0.0;
  double ms_depth = 0.0;
  /// The far clip distance of this render [m]: constant while the camera stays inside the
  /// world's bounding box (MRPT keeps a table per distinct clip pair for the process's life).
  double far_clip_m = 0.0;
};

/// Owns the EGL context, the scene and the facet list. Not thread-safe; one per thread.
class StereoRenderer {
 public:
  /// Builds the scene from already tessellated meshes. The world's rig gives image size and
  /// intrinsics. Fails when no EGL context can be created.
  static Status create(const World& world,
                       std::vector<TexturedMesh> meshes,
                       const RendererOptions& options,
                       std::unique_ptr<StereoRenderer>* out);
  ~StereoRenderer();
  StereoRenderer(const StereoRenderer&) = delete;
  StereoRenderer& operator=(const StereoRenderer&) = delete;

  /// Renders the left and right views for the left camera pose T_w_cl: noise-free grey
  /// images and the left view's exact depth along the optical axis [m] (0 = no surface).
  void render(const Eigen::Isometry3d& T_w_cl,
              ImageU8* left,
              ImageU8* right,
              ImageF32* depth_left,
              RenderStats* stats = nullptr);

  /// Renders one view only (no depth refinement), e.g. for tests.
  void renderView(const Eigen::Isometry3d& T_w_c, ImageU8* grey, ImageF32* rendered_depth);

  /// All facets, flattened (the geometry ground truth is computed from).
  const std::vector<Facet>& facets() const { return facets_; }

 private:
  struct Impl;
  explicit StereoRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  std::vector<Facet> facets_;
};

/// Exact depth of the first surface hit by the ray through left pixel (u, v), searching all
/// facets (slow; for tests and checks). Returns 0 when nothing is hit.
double analyticDepth(const std::vector<Facet>& facets,
                     const StereoRig& rig,
                     const Eigen::Isometry3d& T_w_c,
                     double u,
                     double v);

}  // namespace twocam::sim
