#include "sim/world_io.h"

#include <mrpt/containers/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "yaml/yaml_text.h"

namespace twocam::sim {

namespace {

namespace fs = std::filesystem;
using yaml::editDistance;
using yaml::mrptMessage;
using yaml::parseYaml;
using Yaml = mrpt::containers::yaml;
using Node = Yaml::node_t;

constexpr double kDegToRad = M_PI / 180.0;
/// Mount used for keys absent from rig.mount: a camera half a metre above the body origin,
/// looking straight ahead (the struct's identity T_b_cl would look at the sky).
constexpr double kDefaultMountHeightM = 0.5;

/// Thrown by the readers below and turned into a Status by parseWorld. Exceptions stay inside
/// this file: parsing a file is an I/O edge (STYLE §5), and threading a Status through every
/// one of the ~80 key reads would bury the format under error plumbing.
class WorldFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail(const std::string& message) { throw WorldFileError(message); }

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}
std::string indexed(const std::string& path, size_t i) {
  return path + "[" + std::to_string(i) + "]";
}
std::string lineOf(const Node& n) { return " (line " + std::to_string(n.marks.line + 1) + ")"; }

/// How a node looks in an error message: a scalar's text or the kind of node.
std::string describe(const Node& n) {
  if (n.isNullNode()) return "null";
  if (n.isSequence()) return "a sequence";
  if (n.isMap()) return "a map";
  return "'" + n.as<std::string>() + "'";
}

// ---- scalars -------------------------------------------------------------------------------

std::string scalarText(const Node& n, const std::string& key, const char* expected) {
  if (!n.isScalar()) fail(key + " = " + describe(n) + ": must be " + expected + lineOf(n));
  return n.as<std::string>();
}

double toNumber(const Node& n, const std::string& key) {
  const std::string s = scalarText(n, key, "a number");
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE) {
    fail(key + " = '" + s + "': must be a number" + lineOf(n));
  }
  if (!std::isfinite(v)) fail(key + " = '" + s + "': must be a finite number" + lineOf(n));
  return v;
}

long long toInteger(const Node& n, const std::string& key) {
  const std::string s = scalarText(n, key, "an integer");
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE) {
    fail(key + " = '" + s + "': must be an integer" + lineOf(n));
  }
  return v;
}

uint64_t toUnsigned(const Node& n, const std::string& key) {
  const std::string s = scalarText(n, key, "an unsigned integer");
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(s.c_str(), &end, 10);
  if (s.empty() || s[0] == '-' || end != s.c_str() + s.size() || errno == ERANGE) {
    fail(key + " = '" + s + "': must be an unsigned 64-bit integer" + lineOf(n));
  }
  return static_cast<uint64_t>(v);
}

bool toBool(const Node& n, const std::string& key) {
  const std::string s = scalarText(n, key, "true or false");
  for (const char* t : {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"}) {
    if (s == t) return true;
  }
  for (const char* f : {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"}) {
    if (s == f) return false;
  }
  fail(key + " = '" + s + "': must be true or false" + lineOf(n));
}

std::vector<double> toNumbers(const Node& n, const std::string& key, size_t count) {
  const std::string expected = "must be a sequence of " + std::to_string(count) + " numbers";
  if (!n.isSequence()) fail(key + " = " + describe(n) + ": " + expected + lineOf(n));
  const Yaml::sequence_t& seq = n.asSequence();
  if (seq.size() != count) {
    fail(key + ": " + expected + ", got " + std::to_string(seq.size()) + lineOf(n));
  }
  std::vector<double> out;
  for (size_t i = 0; i < count; ++i) out.push_back(toNumber(seq[i], indexed(key, i)));
  return out;
}

// ---- maps ----------------------------------------------------------------------------------

/// A map node with a fixed set of allowed keys. Construction fails on any other key, naming
/// its full path and the closest allowed key. Absent keys leave the targets untouched, so the
/// struct defaults stand.
class MapReader {
 public:
  MapReader(const Node& node, std::string path, std::initializer_list<const char*> allowed)
      : node_(node), path_(std::move(path)) {
    if (!node.isMap()) {
      fail((path_.empty() ? std::string("the document") : path_) + " = " + describe(node) +
           ": must be a map of 'key: value' entries" + lineOf(node));
    }
    for (const auto& [key_node, value] : node.asMap()) {
      (void)value;
      const std::string key = key_node.as<std::string>();
      if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      std::string message = "unknown key '" + join(path_, key) + "'" + lineOf(key_node);
      const char* best = nullptr;
      size_t best_distance = 0;
      for (const char* candidate : allowed) {
        const size_t d = editDistance(key, candidate);
        if (best == nullptr || d < best_distance) {
          best = candidate;
          best_distance = d;
        }
      }
      // A hint only when it is plausibly a typo: up to a third of the letters wrong.
      if (best != nullptr && best_distance <= std::max<size_t>(2, key.size() / 3)) {
        message += "; did you mean '" + join(path_, best) + "'?";
      }
      fail(message);
    }
  }

  [[nodiscard]] std::string path(const char* key) const { return join(path_, key); }

  /// The value of key, or nullptr when absent.
  [[nodiscard]] const Node* find(const char* key) const {
    for (const auto& [key_node, value] : node_.asMap()) {
      if (key_node.as<std::string>() == key) return &value;
    }
    return nullptr;
  }

  [[nodiscard]] const Node& require(const char* key) const {
    const Node* n = find(key);
    if (n == nullptr) {
      fail((path_.empty() ? std::string("the document") : path_) + ": missing key '" + key + "'" +
           lineOf(node_));
    }
    return *n;
  }

  void read(const char* key, double* out) const {
    if (const Node* n = find(key)) *out = toNumber(*n, path(key));
  }
  /// Reads degrees, stores radians.
  void readDeg(const char* key, double* out_rad) const {
    if (const Node* n = find(key)) *out_rad = toNumber(*n, path(key)) * kDegToRad;
  }
  void read(const char* key, int* out) const {
    if (const Node* n = find(key)) {
      const long long v = toInteger(*n, path(key));
      if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) {
        fail(path(key) + " = " + std::to_string(v) + ": out of range" + lineOf(*n));
      }
      *out = static_cast<int>(v);
    }
  }
  void read(const char* key, uint64_t* out) const {
    if (const Node* n = find(key)) *out = toUnsigned(*n, path(key));
  }
  void read(const char* key, bool* out) const {
    if (const Node* n = find(key)) *out = toBool(*n, path(key));
  }
  void read(const char* key, std::string* out) const {
    if (const Node* n = find(key)) *out = scalarText(*n, path(key), "a string");
  }
  /// A fixed-length list of numbers; false when absent.
  bool read(const char* key, size_t count, std::vector<double>* out) const {
    const Node* n = find(key);
    if (n == nullptr) return false;
    *out = toNumbers(*n, path(key), count);
    return true;
  }
  [[nodiscard]] double requireNumber(const char* key) const {
    return toNumber(require(key), path(key));
  }
  [[nodiscard]] std::vector<double> requireNumbers(const char* key, size_t count) const {
    return toNumbers(require(key), path(key), count);
  }

  [[nodiscard]] const Node& node() const { return node_; }

 private:
  const Node& node_;
  std::string path_;
};

/// The items of an optional sequence key (empty when absent).
const Yaml::sequence_t* sequenceOrNull(const MapReader& map, const char* key) {
  const Node* n = map.find(key);
  if (n == nullptr) return nullptr;
  if (!n->isSequence()) {
    fail(map.path(key) + " = " + describe(*n) + ": must be a sequence" + lineOf(*n));
  }
  return &n->asSequence();
}

void checkPositive(const MapReader& map, const char* key, double v) {
  if (!(v > 0.0)) {
    std::ostringstream os;
    os << map.path(key) << " = " << v << ": must be > 0" << lineOf(*map.find(key));
    fail(os.str());
  }
}

// ---- sections ------------------------------------------------------------------------------

/// Left camera on the robot body (rig.mount); defaults used for absent keys.
struct Mount {
  double x_m = 0.0;
  double y_m = 0.0;
  double height_m = kDefaultMountHeightM;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};

/// Reads the rig section. node == nullptr (no section) keeps the struct's intrinsics; the
/// camera is then mounted with the default mount.
void parseRig(const Node* node, StereoRig* rig) {
  Mount mount;
  if (node != nullptr) {
    const MapReader m(
        *node,
        "rig",
        {"width_px", "height_px", "fx_px", "fy_px", "cx_px", "cy_px", "baseline_m", "mount"});
    m.read("width_px", &rig->width_px);
    m.read("height_px", &rig->height_px);
    m.read("fx_px", &rig->fx_px);
    m.read("fy_px", &rig->fy_px);
    rig->cx_px = 0.5 * (rig->width_px - 1);
    rig->cy_px = 0.5 * (rig->height_px - 1);
    m.read("cx_px", &rig->cx_px);
    m.read("cy_px", &rig->cy_px);
    m.read("baseline_m", &rig->baseline_m);
    if (const Node* n = m.find("mount")) {
      const MapReader mm(*n, "rig.mount", {"x_m", "y_m", "height_m", "pitch_deg", "yaw_deg"});
      mm.read("x_m", &mount.x_m);
      mm.read("y_m", &mount.y_m);
      mm.read("height_m", &mount.height_m);
      mm.readDeg("pitch_deg", &mount.pitch_rad);
      mm.readDeg("yaw_deg", &mount.yaw_rad);
    }
  }
  rig->T_b_cl = Eigen::Isometry3d::Identity();
  rig->T_b_cl.linear() = opticalRotationFromYawPitch(mount.yaw_rad, mount.pitch_rad);
  rig->T_b_cl.translation() = Eigen::Vector3d(mount.x_m, mount.y_m, mount.height_m);
}

void parseRobot(const Node& node, RobotSpec* robot) {
  const MapReader m(node,
                    "robot",
                    {"speed_mps",
                     "max_yaw_rate_dps",
                     "waypoint_radius_m",
                     "loop",
                     "frame_rate_hz",
                     "wheel_base_m",
                     "waypoints"});
  m.read("speed_mps", &robot->speed_mps);
  m.readDeg("max_yaw_rate_dps", &robot->max_yaw_rate_rps);
  m.read("waypoint_radius_m", &robot->waypoint_radius_m);
  m.read("loop", &robot->loop);
  m.read("frame_rate_hz", &robot->frame_rate_hz);
  m.read("wheel_base_m", &robot->wheel_base_m);
  if (const Yaml::sequence_t* seq = sequenceOrNull(m, "waypoints")) {
    robot->waypoints.clear();
    for (size_t i = 0; i < seq->size(); ++i) {
      const std::vector<double> p = toNumbers((*seq)[i], indexed("robot.waypoints", i), 2);
      robot->waypoints.emplace_back(p[0], p[1]);
    }
  }
}

void parseRadiometry(const Node& node, const std::string& path, CameraRadiometry* r) {
  const MapReader m(node, path, {"gain", "offset_grey"});
  m.read("gain", &r->gain);
  m.read("offset_grey", &r->offset_grey);
}

void parseImageNoise(const Node& node, ImageNoiseSpec* noise) {
  const MapReader m(node, "image_noise", {"sigma_grey", "left", "right"});
  m.read("sigma_grey", &noise->sigma_grey);
  if (const Node* n = m.find("left")) parseRadiometry(*n, "image_noise.left", &noise->left);
  if (const Node* n = m.find("right")) parseRadiometry(*n, "image_noise.right", &noise->right);
}

void parseOdometryNoise(const Node& node, OdometryNoiseSpec* noise) {
  const MapReader m(node,
                    "odometry_noise",
                    {"sigma_per_m", "sigma_per_rad", "scale_error", "wheel_base_error", "slips"});
  m.read("sigma_per_m", &noise->sigma_per_m);
  m.read("sigma_per_rad", &noise->sigma_per_rad);
  m.read("scale_error", &noise->scale_error);
  m.read("wheel_base_error", &noise->wheel_base_error);
  if (const Yaml::sequence_t* seq = sequenceOrNull(m, "slips")) {
    noise->slips.clear();
    for (size_t i = 0; i < seq->size(); ++i) {
      const MapReader s(
          (*seq)[i], indexed("odometry_noise.slips", i), {"time_s", "dx_m", "dy_m", "dyaw_deg"});
      SlipEvent slip;
      s.read("time_s", &slip.time_s);
      s.read("dx_m", &slip.dx_m);
      s.read("dy_m", &slip.dy_m);
      s.readDeg("dyaw_deg", &slip.dyaw_rad);
      noise->slips.push_back(slip);
    }
  }
}

TextureKind parseTextureKind(const Node& n, const std::string& key) {
  const std::string s = scalarText(n, key, "a texture kind");
  static constexpr std::pair<const char*, TextureKind> kKinds[] = {
      {"blobs", TextureKind::kBlobs},
      {"checker", TextureKind::kChecker},
      {"stripes", TextureKind::kStripes},
      {"bricks", TextureKind::kBricks},
      {"gradient", TextureKind::kGradient},
      {"solid", TextureKind::kSolid},
      {"image", TextureKind::kImage},
  };
  for (const auto& [name, kind] : kKinds) {
    if (s == name) return kind;
  }
  fail(key + " = '" + s +
       "': must be one of blobs, checker, stripes, bricks, gradient, solid, image" + lineOf(n));
}

void parseTexture(const Node& node,
                  const std::string& path,
                  const std::string& base_dir,
                  TextureSpec* t) {
  const MapReader m(node,
                    path,
                    {"kind",
                     "scale_m",
                     "grey_low",
                     "grey_high",
                     "duty",
                     "brick_height_m",
                     "mortar_m",
                     "gradient_along",
                     "file",
                     "texels_per_m"});
  if (const Node* n = m.find("kind")) t->kind = parseTextureKind(*n, m.path("kind"));
  m.read("scale_m", &t->scale_m);
  m.read("grey_low", &t->grey_low);
  m.read("grey_high", &t->grey_high);
  m.read("duty", &t->duty);
  m.read("brick_height_m", &t->brick_height_m);
  m.read("mortar_m", &t->mortar_m);
  m.read("texels_per_m", &t->texels_per_m);
  if (const Node* n = m.find("gradient_along")) {
    const std::string s = scalarText(*n, m.path("gradient_along"), "u or v");
    if (s != "u" && s != "v") {
      fail(m.path("gradient_along") + " = '" + s + "': must be u or v" + lineOf(*n));
    }
    t->gradient_along_u = s == "u";
  }
  if (const Node* n = m.find("file")) {
    if (t->kind != TextureKind::kImage) {
      fail(m.path("file") + ": only used with kind: image" + lineOf(*n));
    }
    m.read("file", &t->file);
  }
  if (t->kind == TextureKind::kImage) {
    if (t->file.empty()) fail(m.path("file") + ": kind: image needs a file" + lineOf(node));
    fs::path p(t->file);
    if (p.is_relative()) p = fs::path(base_dir) / p;
    p = p.lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(p, ec)) {
      fail(m.path("file") + " = '" + t->file + "': no such file '" + p.string() + "'" +
           lineOf(*m.find("file")));
    }
    t->resolved_path = p.string();
  }
}

Eigen::Matrix3d rotationRpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .matrix();
}

Shape parseShape(const Node& node, size_t index, const std::string& base_dir) {
  const std::string path = indexed("shapes", index);
  if (!node.isMap()) {
    fail(path + " = " + describe(node) + ": must be a map with a 'type' key" + lineOf(node));
  }
  // The allowed keys depend on the type, so read it before checking the others.
  const Node* type_node = nullptr;
  for (const auto& [key_node, value] : node.asMap()) {
    if (key_node.as<std::string>() == "type") type_node = &value;
  }
  if (type_node == nullptr) {
    fail(path + ": missing key 'type' (plane, wall, box or cylinder)" + lineOf(node));
  }
  const std::string type = scalarText(*type_node, path + ".type", "a shape type");

  Shape shape;
  shape.name = type + std::to_string(index);
  const auto read_common = [&](const MapReader& m) {
    m.read("name", &shape.name);
    if (const Node* t = m.find("texture")) {
      parseTexture(*t, m.path("texture"), base_dir, &shape.texture);
    }
  };

  if (type == "plane") {
    const MapReader m(node, path, {"type", "name", "texture", "center_m", "rpy_deg", "size_m"});
    read_common(m);
    shape.kind = ShapeKind::kPlane;
    std::vector<double> c{0.0, 0.0, 0.0};
    std::vector<double> rpy{0.0, 0.0, 0.0};
    m.read("center_m", 3, &c);
    m.read("rpy_deg", 3, &rpy);
    const std::vector<double> size = m.requireNumbers("size_m", 2);
    shape.T_w_s.linear() = rotationRpy(rpy[0] * kDegToRad, rpy[1] * kDegToRad, rpy[2] * kDegToRad);
    shape.T_w_s.translation() = Eigen::Vector3d(c[0], c[1], c[2]);
    shape.size_m = Eigen::Vector3d(size[0], size[1], 0.0);
  } else if (type == "wall") {
    const MapReader m(
        node, path, {"type", "name", "texture", "from_m", "to_m", "z0_m", "height_m"});
    read_common(m);
    shape.kind = ShapeKind::kPlane;
    const std::vector<double> from = m.requireNumbers("from_m", 2);
    const std::vector<double> to = m.requireNumbers("to_m", 2);
    double z0_m = 0.0;
    m.read("z0_m", &z0_m);
    const double height_m = m.requireNumber("height_m");
    checkPositive(m, "height_m", height_m);
    const Eigen::Vector2d a(from[0], from[1]);
    const Eigen::Vector2d b(to[0], to[1]);
    const double length_m = (b - a).norm();
    if (!(length_m > 0.0)) fail(path + ".to_m: must differ from from_m" + lineOf(node));
    // Local x along the wall, local y up, local z the horizontal normal (x cross y).
    const Eigen::Vector3d ex((b - a).x() / length_m, (b - a).y() / length_m, 0.0);
    const Eigen::Vector3d ey = Eigen::Vector3d::UnitZ();
    shape.T_w_s.linear().col(0) = ex;
    shape.T_w_s.linear().col(1) = ey;
    shape.T_w_s.linear().col(2) = ex.cross(ey);
    const Eigen::Vector2d mid = 0.5 * (a + b);
    shape.T_w_s.translation() = Eigen::Vector3d(mid.x(), mid.y(), z0_m + 0.5 * height_m);
    shape.size_m = Eigen::Vector3d(length_m, height_m, 0.0);
  } else if (type == "box") {
    const MapReader m(node, path, {"type", "name", "texture", "center_m", "yaw_deg", "size_m"});
    read_common(m);
    shape.kind = ShapeKind::kBox;
    const std::vector<double> c = m.requireNumbers("center_m", 3);
    double yaw_rad = 0.0;
    m.readDeg("yaw_deg", &yaw_rad);
    const std::vector<double> size = m.requireNumbers("size_m", 3);
    shape.T_w_s.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).matrix();
    shape.T_w_s.translation() = Eigen::Vector3d(c[0], c[1], c[2]);
    shape.size_m = Eigen::Vector3d(size[0], size[1], size[2]);
  } else if (type == "cylinder") {
    const MapReader m(node, path, {"type", "name", "texture", "base_m", "radius_m", "height_m"});
    read_common(m);
    shape.kind = ShapeKind::kCylinder;
    const std::vector<double> base = m.requireNumbers("base_m", 3);
    const double radius_m = m.requireNumber("radius_m");
    const double height_m = m.requireNumber("height_m");
    shape.T_w_s.translation() = Eigen::Vector3d(base[0], base[1], base[2]);
    shape.size_m = Eigen::Vector3d(radius_m, radius_m, height_m);
  } else {
    fail(path + ".type = '" + type + "': must be one of plane, wall, box, cylinder" +
         lineOf(*type_node));
  }
  return shape;
}

void parseDocument(const Node& root, const std::string& base_dir, World* w) {
  if (root.isNullNode()) fail("the document is empty");
  const MapReader m(root,
                    "",
                    {"name",
                     "seed",
                     "frames",
                     "background_grey",
                     "rig",
                     "robot",
                     "image_noise",
                     "odometry_noise",
                     "shapes"});
  m.read("name", &w->name);
  m.read("seed", &w->seed);
  m.read("frames", &w->frames);
  m.read("background_grey", &w->background_grey);
  parseRig(m.find("rig"), &w->rig);
  if (const Node* n = m.find("robot")) parseRobot(*n, &w->robot);
  if (const Node* n = m.find("image_noise")) parseImageNoise(*n, &w->image_noise);
  if (const Node* n = m.find("odometry_noise")) parseOdometryNoise(*n, &w->odometry_noise);
  if (const Yaml::sequence_t* seq = sequenceOrNull(m, "shapes")) {
    for (size_t i = 0; i < seq->size(); ++i)
      w->shapes.push_back(parseShape((*seq)[i], i, base_dir));
  }
}

Status parseImpl(const std::string& yaml_text,
                 const std::string& base_dir,
                 const std::string& source,
                 World* world) {
  Yaml doc;
  if (const auto error = parseYaml(yaml_text, &doc)) {
    return Status::error("cannot parse world file " + source + ": " + *error);
  }
  World w;
  w.base_dir = base_dir;
  try {
    parseDocument(doc.node(), base_dir, &w);
  } catch (const WorldFileError& e) {
    return Status::error(e.what());
  } catch (const std::exception& e) {
    // MRPT accessors throw on node kinds the readers did not expect.
    return Status::error("cannot read world file " + source + ": " + mrptMessage(e));
  }
  if (Status s = w.validate(); !s) return s;
  *world = std::move(w);
  return Status::ok();
}

}  // namespace

Status parseOdometryNoiseFile(const std::string& yaml_text,
                              const std::string& source,
                              OdometryNoiseSpec* noise) {
  Yaml doc;
  if (const auto error = parseYaml(yaml_text, &doc)) {
    return Status::error("cannot parse odometry noise file " + source + ": " + *error);
  }
  // A world file's defaults for absent keys.
  OdometryNoiseSpec spec = World().odometry_noise;
  try {
    const Node& root = doc.node();
    if (root.isNullNode()) fail("the document is empty; expected an 'odometry_noise:' section");
    const MapReader m(root, "", {"odometry_noise"});
    parseOdometryNoise(m.require("odometry_noise"), &spec);
  } catch (const WorldFileError& e) {
    return Status::error("odometry noise file " + source + ": " + e.what());
  } catch (const std::exception& e) {
    return Status::error("cannot read odometry noise file " + source + ": " + mrptMessage(e));
  }
  if (Status s = spec.validate(); !s) {
    return Status::error("odometry noise file " + source + ": " + s.message());
  }
  *noise = std::move(spec);
  return Status::ok();
}

Status loadOdometryNoise(const std::string& path, OdometryNoiseSpec* noise) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    return Status::error("cannot read odometry noise file '" + path + "': no such file");
  if (fs::is_directory(path, ec))
    return Status::error("cannot read odometry noise file '" + path + "': it is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return Status::error("cannot read odometry noise file '" + path + "': " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Status::error("cannot read odometry noise file '" + path + "': read error");
  return parseOdometryNoiseFile(text.str(), "'" + path + "'", noise);
}

Status parseWorld(const std::string& yaml_text, const std::string& base_dir, World* world) {
  return parseImpl(yaml_text, base_dir, "(YAML text)", world);
}

Status selfContainedWorldText(const std::string& yaml_text,
                              const std::string& base_dir,
                              std::string* out) {
  World check;
  if (Status st = parseWorld(yaml_text, base_dir, &check); !st) return st;
  Yaml doc;
  if (const auto error = parseYaml(yaml_text, &doc)) return Status::error(*error);
  // (position, length, replacement) of each relative texture file scalar.
  struct Edit {
    size_t pos, length;
    std::string text;
  };
  std::vector<Edit> edits;
  const Node& root = doc.node();
  const Node* shapes = nullptr;
  for (const auto& [k, v] : root.asMap())
    if (k.as<std::string>() == "shapes") shapes = &v;
  if (shapes != nullptr && shapes->isSequence()) {
    for (const Node& shape : shapes->asSequence()) {
      if (!shape.isMap()) continue;
      for (const auto& [k, texture] : shape.asMap()) {
        if (k.as<std::string>() != "texture" || !texture.isMap()) continue;
        for (const auto& [tk, file] : texture.asMap()) {
          if (tk.as<std::string>() != "file" || !file.isScalar()) continue;
          const std::string value = file.as<std::string>();
          if (fs::path(value).is_absolute()) continue;
          const size_t pos = file.marks.input_pos;
          size_t length = 0;
          if (pos < yaml_text.size() && (yaml_text[pos] == '\'' || yaml_text[pos] == '"')) {
            const size_t close = yaml_text.find(yaml_text[pos], pos + 1);
            if (close == std::string::npos) return Status::error("unterminated quote");
            length = close + 1 - pos;
          } else if (yaml_text.compare(pos, value.size(), value) == 0) {
            length = value.size();
          } else {
            return Status::error("cannot locate texture file '" + value + "'" + lineOf(file));
          }
          std::string quoted = "'";
          for (char c : (fs::path(base_dir) / value).lexically_normal().string()) {
            quoted += c;
            if (c == '\'') quoted += c;
          }
          edits.push_back({pos, length, quoted + "'"});
        }
      }
    }
  }
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.pos > b.pos; });
  std::string text = yaml_text;
  for (const Edit& e : edits) text.replace(e.pos, e.length, e.text);
  // The copy must describe the same world from anywhere.
  World copy;
  if (Status st = parseWorld(text, "/nonexistent-folder", &copy); !st)
    return Status::error("texture paths could not be made absolute: " + st.message());
  *out = std::move(text);
  return Status::ok();
}

Status loadWorld(const std::string& path, World* world) {
  std::error_code ec;
  const fs::path file(path);
  if (!fs::exists(file, ec))
    return Status::error("cannot read world file '" + path + "': no such file");
  if (fs::is_directory(file, ec)) {
    return Status::error("cannot read world file '" + path + "': it is a directory");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    return Status::error("cannot read world file '" + path + "': " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Status::error("cannot read world file '" + path + "': read error");

  const std::string base_dir = fs::absolute(file, ec).parent_path().lexically_normal().string();
  World w;
  const Status s = parseImpl(text.str(), base_dir, "'" + path + "'", &w);
  if (!s) {
    // Parse errors already name the file; prefix the others.
    if (s.message().rfind("cannot ", 0) == 0) return s;
    return Status::error("world file '" + path + "': " + s.message());
  }
  if (w.name.empty()) w.name = file.stem().string();
  *world = std::move(w);
  return Status::ok();
}

}  // namespace twocam::sim
