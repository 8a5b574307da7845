#pragma once
/// A simulated world: static textured scene, robot path, stereo rig, sensor noise and seed.
/// A world file (worlds/*.yaml, format in worlds/README.md) fully determines a simulation.
/// Frames: world x forward, y left, z up; the robot drives on z = 0 (docs/conventions.md).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.h"
#include "common/status.h"

namespace twocam::sim {

enum class TextureKind {
  kBlobs,     ///< random grey blobs at a chosen feature scale (rich, unique texture)
  kChecker,   ///< checkerboard of squares
  kStripes,   ///< vertical stripes: periodic along the scanline (provokes false matches)
  kBricks,    ///< brick bond: periodic rows of bricks with mortar lines
  kGradient,  ///< smooth linear gradient: nearly textureless
  kSolid,     ///< one grey level: textureless
  kImage,     ///< an image file tiled over the surface
};

/// How a surface looks. Lengths are measured on the surface [m]; grey levels in [0, 255].
struct TextureSpec {
  TextureKind kind = TextureKind::kBlobs;
  /// Feature size: blob diameter, checker square, stripe period, brick length, image tile width
  /// [m].
  double scale_m = 0.08;
  /// Darkest and brightest grey level of the pattern.
  double grey_low = 40.0;
  double grey_high = 220.0;
  /// Stripes: fraction of the period that is dark, in (0, 1).
  double duty = 0.5;
  /// Bricks: brick height [m] (length is scale_m) and mortar line width [m].
  double brick_height_m = 0.07;
  double mortar_m = 0.01;
  /// Gradient: direction along the surface's first axis (true) or second axis (false).
  bool gradient_along_u = true;
  /// Image: path as written in the world file, and the same resolved against the world
  /// file's folder (the loader fills resolved_path).
  std::string file;
  std::string resolved_path;
  /// Texels per metre when the pattern is rasterised for rendering [1/m].
  double texels_per_m = 400.0;
};

enum class ShapeKind { kPlane, kBox, kCylinder };

/// One static object. Every shape has a local frame s placed in the world by T_w_s.
/// - kPlane: rectangle in the local x-y plane centred at the origin, size_m.x() by size_m.y(),
///   visible from both sides.
/// - kBox: box centred at the origin with edge lengths size_m (x, y, z).
/// - kCylinder: axis along local z from z = 0 to z = size_m.z() (height), radius size_m.x().
struct Shape {
  ShapeKind kind = ShapeKind::kPlane;
  std::string name;
  Eigen::Isometry3d T_w_s = Eigen::Isometry3d::Identity();
  Eigen::Vector3d size_m = Eigen::Vector3d::Ones();
  TextureSpec texture;
};

/// Differential-drive robot following waypoints on the floor with smooth turns.
struct RobotSpec {
  /// Waypoints (x, y) [m]; the robot starts at waypoints[start_waypoint], heading for the next.
  std::vector<Eigen::Vector2d> waypoints;
  /// Index of the waypoint the robot starts at, heading for the one after it (`twocam simulate
  /// --start-waypoint`). 0 (the first) by default. A looping path wraps round past the last
  /// waypoint to the first; a non-looping one still stops at its last waypoint, so there it must
  /// be below the last index (see startWaypointStatus()).
  int start_waypoint = 0;
  /// Cruise speed [m/s].
  double speed_mps = 0.4;
  /// Largest yaw rate [rad/s]; bounds how sharp turns are.
  double max_yaw_rate_rps = 0.6;
  /// Distance at which a waypoint counts as reached and the next one is steered for [m].
  double waypoint_radius_m = 0.4;
  /// Start again at the first waypoint after the last one (true) or stop there (false).
  bool loop = true;
  /// Camera and odometry rate [Hz].
  double frame_rate_hz = 15.0;
  /// Distance between the wheels [m] (wheel odometry model).
  double wheel_base_m = 0.35;
};

/// Image formation noise. Observed grey = gain * rendered + offset + N(0, sigma^2), clamped.
struct CameraRadiometry {
  double gain = 1.0;
  double offset_grey = 0.0;
};
struct ImageNoiseSpec {
  /// Standard deviation of additive Gaussian noise [grey levels].
  double sigma_grey = 2.0;
  CameraRadiometry left;
  CameraRadiometry right;
};

/// A slip: the wheels report a displacement the body did not make (wheel spin), expressed
/// in the body frame at the time of the event.
struct SlipEvent {
  double time_s = 0.0;
  double dx_m = 0.0;
  double dy_m = 0.0;
  double dyaw_rad = 0.0;
};

/// Wheel odometry error model (see docs/simulator.md):
/// - random walk: the travelled distance error has variance sigma_per_m^2 per metre travelled,
///   the heading error has variance sigma_per_rad^2 per radian turned;
/// - systematic: reported distance = (1 + scale_error) * true distance; the odometry assumes a
///   wheel base of (1 + wheel_base_error) * true, so reported turns = true / (1 +
///   wheel_base_error);
/// - slip events.
struct OdometryNoiseSpec {
  double sigma_per_m = 0.02;      ///< [m / sqrt(m)]
  double sigma_per_rad = 0.02;    ///< [rad / sqrt(rad)]
  double scale_error = 0.0;       ///< [-], e.g. 0.01 = reports 1 % too far
  double wheel_base_error = 0.0;  ///< [-], relative
  std::vector<SlipEvent> slips;

  /// The checks World::validate() makes on its odometry_noise section (sigmas >= 0, scale and
  /// wheel-base errors > -1, slip times >= 0, finite offsets); messages name the key as a world
  /// file writes it ("odometry_noise.sigma_per_m = -1: must be >= 0").
  [[nodiscard]] Status validate() const;
};

/// The noise model with every error multiplied by `factor` >= 0: the random-walk sigmas, the
/// scale and wheel-base errors and each slip's offsets (slips stay at their times). 0 gives
/// exact odometry, 1 the model as given, 3 the "three times the world's default" level of the
/// landmark experiments.
[[nodiscard]] OdometryNoiseSpec scaledOdometryNoise(const OdometryNoiseSpec& spec, double factor);

/// The whole simulation.
struct World {
  std::string name;
  /// Seed of every random draw of the simulation (textures, image noise, odometry noise).
  uint64_t seed = 1;
  /// Seed of the procedural textures when set; otherwise `seed` draws them too. Set it to the
  /// world file's seed to simulate the same-looking world with other noise (`twocam simulate
  /// --noise-seed`): a second log of the same place, e.g. for relocalisation.
  std::optional<uint64_t> texture_seed;
  /// Frames simulated when the command line does not say otherwise.
  int frames = 300;
  StereoRig rig;
  RobotSpec robot;
  ImageNoiseSpec image_noise;
  OdometryNoiseSpec odometry_noise;
  std::vector<Shape> shapes;
  /// Background grey level where no surface is hit.
  double background_grey = 128.0;
  /// Folder of the world file, for resolving relative paths.
  std::string base_dir;

  [[nodiscard]] Status validate() const;
};

/// Whether start_waypoint is a valid start of robot's path: in [0, n - 1] for a looping path of
/// n waypoints, in [0, n - 2] for a non-looping one (its last waypoint is where it stops). The
/// error names the value and the number of waypoints, not the key, so that a caller can prefix
/// the option the user typed (World::validate() prefixes robot.start_waypoint).
[[nodiscard]] Status startWaypointStatus(const RobotSpec& robot, int start_waypoint);

/// Axis-aligned bounding box of all shapes in the world frame [m].
Eigen::AlignedBox3d worldBounds(const World& world);

/// Limits World::validate() enforces so that a valid world can be simulated in bounded memory
/// and time (worlds/README.md):
/// Largest image side [px]: the offscreen renderer's framebuffer (EGL/Mesa allow 8192-16384;
/// 4096 leaves room and is 3x the largest shipped rig).
inline constexpr int kMaxRigSidePx = 4096;
/// Largest |x|, |y|, |height| of the camera mount from the body origin [m].
inline constexpr double kMaxMountOffsetM = 10.0;
/// Most shapes in a world (each one is a draw call and a texture).
inline constexpr size_t kMaxShapes = 1000;
/// Most textured surfaces (plane 1, box 6, cylinder 3): MRPT 2.5 holds at most 192 OpenGL
/// textures at once and warns once per surface and frame beyond that.
inline constexpr int kMaxTextures = 192;
/// Textured surfaces of the world's shapes (the quantity kMaxTextures bounds).
int textureCount(const World& world);
/// Most texture texels in a world, counted as the renderer holds them (power-of-two sides),
/// ~8 bytes each across the rasterised, padded and GPU copies: 2^27 texels ~ 1 GiB.
inline constexpr double kMaxWorldTexels = 134217728.0;

/// Texels the world's textures take in the renderer (the quantity kMaxWorldTexels bounds).
double textureTexels(const World& world);

}  // namespace twocam::sim
