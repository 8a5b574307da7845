#include "sim/world.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "sim/texture.h"

namespace twocam::sim {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
/// Highest frame rate accepted [Hz]; above it the time stamps (ns) and the motion substeps
/// stop being meaningful for a wheeled robot.
constexpr double kMaxFrameRateHz = 1000.0;
constexpr double kMaxGrey = 255.0;

std::string indexed(const std::string& list, size_t i) {
  return list + "[" + std::to_string(i) + "]";
}

/// Checks values one after another and keeps the first failure. Messages name the key as it
/// is written in the world file, with the value in the file's units:
/// "rig.baseline_m = -0.1: must be > 0".
class Checker {
 public:
  void positive(const std::string& key, double v) {
    if (!(std::isfinite(v) && v > 0.0)) fail(key, v, "must be > 0");
  }
  void nonNegative(const std::string& key, double v) {
    if (!(std::isfinite(v) && v >= 0.0)) fail(key, v, "must be >= 0");
  }
  void finite(const std::string& key, double v) {
    if (!std::isfinite(v)) fail(key, v, "must be a finite number");
  }
  void greaterThan(const std::string& key, double v, double lo) {
    if (!(std::isfinite(v) && v > lo)) fail(key, v, "must be > " + str(lo));
  }
  /// lo <= v <= hi.
  void closed(const std::string& key, double v, double lo, double hi) {
    if (!(std::isfinite(v) && v >= lo && v <= hi)) {
      fail(key, v, "must be in [" + str(lo) + ", " + str(hi) + "]");
    }
  }
  /// lo < v < hi.
  void open(const std::string& key, double v, double lo, double hi) {
    if (!(std::isfinite(v) && v > lo && v < hi)) {
      fail(key, v, "must be in (" + str(lo) + ", " + str(hi) + ")");
    }
  }
  /// lo < v <= hi.
  void openClosed(const std::string& key, double v, double lo, double hi) {
    if (!(std::isfinite(v) && v > lo && v <= hi)) {
      fail(key, v, "must be in (" + str(lo) + ", " + str(hi) + "]");
    }
  }
  void require(bool ok, const std::string& message) {
    if (!ok && !error_) error_ = message;
  }

  [[nodiscard]] bool failed() const { return error_.has_value(); }
  [[nodiscard]] Status status() const { return error_ ? Status::error(*error_) : Status::ok(); }

  static std::string str(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  }

 private:
  void fail(const std::string& key, double v, const std::string& why) {
    if (!error_) error_ = key + " = " + str(v) + ": " + why;
  }
  std::optional<std::string> error_;
};

void checkRig(const StereoRig& rig, Checker* c) {
  c->require(rig.width_px >= 16 && rig.width_px <= kMaxRigSidePx,
             "rig.width_px = " + std::to_string(rig.width_px) + ": must be in [16, " +
                 std::to_string(kMaxRigSidePx) + "]");
  c->require(rig.height_px >= 16 && rig.height_px <= kMaxRigSidePx,
             "rig.height_px = " + std::to_string(rig.height_px) + ": must be in [16, " +
                 std::to_string(kMaxRigSidePx) + "]");
  c->positive("rig.fx_px", rig.fx_px);
  c->positive("rig.fy_px", rig.fy_px);
  c->finite("rig.cx_px", rig.cx_px);
  c->finite("rig.cy_px", rig.cy_px);
  c->positive("rig.baseline_m", rig.baseline_m);
  c->require(rig.T_b_cl.matrix().allFinite(), "rig.mount: pose is not finite");
  const Eigen::Vector3d& t = rig.T_b_cl.translation();
  c->closed("rig.mount.x_m", t.x(), -kMaxMountOffsetM, kMaxMountOffsetM);
  c->closed("rig.mount.y_m", t.y(), -kMaxMountOffsetM, kMaxMountOffsetM);
  c->closed("rig.mount.height_m", t.z(), -kMaxMountOffsetM, kMaxMountOffsetM);
  if (c->failed()) return;
  // Backstop for constraints the rig itself adds later.
  if (const Status s = rig.validate(); !s) c->require(false, s.message());
}

void checkRobot(const RobotSpec& robot, Checker* c) {
  c->positive("robot.speed_mps", robot.speed_mps);
  c->positive("robot.max_yaw_rate_dps", robot.max_yaw_rate_rps * kRadToDeg);
  c->positive("robot.waypoint_radius_m", robot.waypoint_radius_m);
  c->openClosed("robot.frame_rate_hz", robot.frame_rate_hz, 0.0, kMaxFrameRateHz);
  c->positive("robot.wheel_base_m", robot.wheel_base_m);
  c->require(
      robot.waypoints.size() >= 2,
      "robot.waypoints: need at least 2 waypoints, got " + std::to_string(robot.waypoints.size()));
  for (size_t i = 0; i < robot.waypoints.size(); ++i) {
    const Eigen::Vector2d& p = robot.waypoints[i];
    c->require(p.allFinite(), indexed("robot.waypoints", i) + " is not finite");
    if (i > 0) {
      c->require(p != robot.waypoints[i - 1],
                 indexed("robot.waypoints", i) + " repeats the waypoint before it");
    }
  }
  if (robot.waypoints.size() >= 2) {
    const Status s = startWaypointStatus(robot, robot.start_waypoint);
    c->require(s.isOk(), "robot.start_waypoint " + s.message());
  }
}

void checkOdometryNoise(const OdometryNoiseSpec& odo, Checker* c) {
  c->nonNegative("odometry_noise.sigma_per_m", odo.sigma_per_m);
  c->nonNegative("odometry_noise.sigma_per_rad", odo.sigma_per_rad);
  // Both factors divide or scale a motion; -1 would report no motion at all.
  c->greaterThan("odometry_noise.scale_error", odo.scale_error, -1.0);
  c->greaterThan("odometry_noise.wheel_base_error", odo.wheel_base_error, -1.0);
  for (size_t i = 0; i < odo.slips.size(); ++i) {
    const std::string key = indexed("odometry_noise.slips", i);
    const SlipEvent& slip = odo.slips[i];
    c->nonNegative(key + ".time_s", slip.time_s);
    c->finite(key + ".dx_m", slip.dx_m);
    c->finite(key + ".dy_m", slip.dy_m);
    c->finite(key + ".dyaw_deg", slip.dyaw_rad * kRadToDeg);
  }
}

void checkNoise(const ImageNoiseSpec& image, const OdometryNoiseSpec& odo, Checker* c) {
  c->nonNegative("image_noise.sigma_grey", image.sigma_grey);
  c->positive("image_noise.left.gain", image.left.gain);
  c->finite("image_noise.left.offset_grey", image.left.offset_grey);
  c->positive("image_noise.right.gain", image.right.gain);
  c->finite("image_noise.right.offset_grey", image.right.offset_grey);
  checkOdometryNoise(odo, c);
}

void checkTexture(const TextureSpec& t, const std::string& key, Checker* c) {
  c->positive(key + ".scale_m", t.scale_m);
  c->closed(key + ".grey_low", t.grey_low, 0.0, kMaxGrey);
  c->closed(key + ".grey_high", t.grey_high, 0.0, kMaxGrey);
  if (!c->failed()) {
    c->require(t.grey_low <= t.grey_high,
               key + ": grey_low = " + Checker::str(t.grey_low) +
                   " exceeds grey_high = " + Checker::str(t.grey_high));
  }
  c->open(key + ".duty", t.duty, 0.0, 1.0);
  c->positive(key + ".brick_height_m", t.brick_height_m);
  c->nonNegative(key + ".mortar_m", t.mortar_m);
  if (t.kind == TextureKind::kBricks && !c->failed()) {
    c->require(t.mortar_m < t.brick_height_m && t.mortar_m < t.scale_m,
               key + ".mortar_m = " + Checker::str(t.mortar_m) +
                   ": must be smaller than brick_height_m and scale_m");
  }
  c->positive(key + ".texels_per_m", t.texels_per_m);
  if (t.kind == TextureKind::kImage) {
    c->require(!t.file.empty(), key + ".file: an image texture needs a file");
  }
}

void checkShape(const Shape& shape, size_t i, Checker* c) {
  const std::string key = indexed("shapes", i);
  const std::string who = " (shape '" + shape.name + "')";
  c->require(shape.T_w_s.matrix().allFinite(), key + ": pose is not finite" + who);
  const Eigen::Vector3d& s = shape.size_m;
  const auto positive = [&](const std::string& sub, double v) {
    c->require(std::isfinite(v) && v > 0.0,
               key + "." + sub + " = " + Checker::str(v) + ": must be > 0" + who);
  };
  switch (shape.kind) {
    case ShapeKind::kPlane:
      positive("size_m[0]", s.x());
      positive("size_m[1]", s.y());
      break;
    case ShapeKind::kBox:
      positive("size_m[0]", s.x());
      positive("size_m[1]", s.y());
      positive("size_m[2]", s.z());
      break;
    case ShapeKind::kCylinder:
      positive("radius_m", s.x());
      positive("height_m", s.z());
      break;
  }
  checkTexture(shape.texture, key + ".texture", c);
}

}  // namespace

namespace {
int nextPow2(long x) {
  int p = 1;
  while (p < x && p < (1 << 30)) p <<= 1;
  return p;
}
/// Texels of one face's texture as the renderer holds it: the rasterised grid
/// (texture.cpp's makeGrid) padded to power-of-two sides (renderer.cpp).
double faceTexels(const TextureSpec& t, double width_m, double height_m) {
  if (!(width_m > 0.0) || !(height_m > 0.0) || !(t.texels_per_m > 0.0)) return 0.0;
  const double tpm = std::min(t.texels_per_m, kMaxTextureSidePx / std::max(width_m, height_m));
  const auto side = [tpm](double len_m) {
    return nextPow2(std::clamp(std::lround(len_m * tpm), 2L, long{kMaxTextureSidePx}));
  };
  return static_cast<double>(side(width_m)) * side(height_m);
}
}  // namespace

int textureCount(const World& world) {
  int n = 0;
  for (const Shape& s : world.shapes) {
    n += s.kind == ShapeKind::kPlane ? 1 : s.kind == ShapeKind::kBox ? 6 : 3;
  }
  return n;
}

double textureTexels(const World& world) {
  double total = 0.0;
  for (const Shape& s : world.shapes) {
    const Eigen::Vector3d& d = s.size_m;
    switch (s.kind) {
      case ShapeKind::kPlane:
        total += faceTexels(s.texture, d.x(), d.y());
        break;
      case ShapeKind::kBox:
        total += 2.0 * (faceTexels(s.texture, d.y(), d.z()) + faceTexels(s.texture, d.x(), d.z()) +
                        faceTexels(s.texture, d.x(), d.y()));
        break;
      case ShapeKind::kCylinder:
        total += faceTexels(s.texture, 2.0 * M_PI * d.x(), d.z()) +
                 2.0 * faceTexels(s.texture, 2.0 * d.x(), 2.0 * d.x());
        break;
    }
  }
  return total;
}

Status World::validate() const {
  Checker c;
  c.require(frames >= 1, "frames = " + std::to_string(frames) + ": must be >= 1");
  c.closed("background_grey", background_grey, 0.0, kMaxGrey);
  checkRig(rig, &c);
  checkRobot(robot, &c);
  checkNoise(image_noise, odometry_noise, &c);
  c.require(!shapes.empty(), "shapes: the world needs at least one shape");
  c.require(shapes.size() <= kMaxShapes,
            "shapes: " + std::to_string(shapes.size()) + " shapes; at most " +
                std::to_string(kMaxShapes));
  for (size_t i = 0; i < shapes.size() && !c.failed(); ++i) checkShape(shapes[i], i, &c);
  if (!c.failed()) {
    const int textures = textureCount(*this);
    c.require(textures <= kMaxTextures,
              "shapes: " + std::to_string(textures) +
                  " textured surfaces (plane 1, box 6, cylinder 3); the renderer holds at most " +
                  std::to_string(kMaxTextures) + " (MRPT's limit of simultaneous textures)");
  }
  if (!c.failed()) {
    const double texels = textureTexels(*this);
    if (texels > kMaxWorldTexels) {
      std::ostringstream os;
      os << "shapes: the textures need " << texels / (1 << 20) << " M texels; at most "
         << kMaxWorldTexels / (1 << 20)
         << " M (~8 bytes each in the renderer): lower texels_per_m or use fewer or smaller "
            "shapes";
      c.require(false, os.str());
    }
  }
  return c.status();
}

Status startWaypointStatus(const RobotSpec& robot, int start_waypoint) {
  const int n = static_cast<int>(robot.waypoints.size());
  const int last = robot.loop ? n - 1 : n - 2;
  if (start_waypoint >= 0 && start_waypoint <= last) return Status::ok();
  std::string message = std::to_string(start_waypoint) + ": must be in [0, " +
                        std::to_string(std::max(last, 0)) + "]; the path has " + std::to_string(n) +
                        " waypoints";
  if (!robot.loop) message += " and does not loop (loop: false stops at the last one)";
  return Status::error(message);
}

Eigen::AlignedBox3d worldBounds(const World& world) {
  Eigen::AlignedBox3d box;  // empty
  for (const Shape& shape : world.shapes) {
    const Eigen::Vector3d h = 0.5 * shape.size_m;
    switch (shape.kind) {
      case ShapeKind::kPlane:
        for (const double sx : {-1.0, 1.0}) {
          for (const double sy : {-1.0, 1.0}) {
            box.extend(shape.T_w_s * Eigen::Vector3d(sx * h.x(), sy * h.y(), 0.0));
          }
        }
        break;
      case ShapeKind::kBox:
        for (const double sx : {-1.0, 1.0}) {
          for (const double sy : {-1.0, 1.0}) {
            for (const double sz : {-1.0, 1.0}) {
              box.extend(shape.T_w_s * Eigen::Vector3d(sx * h.x(), sy * h.y(), sz * h.z()));
            }
          }
        }
        break;
      case ShapeKind::kCylinder: {
        // Conservative: the axis end points grown by the radius in every direction.
        const Eigen::Vector3d r = Eigen::Vector3d::Constant(shape.size_m.x());
        for (const double z : {0.0, shape.size_m.z()}) {
          const Eigen::Vector3d p = shape.T_w_s * Eigen::Vector3d(0.0, 0.0, z);
          box.extend(p - r);
          box.extend(p + r);
        }
        break;
      }
    }
  }
  return box;
}

Status OdometryNoiseSpec::validate() const {
  Checker c;
  checkOdometryNoise(*this, &c);
  return c.status();
}

OdometryNoiseSpec scaledOdometryNoise(const OdometryNoiseSpec& spec, double factor) {
  OdometryNoiseSpec out = spec;
  out.sigma_per_m *= factor;
  out.sigma_per_rad *= factor;
  out.scale_error *= factor;
  out.wheel_base_error *= factor;
  for (SlipEvent& slip : out.slips) {
    slip.dx_m *= factor;
    slip.dy_m *= factor;
    slip.dyaw_rad *= factor;
  }
  return out;
}

}  // namespace twocam::sim
