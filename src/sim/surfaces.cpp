#include "sim/surfaces.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/texture.h"

namespace twocam::sim {

namespace {

/// Parallelogram facet covering the rectangle centre c, half-axes hu * u and hv * v, with
/// its texture stretched over it (uv (0,0) at c - hu u - hv v, (1,1) at the opposite corner).
Facet rectangle(const Eigen::Vector3d& c,
                const Eigen::Vector3d& u,
                const Eigen::Vector3d& v,
                double hu,
                double hv) {
  Facet f;
  f.p0 = c - hu * u - hv * v;
  f.e1 = 2.0 * hu * u;
  f.e2 = 2.0 * hv * v;
  f.uv0 = Eigen::Vector2d(0, 0);
  f.uv1 = Eigen::Vector2d(1, 0);
  f.uv2 = Eigen::Vector2d(0, 1);
  return f;
}

Status addTexturedRectangle(const Shape& shape,
                            int shape_index,
                            const Eigen::Vector3d& c,
                            const Eigen::Vector3d& u,
                            const Eigen::Vector3d& v,
                            double width_m,
                            double height_m,
                            std::mt19937_64& rng,
                            std::vector<TexturedMesh>* meshes) {
  TexturedMesh mesh;
  mesh.shape_index = shape_index;
  Status st = rasterizeTexture(shape.texture, width_m, height_m, rng, &mesh.texture);
  if (!st) return Status::error("shape '" + shape.name + "': " + st.message());
  mesh.facets.push_back(rectangle(c, u, v, 0.5 * width_m, 0.5 * height_m));
  meshes->push_back(std::move(mesh));
  return Status::ok();
}

}  // namespace

int cylinderSegments(double radius_m) {
  constexpr double kSideLengthM = 0.04;
  const int n = static_cast<int>(std::ceil(2.0 * M_PI * radius_m / kSideLengthM));
  return std::clamp(n, 24, 96);
}

Status buildMeshes(const World& world, std::mt19937_64& rng, std::vector<TexturedMesh>* meshes) {
  meshes->clear();
  for (size_t i = 0; i < world.shapes.size(); ++i) {
    const Shape& s = world.shapes[i];
    const int idx = static_cast<int>(i);
    const Eigen::Matrix3d R = s.T_w_s.linear();
    const Eigen::Vector3d t = s.T_w_s.translation();
    const Eigen::Vector3d ex = R.col(0), ey = R.col(1), ez = R.col(2);
    Status st;
    switch (s.kind) {
      case ShapeKind::kPlane:
        st = addTexturedRectangle(s, idx, t, ex, ey, s.size_m.x(), s.size_m.y(), rng, meshes);
        break;
      case ShapeKind::kBox: {
        const Eigen::Vector3d h = 0.5 * s.size_m;
        // Each face: centre, in-face axes (u, v) with v pointing up where possible.
        struct Face {
          Eigen::Vector3d c, u, v;
          double w, hgt;
        };
        const Face faces[6] = {
            {t + h.x() * ex, ey, ez, s.size_m.y(), s.size_m.z()},
            {t - h.x() * ex, -ey, ez, s.size_m.y(), s.size_m.z()},
            {t + h.y() * ey, -ex, ez, s.size_m.x(), s.size_m.z()},
            {t - h.y() * ey, ex, ez, s.size_m.x(), s.size_m.z()},
            {t + h.z() * ez, ex, ey, s.size_m.x(), s.size_m.y()},
            {t - h.z() * ez, ex, -ey, s.size_m.x(), s.size_m.y()},
        };
        for (const Face& f : faces) {
          st = addTexturedRectangle(s, idx, f.c, f.u, f.v, f.w, f.hgt, rng, meshes);
          if (!st) break;
        }
        break;
      }
      case ShapeKind::kCylinder: {
        const double r = s.size_m.x();
        const double height = s.size_m.z();
        const int n = cylinderSegments(r);
        TexturedMesh side;
        side.shape_index = idx;
        st = rasterizeTexture(s.texture, 2.0 * M_PI * r, height, rng, &side.texture);
        if (!st) {
          st = Status::error("shape '" + s.name + "': " + st.message());
          break;
        }
        for (int k = 0; k < n; ++k) {
          const double a0 = 2.0 * M_PI * k / n, a1 = 2.0 * M_PI * (k + 1) / n;
          const Eigen::Vector3d q0 = t + r * (std::cos(a0) * ex + std::sin(a0) * ey);
          const Eigen::Vector3d q1 = t + r * (std::cos(a1) * ex + std::sin(a1) * ey);
          Facet f;
          f.p0 = q0;
          f.e1 = q1 - q0;
          f.e2 = height * ez;
          f.uv0 = Eigen::Vector2d(static_cast<double>(k) / n, 0.0);
          f.uv1 = Eigen::Vector2d(static_cast<double>(k + 1) / n, 0.0);
          f.uv2 = Eigen::Vector2d(static_cast<double>(k) / n, 1.0);
          side.facets.push_back(f);
        }
        meshes->push_back(std::move(side));
        // Caps: triangle fans, texture projected from the cap's bounding square.
        for (int cap = 0; cap < 2; ++cap) {
          TexturedMesh m;
          m.shape_index = idx;
          st = rasterizeTexture(s.texture, 2.0 * r, 2.0 * r, rng, &m.texture);
          if (!st) break;
          const Eigen::Vector3d c = t + (cap == 0 ? 0.0 : height) * ez;
          auto uv_of = [&](double x, double y) {
            return Eigen::Vector2d(0.5 + 0.5 * x / r, 0.5 + 0.5 * y / r);
          };
          for (int k = 0; k < n; ++k) {
            const double a0 = 2.0 * M_PI * k / n, a1 = 2.0 * M_PI * (k + 1) / n;
            const double x0 = r * std::cos(a0), y0 = r * std::sin(a0);
            const double x1 = r * std::cos(a1), y1 = r * std::sin(a1);
            Facet f;
            f.triangle = true;
            f.p0 = c;
            f.e1 = x0 * ex + y0 * ey;
            f.e2 = x1 * ex + y1 * ey;
            f.uv0 = uv_of(0, 0);
            f.uv1 = uv_of(x0, y0);
            f.uv2 = uv_of(x1, y1);
            m.facets.push_back(f);
          }
          meshes->push_back(std::move(m));
        }
        if (!st) st = Status::error("shape '" + s.name + "': " + st.message());
        break;
      }
    }
    if (!st) return st;
  }
  return Status::ok();
}

double intersectFacet(const Facet& f, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
  // Moeller-Trumbore style: solve origin + t dir = p0 + a e1 + b e2.
  const Eigen::Vector3d pvec = dir.cross(f.e2);
  const double det = f.e1.dot(pvec);
  if (std::abs(det) < 1e-300) return -1.0;
  const double inv_det = 1.0 / det;
  const Eigen::Vector3d tvec = origin - f.p0;
  const double a = tvec.dot(pvec) * inv_det;
  if (a < 0.0 || a > 1.0) return -1.0;
  const Eigen::Vector3d qvec = tvec.cross(f.e1);
  const double b = dir.dot(qvec) * inv_det;
  if (b < 0.0 || (f.triangle ? a + b > 1.0 : b > 1.0)) return -1.0;
  const double t = f.e2.dot(qvec) * inv_det;
  return t > 0.0 ? t : -1.0;
}

}  // namespace twocam::sim
