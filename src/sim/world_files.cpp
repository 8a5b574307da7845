#include "sim/world_files.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <vector>

namespace twocam::sim {

namespace fs = std::filesystem;

std::string worldSidecarPath(const std::string& log_path) {
  const fs::path p(log_path);
  return ((p.has_parent_path() ? p.parent_path() : fs::path(".")) /
          (p.stem().string() + ".world.yaml"))
      .string();
}

/// Top-down outline of every shape as polylines (x, y) for the trajectory plot: vertical
/// planes as segments, horizontal planes and boxes as rectangles, cylinders as polygons.
std::string worldOutlineCsv(const World& world) {
  std::ostringstream os;
  os << "shape,name,kind,x_m,y_m\n";
  auto emit = [&](size_t i, const std::string& kind, const std::vector<Eigen::Vector3d>& pts) {
    for (const auto& p : pts)
      os << i << "," << world.shapes[i].name << "," << kind << "," << p.x() << "," << p.y() << "\n";
  };
  for (size_t i = 0; i < world.shapes.size(); ++i) {
    const Shape& s = world.shapes[i];
    const Eigen::Isometry3d& T = s.T_w_s;
    switch (s.kind) {
      case ShapeKind::kPlane: {
        const double hx = 0.5 * s.size_m.x(), hy = 0.5 * s.size_m.y();
        const bool horizontal = std::abs(T.linear().col(2).z()) > 0.9;
        std::vector<Eigen::Vector3d> c = {T * Eigen::Vector3d(-hx, -hy, 0),
                                          T * Eigen::Vector3d(hx, -hy, 0),
                                          T * Eigen::Vector3d(hx, hy, 0),
                                          T * Eigen::Vector3d(-hx, hy, 0)};
        if (horizontal) {
          c.push_back(c.front());
          emit(i, "floor", c);
        } else {
          // Wall parts that do not reach down to the robot (lintels above doors) are drawn apart.
          double min_z = c[0].z();
          for (const auto& p : c) min_z = std::min(min_z, p.z());
          emit(i, min_z > 1.0 ? "overhead" : "wall", {c[0], c[1], c[2], c[3], c[0]});
        }
        break;
      }
      case ShapeKind::kBox: {
        const Eigen::Vector3d h = 0.5 * s.size_m;
        emit(i,
             "box",
             {T * Eigen::Vector3d(-h.x(), -h.y(), 0),
              T * Eigen::Vector3d(h.x(), -h.y(), 0),
              T * Eigen::Vector3d(h.x(), h.y(), 0),
              T * Eigen::Vector3d(-h.x(), h.y(), 0),
              T * Eigen::Vector3d(-h.x(), -h.y(), 0)});
        break;
      }
      case ShapeKind::kCylinder: {
        std::vector<Eigen::Vector3d> c;
        for (int k = 0; k <= 24; ++k) {
          const double a = 2.0 * M_PI * k / 24;
          c.push_back(T *
                      Eigen::Vector3d(s.size_m.x() * std::cos(a), s.size_m.x() * std::sin(a), 0));
        }
        emit(i, "cylinder", c);
        break;
      }
    }
  }
  return os.str();
}

}  // namespace twocam::sim
