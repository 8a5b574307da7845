#include "sim/world_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "support/test_paths.h"

namespace twocam::sim {
namespace {

namespace fs = std::filesystem;

/// Values read from text and converted once (deg -> rad, products of a few doubles).
constexpr double kConversionTol = 1e-12;
/// Geometry built from rotations and normalised vectors: a few ulps of metre-scale values.
constexpr double kGeometryTol = 1e-9;
constexpr double kDegToRad = M_PI / 180.0;

/// The example of worlds/README.md: every section, every shape type.
const char* const kExampleYaml = R"(
name: office            # optional
seed: 42
frames: 300
background_grey: 128
rig:
  width_px: 640
  height_px: 480
  fx_px: 500
  fy_px: 501
  baseline_m: 0.12
  mount: {x_m: 0.1, y_m: 0.06, height_m: 0.5, pitch_deg: 5, yaw_deg: 0}
robot:
  speed_mps: 0.4
  max_yaw_rate_dps: 35
  waypoint_radius_m: 0.4
  loop: true
  frame_rate_hz: 15
  wheel_base_m: 0.35
  waypoints: [[0, 0], [4, 0], [4, 3]]
image_noise:
  sigma_grey: 2.0
  left: {gain: 1.0, offset_grey: 0}
  right: {gain: 1.04, offset_grey: -6}
odometry_noise:
  sigma_per_m: 0.02
  sigma_per_rad: 0.03
  scale_error: 0.01
  wheel_base_error: -0.005
  slips: [{time_s: 8.0, dx_m: 0.05, dy_m: 0.0, dyaw_deg: 2.0}]
shapes:
  - {type: plane, name: floor, center_m: [5, 0, 0], rpy_deg: [0, 0, 0], size_m: [12, 8], texture: {kind: blobs, scale_m: 0.1}}
  - {type: wall, name: north, from_m: [0, 4], to_m: [10, 4], z0_m: 0.2, height_m: 2.5, texture: {kind: bricks, scale_m: 0.25, brick_height_m: 0.08, mortar_m: 0.012}}
  - {type: box, center_m: [3, 1, 0.4], yaw_deg: 20, size_m: [0.6, 0.5, 0.8], texture: {kind: checker, scale_m: 0.1}}
  - {type: cylinder, base_m: [6, -1, 0], radius_m: 0.2, height_m: 1.5, texture: {kind: stripes, scale_m: 0.05, duty: 0.3}}
  - type: plane
    center_m: [1, 2, 3]
    rpy_deg: [10, 20, 30]
    size_m: [1, 2]
    texture:
      kind: gradient
      gradient_along: v
      grey_low: 10
      grey_high: 20
      texels_per_m: 100
)";

/// kExampleYaml with one piece of text replaced; fails the test if the piece is not there.
std::string exampleWith(const std::string& from, const std::string& to) {
  std::string text = kExampleYaml;
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "fixture lacks '" << from << "'";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// Parses text that must fail and returns the message.
std::string parseError(const std::string& text, const std::string& base_dir = ".") {
  World world;
  const Status s = parseWorld(text, base_dir, &world);
  EXPECT_FALSE(s.isOk()) << "expected an error for:\n" << text;
  return s.message();
}

World parseExample() {
  World world;
  const Status s = parseWorld(kExampleYaml, ".", &world);
  EXPECT_TRUE(s.isOk()) << s.message();
  return world;
}

TEST(WorldIo, ParsesTopLevelAndRig) {
  const World w = parseExample();
  EXPECT_EQ(w.name, "office");
  EXPECT_EQ(w.seed, 42u);
  EXPECT_EQ(w.frames, 300);
  EXPECT_DOUBLE_EQ(w.background_grey, 128.0);
  EXPECT_EQ(w.rig.width_px, 640);
  EXPECT_EQ(w.rig.height_px, 480);
  EXPECT_DOUBLE_EQ(w.rig.fx_px, 500.0);
  EXPECT_DOUBLE_EQ(w.rig.fy_px, 501.0);
  // Absent principal point: the image centre in the pixel-centre convention.
  EXPECT_DOUBLE_EQ(w.rig.cx_px, 0.5 * (640 - 1));
  EXPECT_DOUBLE_EQ(w.rig.cy_px, 0.5 * (480 - 1));
  EXPECT_DOUBLE_EQ(w.rig.baseline_m, 0.12);
}

TEST(WorldIo, ParsesRobotAndNoiseConvertingDegrees) {
  const World w = parseExample();
  EXPECT_DOUBLE_EQ(w.robot.speed_mps, 0.4);
  EXPECT_NEAR(w.robot.max_yaw_rate_rps, 35.0 * kDegToRad, kConversionTol);
  EXPECT_DOUBLE_EQ(w.robot.waypoint_radius_m, 0.4);
  EXPECT_TRUE(w.robot.loop);
  EXPECT_DOUBLE_EQ(w.robot.frame_rate_hz, 15.0);
  EXPECT_DOUBLE_EQ(w.robot.wheel_base_m, 0.35);
  ASSERT_EQ(w.robot.waypoints.size(), 3u);
  EXPECT_EQ(w.robot.waypoints[2], Eigen::Vector2d(4.0, 3.0));

  EXPECT_DOUBLE_EQ(w.image_noise.sigma_grey, 2.0);
  EXPECT_DOUBLE_EQ(w.image_noise.left.gain, 1.0);
  EXPECT_DOUBLE_EQ(w.image_noise.right.gain, 1.04);
  EXPECT_DOUBLE_EQ(w.image_noise.right.offset_grey, -6.0);

  EXPECT_DOUBLE_EQ(w.odometry_noise.sigma_per_m, 0.02);
  EXPECT_DOUBLE_EQ(w.odometry_noise.sigma_per_rad, 0.03);
  EXPECT_DOUBLE_EQ(w.odometry_noise.scale_error, 0.01);
  EXPECT_DOUBLE_EQ(w.odometry_noise.wheel_base_error, -0.005);
  ASSERT_EQ(w.odometry_noise.slips.size(), 1u);
  EXPECT_DOUBLE_EQ(w.odometry_noise.slips[0].time_s, 8.0);
  EXPECT_DOUBLE_EQ(w.odometry_noise.slips[0].dx_m, 0.05);
  EXPECT_NEAR(w.odometry_noise.slips[0].dyaw_rad, 2.0 * kDegToRad, kConversionTol);
}

TEST(WorldIo, MountPutsCameraAtHeightLookingAlongBodyX) {
  const World w = parseExample();
  // Translation is the left camera's position in the body frame.
  EXPECT_TRUE(w.rig.T_b_cl.translation().isApprox(Eigen::Vector3d(0.1, 0.06, 0.5), kGeometryTol));
  // Pitch 5 deg down: the optical axis (camera z) leans from +x_b towards -z_b.
  const Eigen::Vector3d z_b = w.rig.T_b_cl.linear().col(2);
  const double pitch = 5.0 * kDegToRad;
  EXPECT_TRUE(z_b.isApprox(Eigen::Vector3d(std::cos(pitch), 0.0, -std::sin(pitch)), kGeometryTol))
      << z_b.transpose();

  // Zero yaw and pitch: optical z = +x_b, optical x (right) = -y_b, optical y (down) = -z_b.
  World level;
  ASSERT_TRUE(parseWorld(exampleWith("pitch_deg: 5", "pitch_deg: 0"), ".", &level).isOk());
  const Eigen::Matrix3d R_b_cl = level.rig.T_b_cl.linear();
  EXPECT_TRUE(R_b_cl.col(2).isApprox(Eigen::Vector3d::UnitX(), kGeometryTol));
  EXPECT_TRUE(R_b_cl.col(0).isApprox(-Eigen::Vector3d::UnitY(), kGeometryTol));
  EXPECT_TRUE(R_b_cl.col(1).isApprox(-Eigen::Vector3d::UnitZ(), kGeometryTol));
  // A point 2 m ahead of the body at camera height lies on the optical axis at depth 2 - x_m.
  const Eigen::Vector3d p_cl = level.rig.T_b_cl.inverse() * Eigen::Vector3d(2.0, 0.06, 0.5);
  EXPECT_TRUE(p_cl.isApprox(Eigen::Vector3d(0.0, 0.0, 1.9), kGeometryTol)) << p_cl.transpose();
}

TEST(WorldIo, ParsesPlaneWithRollPitchYaw) {
  const World w = parseExample();
  ASSERT_EQ(w.shapes.size(), 5u);
  const Shape& floor = w.shapes[0];
  EXPECT_EQ(floor.kind, ShapeKind::kPlane);
  EXPECT_EQ(floor.name, "floor");
  EXPECT_TRUE(floor.T_w_s.translation().isApprox(Eigen::Vector3d(5, 0, 0), kGeometryTol));
  EXPECT_TRUE(floor.T_w_s.linear().isApprox(Eigen::Matrix3d::Identity(), kGeometryTol));
  EXPECT_DOUBLE_EQ(floor.size_m.x(), 12.0);
  EXPECT_DOUBLE_EQ(floor.size_m.y(), 8.0);
  EXPECT_EQ(floor.texture.kind, TextureKind::kBlobs);
  EXPECT_DOUBLE_EQ(floor.texture.scale_m, 0.1);

  const Shape& tilted = w.shapes[4];
  EXPECT_EQ(tilted.name, "plane4");  // default name: type and index
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(30 * kDegToRad, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(20 * kDegToRad, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(10 * kDegToRad, Eigen::Vector3d::UnitX()))
                                       .matrix();
  EXPECT_TRUE(tilted.T_w_s.linear().isApprox(expected, kGeometryTol));
  EXPECT_EQ(tilted.texture.kind, TextureKind::kGradient);
  EXPECT_FALSE(tilted.texture.gradient_along_u);
  EXPECT_DOUBLE_EQ(tilted.texture.grey_low, 10.0);
  EXPECT_DOUBLE_EQ(tilted.texture.grey_high, 20.0);
  EXPECT_DOUBLE_EQ(tilted.texture.texels_per_m, 100.0);
}

TEST(WorldIo, WallIsAVerticalPlaneThroughItsEndPoints) {
  const World w = parseExample();
  const Shape& wall = w.shapes[1];
  EXPECT_EQ(wall.kind, ShapeKind::kPlane);
  EXPECT_EQ(wall.name, "north");
  EXPECT_DOUBLE_EQ(wall.size_m.x(), 10.0);
  EXPECT_DOUBLE_EQ(wall.size_m.y(), 2.5);
  EXPECT_TRUE(wall.T_w_s.linear().isUnitary(kGeometryTol));
  EXPECT_NEAR(wall.T_w_s.linear().determinant(), 1.0, kGeometryTol);
  // Local y is world up; the normal (local z) is horizontal.
  EXPECT_TRUE(wall.T_w_s.linear().col(1).isApprox(Eigen::Vector3d::UnitZ(), kGeometryTol));
  EXPECT_NEAR(wall.T_w_s.linear().col(2).z(), 0.0, kGeometryTol);
  // The rectangle's corners are from/to at the bottom (z0) and top (z0 + height).
  const Eigen::Vector2d half = 0.5 * wall.size_m.head<2>();
  const auto corner = [&](double sx, double sy) {
    return Eigen::Vector3d(wall.T_w_s * Eigen::Vector3d(sx * half.x(), sy * half.y(), 0.0));
  };
  EXPECT_TRUE(corner(-1, -1).isApprox(Eigen::Vector3d(0, 4, 0.2), kGeometryTol));
  EXPECT_TRUE(corner(1, -1).isApprox(Eigen::Vector3d(10, 4, 0.2), kGeometryTol));
  EXPECT_TRUE(corner(1, 1).isApprox(Eigen::Vector3d(10, 4, 2.7), kGeometryTol));
  EXPECT_EQ(wall.texture.kind, TextureKind::kBricks);
  EXPECT_DOUBLE_EQ(wall.texture.brick_height_m, 0.08);
  EXPECT_DOUBLE_EQ(wall.texture.mortar_m, 0.012);
}

TEST(WorldIo, ParsesBoxAndCylinder) {
  const World w = parseExample();
  const Shape& box = w.shapes[2];
  EXPECT_EQ(box.kind, ShapeKind::kBox);
  EXPECT_EQ(box.name, "box2");
  EXPECT_TRUE(box.T_w_s.translation().isApprox(Eigen::Vector3d(3, 1, 0.4), kGeometryTol));
  const Eigen::Matrix3d yaw20 =
      Eigen::AngleAxisd(20 * kDegToRad, Eigen::Vector3d::UnitZ()).matrix();
  EXPECT_TRUE(box.T_w_s.linear().isApprox(yaw20, kGeometryTol));
  EXPECT_TRUE(box.size_m.isApprox(Eigen::Vector3d(0.6, 0.5, 0.8), kGeometryTol));
  EXPECT_EQ(box.texture.kind, TextureKind::kChecker);

  const Shape& cyl = w.shapes[3];
  EXPECT_EQ(cyl.kind, ShapeKind::kCylinder);
  EXPECT_TRUE(cyl.T_w_s.translation().isApprox(Eigen::Vector3d(6, -1, 0), kGeometryTol));
  EXPECT_TRUE(cyl.T_w_s.linear().isApprox(Eigen::Matrix3d::Identity(), kGeometryTol));
  EXPECT_TRUE(cyl.size_m.isApprox(Eigen::Vector3d(0.2, 0.2, 1.5), kGeometryTol));
  EXPECT_EQ(cyl.texture.kind, TextureKind::kStripes);
  EXPECT_DOUBLE_EQ(cyl.texture.duty, 0.3);
}

TEST(WorldIo, AbsentKeysTakeStructDefaults) {
  World w;
  const Status s = parseWorld(
      "robot: {waypoints: [[0, 0], [1, 0]]}\n"
      "shapes: [{type: box, center_m: [3, 0, 0.5], size_m: [1, 1, 1]}]\n",
      ".",
      &w);
  ASSERT_TRUE(s.isOk()) << s.message();
  const World defaults;
  EXPECT_EQ(w.seed, defaults.seed);
  EXPECT_EQ(w.frames, defaults.frames);
  EXPECT_EQ(w.rig.width_px, defaults.rig.width_px);
  EXPECT_DOUBLE_EQ(w.rig.baseline_m, defaults.rig.baseline_m);
  EXPECT_DOUBLE_EQ(w.robot.speed_mps, defaults.robot.speed_mps);
  EXPECT_DOUBLE_EQ(w.odometry_noise.sigma_per_m, defaults.odometry_noise.sigma_per_m);
  const TextureSpec default_texture;
  EXPECT_EQ(w.shapes[0].texture.kind, default_texture.kind);
  EXPECT_DOUBLE_EQ(w.shapes[0].texture.scale_m, default_texture.scale_m);
  // Without a mount the camera still looks ahead (not along the body's z axis).
  EXPECT_TRUE(w.rig.T_b_cl.linear().col(2).isApprox(Eigen::Vector3d::UnitX(), kGeometryTol));
}

TEST(WorldIo, MalformedYamlIsAParseError) {
  const std::string unclosed = parseError("rig: {width_px: 640\nrobot: [1, 2\n");
  EXPECT_NE(unclosed.find("cannot parse world file"), std::string::npos) << unclosed;
  EXPECT_NE(unclosed.find("line"), std::string::npos) << unclosed;

  const std::string bad_indent = parseError("rig:\n  width_px: 640\n height_px: 480\n");
  EXPECT_NE(bad_indent.find("cannot parse world file"), std::string::npos) << bad_indent;

  const std::string quote = parseError("name: \"office\n");
  EXPECT_NE(quote.find("cannot parse world file"), std::string::npos) << quote;

  const std::string empty = parseError("");
  EXPECT_NE(empty.find("empty"), std::string::npos) << empty;

  const std::string scalar = parseError("just text");
  EXPECT_NE(scalar.find("must be a map"), std::string::npos) << scalar;
}

TEST(WorldIo, UnknownKeysNameTheirPath) {
  const std::string top = parseError(exampleWith("background_grey:", "backgroud_grey:"));
  EXPECT_NE(top.find("unknown key 'backgroud_grey'"), std::string::npos) << top;
  EXPECT_NE(top.find("did you mean 'background_grey'"), std::string::npos) << top;

  const std::string rig = parseError(exampleWith("baseline_m: 0.12", "basline_m: 0.12"));
  EXPECT_NE(rig.find("unknown key 'rig.basline_m'"), std::string::npos) << rig;
  EXPECT_NE(rig.find("did you mean 'rig.baseline_m'"), std::string::npos) << rig;

  const std::string mount = parseError(exampleWith("pitch_deg: 5", "pitch: 5"));
  EXPECT_NE(mount.find("unknown key 'rig.mount.pitch'"), std::string::npos) << mount;

  const std::string texture = parseError(exampleWith("duty: 0.3", "dutty: 0.3"));
  EXPECT_NE(texture.find("unknown key 'shapes[3].texture.dutty'"), std::string::npos) << texture;

  // A key valid for another shape type is still unknown here.
  const std::string cyl = parseError(exampleWith("radius_m: 0.2", "radius_m: 0.2, yaw_deg: 3"));
  EXPECT_NE(cyl.find("unknown key 'shapes[3].yaw_deg'"), std::string::npos) << cyl;

  const std::string slip = parseError(exampleWith("dyaw_deg: 2.0", "dyaw_rad: 2.0"));
  EXPECT_NE(slip.find("unknown key 'odometry_noise.slips[0].dyaw_rad'"), std::string::npos) << slip;
}

TEST(WorldIo, WrongTypesNameTheKey) {
  const std::string number = parseError(exampleWith("baseline_m: 0.12", "baseline_m: wide"));
  EXPECT_NE(number.find("rig.baseline_m = 'wide': must be a number"), std::string::npos) << number;

  const std::string integer = parseError(exampleWith("frames: 300", "frames: 30.5"));
  EXPECT_NE(integer.find("frames = '30.5': must be an integer"), std::string::npos) << integer;

  const std::string boolean = parseError(exampleWith("loop: true", "loop: sometimes"));
  EXPECT_NE(boolean.find("robot.loop"), std::string::npos) << boolean;

  const std::string map = parseError(exampleWith("left: {gain: 1.0, offset_grey: 0}", "left: 3"));
  EXPECT_NE(map.find("image_noise.left = '3': must be a map"), std::string::npos) << map;

  const std::string vec = parseError(exampleWith("size_m: [12, 8]", "size_m: [12, 8, 1]"));
  EXPECT_NE(vec.find("shapes[0].size_m: must be a sequence of 2 numbers"), std::string::npos)
      << vec;

  const std::string waypoint = parseError(exampleWith("[4, 3]", "[4, x]"));
  EXPECT_NE(waypoint.find("robot.waypoints[2][1] = 'x'"), std::string::npos) << waypoint;

  const std::string kind = parseError(exampleWith("kind: checker", "kind: plaid"));
  EXPECT_NE(kind.find("shapes[2].texture.kind = 'plaid'"), std::string::npos) << kind;

  const std::string type = parseError(exampleWith("type: box", "type: sphere"));
  EXPECT_NE(type.find("shapes[2].type = 'sphere'"), std::string::npos) << type;

  const std::string seed = parseError(exampleWith("seed: 42", "seed: -42"));
  EXPECT_NE(seed.find("seed = '-42'"), std::string::npos) << seed;
}

TEST(WorldIo, OutOfRangeValuesNameTheKey) {
  const std::string baseline = parseError(exampleWith("baseline_m: 0.12", "baseline_m: -0.1"));
  EXPECT_NE(baseline.find("rig.baseline_m = -0.1: must be > 0"), std::string::npos) << baseline;

  const std::string speed = parseError(exampleWith("speed_mps: 0.4", "speed_mps: 0"));
  EXPECT_NE(speed.find("robot.speed_mps = 0: must be > 0"), std::string::npos) << speed;

  const std::string one_waypoint = parseError(exampleWith("[[0, 0], [4, 0], [4, 3]]", "[[0, 0]]"));
  EXPECT_NE(one_waypoint.find("robot.waypoints: need at least 2 waypoints"), std::string::npos)
      << one_waypoint;

  const std::string grey = parseError(exampleWith("grey_low: 10", "grey_low: 30"));
  EXPECT_NE(grey.find("shapes[4].texture: grey_low = 30 exceeds grey_high = 20"), std::string::npos)
      << grey;

  const std::string duty = parseError(exampleWith("duty: 0.3", "duty: 1.0"));
  EXPECT_NE(duty.find("shapes[3].texture.duty = 1: must be in (0, 1)"), std::string::npos) << duty;

  const std::string rate = parseError(exampleWith("frame_rate_hz: 15", "frame_rate_hz: 2000"));
  EXPECT_NE(rate.find("robot.frame_rate_hz = 2000"), std::string::npos) << rate;

  const std::string frames = parseError(exampleWith("frames: 300", "frames: 0"));
  EXPECT_NE(frames.find("frames = 0: must be >= 1"), std::string::npos) << frames;

  const std::string yaw_rate =
      parseError(exampleWith("max_yaw_rate_dps: 35", "max_yaw_rate_dps: -35"));
  EXPECT_NE(yaw_rate.find("robot.max_yaw_rate_dps = -35: must be > 0"), std::string::npos)
      << yaw_rate;

  const std::string radius = parseError(exampleWith("radius_m: 0.2", "radius_m: 0"));
  EXPECT_NE(radius.find("shapes[3].radius_m = 0: must be > 0"), std::string::npos) << radius;

  const std::string wall = parseError(exampleWith("to_m: [10, 4]", "to_m: [0, 4]"));
  EXPECT_NE(wall.find("shapes[1].to_m: must differ from from_m"), std::string::npos) << wall;

  const std::string no_shapes = parseError("robot: {waypoints: [[0, 0], [1, 0]]}\nshapes: []\n");
  EXPECT_NE(no_shapes.find("shapes: the world needs at least one shape"), std::string::npos)
      << no_shapes;
}

TEST(WorldIo, ImageTextureFileIsResolvedAndMustExist) {
  const std::string dir = test::makeTempDir("world_io_image");
  const std::string with_image =
      exampleWith("{kind: checker, scale_m: 0.1}", "{kind: image, file: tex/poster.png}");

  const std::string missing = parseError(with_image, dir);
  EXPECT_NE(missing.find("shapes[2].texture.file = 'tex/poster.png'"), std::string::npos)
      << missing;
  EXPECT_NE(missing.find((fs::path(dir) / "tex" / "poster.png").string()), std::string::npos)
      << missing;

  fs::create_directories(fs::path(dir) / "tex");
  std::ofstream(fs::path(dir) / "tex" / "poster.png") << "not really a png";
  World w;
  const Status s = parseWorld(with_image, dir, &w);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(w.shapes[2].texture.kind, TextureKind::kImage);
  EXPECT_EQ(w.shapes[2].texture.file, "tex/poster.png");
  EXPECT_TRUE(
      fs::equivalent(w.shapes[2].texture.resolved_path, fs::path(dir) / "tex" / "poster.png"));

  const std::string stray = parseError(
      exampleWith("{kind: checker, scale_m: 0.1}", "{kind: checker, file: tex/poster.png}"), dir);
  EXPECT_NE(stray.find("shapes[2].texture.file: only used with kind: image"), std::string::npos)
      << stray;
}

TEST(WorldIo, LoadWorldReportsMissingFileAndDefaultsNameToStem) {
  World w;
  const Status missing = loadWorld("/nonexistent/twocam/world.yaml", &w);
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.message().find("cannot read world file '/nonexistent/twocam/world.yaml'"),
            std::string::npos)
      << missing.message();

  const std::string dir = test::makeTempDir("world_io_load");
  const fs::path file = fs::path(dir) / "little_room.yaml";
  std::ofstream(file) << exampleWith("name: office            # optional\n", "");
  const Status s = loadWorld(file.string(), &w);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(w.name, "little_room");
  EXPECT_TRUE(fs::equivalent(w.base_dir, dir));

  std::ofstream(file) << "rig: [1, 2\n";
  const Status broken = loadWorld(file.string(), &w);
  ASSERT_FALSE(broken.isOk());
  EXPECT_NE(broken.message().find("cannot parse world file '" + file.string() + "'"),
            std::string::npos)
      << broken.message();

  std::ofstream(file) << exampleWith("speed_mps: 0.4", "speed_mps: -1");
  const Status invalid = loadWorld(file.string(), &w);
  ASSERT_FALSE(invalid.isOk());
  EXPECT_NE(invalid.message().find(file.string()), std::string::npos) << invalid.message();
  EXPECT_NE(invalid.message().find("robot.speed_mps = -1"), std::string::npos) << invalid.message();
}

TEST(WorldIo, ValidateAcceptsCodeBuiltWorldAndRejectsBadShape) {
  World w;
  w.robot.waypoints = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0)};
  Shape box;
  box.kind = ShapeKind::kBox;
  box.name = "crate";
  w.shapes.push_back(box);
  EXPECT_TRUE(w.validate().isOk()) << w.validate().message();

  w.shapes[0].size_m.z() = -1.0;
  const Status s = w.validate();
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("shapes[0].size_m[2] = -1: must be > 0"), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("crate"), std::string::npos) << s.message();
}

TEST(WorldIo, WorldBoundsCoverAllShapes) {
  World w;
  Shape plane;  // 2 x 4 m, standing upright at x = 1 (local z along world x)
  plane.kind = ShapeKind::kPlane;
  plane.size_m = Eigen::Vector3d(2.0, 4.0, 0.0);
  plane.T_w_s.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).matrix();
  plane.T_w_s.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  Shape cylinder;
  cylinder.kind = ShapeKind::kCylinder;
  cylinder.size_m = Eigen::Vector3d(0.5, 0.5, 3.0);
  cylinder.T_w_s.translation() = Eigen::Vector3d(5.0, 5.0, 0.0);
  w.shapes = {plane, cylinder};

  const Eigen::AlignedBox3d box = worldBounds(w);
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d(1.0, -2.0, -1.0), kGeometryTol))
      << box.min().transpose();
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d(5.5, 5.5, 3.5), kGeometryTol))
      << box.max().transpose();
  EXPECT_TRUE(worldBounds(World()).isEmpty());
}

TEST(WorldIo, EveryShippedWorldLoads) {
  const fs::path worlds = fs::path(test::sourceDir()) / "worlds";
  ASSERT_TRUE(fs::is_directory(worlds)) << worlds;
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(worlds)) {
    if (entry.path().extension() != ".yaml") continue;
    World w;
    const Status s = loadWorld(entry.path().string(), &w);
    EXPECT_TRUE(s.isOk()) << entry.path() << ": " << s.message();
    EXPECT_FALSE(w.name.empty()) << entry.path();
    // The shipped worlds stay well inside the texture budget.
    EXPECT_LT(textureTexels(w), 0.5 * kMaxWorldTexels) << entry.path();
    EXPECT_LE(textureCount(w), kMaxTextures) << entry.path();
    std::printf("%s: %.1f M texels, %d textures\n",
                entry.path().stem().c_str(),
                textureTexels(w) / (1 << 20),
                textureCount(w));
    names.push_back(entry.path().stem().string());
  }
  for (const char* expected : {"office", "garden", "repetitive", "lowtexture"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end())
        << "worlds/" << expected << ".yaml is missing";
  }
}

TEST(WorldIo, LimitsTheRendererCanHonourNameTheKey) {
  // Above what the offscreen framebuffer takes: one line naming the key, not an OpenGL dump.
  const std::string wide = parseError(exampleWith("width_px: 640", "width_px: 20000"));
  EXPECT_NE(wide.find("rig.width_px = 20000: must be in [16, 4096]"), std::string::npos) << wide;
  const std::string mount = parseError(exampleWith("height_m: 0.5", "height_m: 1e200"));
  EXPECT_NE(mount.find("rig.mount.height_m = 1e+200: must be in [-10, 10]"), std::string::npos)
      << mount;
}

TEST(WorldIo, ManyTexturedShapesAreRefusedBeforeRasterising) {
  // ~500 copies of a textured box took all memory in the renderer.
  std::string text = kExampleYaml;
  text += "\n";
  for (int i = 0; i < 500; ++i) {
    text += "  - {type: box, center_m: [" + std::to_string(i % 20) + ", " + std::to_string(i / 20) +
            ", 1], size_m: [2, 2, 2], texture: {kind: blobs, scale_m: 0.1}}\n";
  }
  const std::string error = parseError(text);
  EXPECT_NE(
      error.find("textured surfaces (plane 1, box 6, cylinder 3); the renderer holds at most 192"),
      std::string::npos)
      << error;
  // Few large surfaces: the texel budget.
  std::string big = kExampleYaml;
  big += "\n";
  for (int i = 0; i < 20; ++i) {
    big += "  - {type: box, center_m: [" + std::to_string(i) +
           ", 0, 1], size_m: [20, 20, 20], texture: {kind: blobs, scale_m: 0.1}}\n";
  }
  const std::string texels = parseError(big);
  EXPECT_NE(texels.find("shapes: the textures need"), std::string::npos) << texels;
  EXPECT_NE(texels.find("at most 128 M"), std::string::npos) << texels;
  std::string many = kExampleYaml;
  many += "\n";
  for (int i = 0; i < 1001; ++i)
    many += "  - {type: wall, from_m: [0, 0], to_m: [1, 0], height_m: 1}\n";
  const std::string too_many = parseError(many);
  EXPECT_NE(too_many.find("shapes: 1006 shapes; at most 1000"), std::string::npos) << too_many;
}

}  // namespace
}  // namespace twocam::sim
