#include "io/kitti.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <utility>

#include "common/quiet_stderr.h"

namespace twocam::io {

namespace {

namespace fs = std::filesystem;

/// KITTI prints poses with 7 significant digits: |R^T R - I| reaches a few 1e-7; 1e-5 accepts
/// that and rejects matrices that are not rotations.
constexpr double kRotationTol = 1e-5;
/// Entries of a rectified projection matrix that must be zero (skew, the last row, P0's
/// translation) are printed as exact zeros by KITTI; allow print rounding of large entries.
constexpr double kZeroTol = 1e-9;
/// P1's intrinsics equal P0's in a rectified pair; relative tolerance for print rounding.
constexpr double kSameIntrinsicsRelTol = 1e-6;

std::string trim(const std::string& s) {
  const char* ws = " \t\r\n";
  const size_t b = s.find_first_not_of(ws);
  if (b == std::string::npos) return std::string();
  return s.substr(b, s.find_last_not_of(ws) - b + 1);
}

/// "file:line: "
std::string where(const std::string& file, int line) {
  return file + ":" + std::to_string(line) + ": ";
}

/// Parses whitespace-separated numbers of `text` into `values`; returns "" or what is wrong.
std::string parseNumbers(const std::string& text, size_t expected, std::vector<double>* values) {
  values->clear();
  std::istringstream in(text);
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) {
      return "'" + token + "' is not a finite number";
    }
    values->push_back(v);
  }
  if (values->size() != expected) {
    return "expected " + std::to_string(expected) + " numbers, got " +
           std::to_string(values->size());
  }
  return std::string();
}

using Matrix34 = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

Matrix34 toMatrix34(const std::vector<double>& v) {
  Matrix34 M;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = v[static_cast<size_t>(4 * r + c)];
  return M;
}

/// Empty when P is a rectified projection K [I | t] with zero skew; else why not.
std::string checkProjection(const Matrix34& P) {
  if (!(P(0, 0) > 0.0) || !(P(1, 1) > 0.0)) return "focal lengths P[0][0], P[1][1] must be > 0";
  const double scale = std::max(1.0, P.cwiseAbs().maxCoeff());
  if (std::abs(P(0, 1)) > kZeroTol * scale || std::abs(P(1, 0)) > kZeroTol * scale ||
      std::abs(P(2, 0)) > kZeroTol * scale || std::abs(P(2, 1)) > kZeroTol * scale ||
      std::abs(P(2, 2) - 1.0) > kZeroTol * scale || std::abs(P(2, 3)) > kZeroTol * scale) {
    return "not a rectified projection matrix (expected [fx 0 cx tx; 0 fy cy 0; 0 0 1 0])";
  }
  return std::string();
}

bool nearRel(double a, double b, double rel_tol) {
  return std::abs(a - b) <= rel_tol * std::max({1.0, std::abs(a), std::abs(b)});
}

/// Non-blank lines of a text file with their 1-based line numbers.
Status readLines(const std::string& path, std::vector<std::pair<int, std::string>>* lines) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return Status::error(path + ": no such file");
  if (fs::is_directory(path, ec)) return Status::error(path + ": is a folder, expected a file");
  std::ifstream in(path);
  if (!in) return Status::error(path + ": cannot open file");
  lines->clear();
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string t = trim(line);
    if (!t.empty()) lines->emplace_back(line_no, t);
  }
  if (in.bad()) return Status::error(path + ": read error");
  return Status::ok();
}

/// The one existing folder among `names` inside dir; errors name both spellings.
Status findImageDir(const fs::path& dir,
                    const std::string& shown_dir,
                    const char* name_a,
                    const char* name_b,
                    const char* which,
                    fs::path* out) {
  std::error_code ec;
  const bool a = fs::is_directory(dir / name_a, ec);
  const bool b = fs::is_directory(dir / name_b, ec);
  if (a && b) {
    return Status::error("'" + shown_dir + "' has both " + name_a + "/ and " + name_b +
                         "/; keep one folder of " + which + " images");
  }
  if (!a && !b) {
    return Status::error("'" + shown_dir + "' is not a KITTI sequence: it has no " + which +
                         " image folder (" + name_a + "/ or " + name_b + "/)");
  }
  *out = dir / (a ? name_a : name_b);
  return Status::ok();
}

/// Names of the PNG files of a folder, sorted.
std::vector<std::string> pngNames(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec)) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
      return static_cast<char>(std::tolower(c));
    });
    if (ext == ".png") names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string kittiName(int k) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06d.png", k);
  return buf;
}

/// Checks that `names` are 000000.png, 000001.png, ... and that the other camera has the
/// same ones; errors name the first image that is missing.
Status checkNames(const std::vector<std::string>& left,
                  const std::vector<std::string>& right,
                  const fs::path& left_dir,
                  const fs::path& right_dir) {
  const auto check_one = [](const std::vector<std::string>& names, const fs::path& dir) -> Status {
    for (size_t k = 0; k < names.size(); ++k) {
      const std::string want = kittiName(static_cast<int>(k));
      if (names[k] != want) {
        return Status::error("image " + (dir / want).string() +
                             " is missing (KITTI images are numbered 000000.png, 000001.png, "
                             "... without gaps; found " +
                             names[k] + " in its place)");
      }
    }
    return Status::ok();
  };
  if (Status s = check_one(left, left_dir); !s) return s;
  if (Status s = check_one(right, right_dir); !s) return s;
  if (left.size() != right.size()) {
    const bool more_left = left.size() > right.size();
    const std::string name = kittiName(static_cast<int>(std::min(left.size(), right.size())));
    return Status::error("image " + ((more_left ? right_dir : left_dir) / name).string() +
                         " is missing (" + std::to_string(left.size()) + " left and " +
                         std::to_string(right.size()) + " right images)");
  }
  return Status::ok();
}

/// A line count check for poses.txt / times.txt.
Status checkCount(const std::string& file, size_t lines, int pairs, bool at_least) {
  if (at_least ? lines >= static_cast<size_t>(pairs) : lines == static_cast<size_t>(pairs))
    return Status::ok();
  return Status::error(file + " has " + std::to_string(lines) + (lines == 1 ? " line" : " lines") +
                       " but " + (at_least ? "at least " : "") + std::to_string(pairs) +
                       " are needed (one per image pair" +
                       (at_least ? " imported" : " in the image folders") + ")");
}

}  // namespace

Eigen::Isometry3d kittiBodyFromLeftCamera() {
  Eigen::Isometry3d T_b_cl = Eigen::Isometry3d::Identity();
  T_b_cl.linear() = opticalRotationFromYawPitch(0.0, 0.0);
  return T_b_cl;
}

Status loadKittiCalibration(const std::string& calib_txt,
                            int width_px,
                            int height_px,
                            StereoRig* rig) {
  if (rig == nullptr) return Status::error("loadKittiCalibration: null output");
  std::vector<std::pair<int, std::string>> lines;
  if (Status s = readLines(calib_txt, &lines); !s) return s;
  std::optional<std::pair<int, Matrix34>> p0;
  std::optional<std::pair<int, Matrix34>> p1;
  int bare_lines = 0;
  bool named = false;
  std::vector<double> values;
  for (const auto& [line_no, text] : lines) {
    const size_t colon = text.find(':');
    std::string name;
    std::string numbers = text;
    if (colon != std::string::npos) {
      name = trim(text.substr(0, colon));
      numbers = text.substr(colon + 1);
      if (name.empty() || name.find_first_of(" \t") != std::string::npos) {
        return Status::error(where(calib_txt, line_no) + "expected 'NAME: 12 numbers' or 12 " +
                             "numbers, got '" + text + "'");
      }
    }
    if (line_no == lines.front().first) named = !name.empty();
    if (named != !name.empty()) {
      return Status::error(where(calib_txt, line_no) +
                           "mixes named lines ('P0: ...') and bare lines of numbers");
    }
    if (named && name != "P0" && name != "P1") continue;  // P2, P3, Tr, ...: not needed
    if (!named && ++bare_lines > 2) continue;             // bare P2, P3, Tr
    if (const std::string why = parseNumbers(numbers, 12, &values); !why.empty()) {
      return Status::error(where(calib_txt, line_no) +
                           (named ? name : std::string(bare_lines == 1 ? "P0" : "P1")) + ": " +
                           why);
    }
    const bool is_p0 = named ? name == "P0" : bare_lines == 1;
    auto& slot = is_p0 ? p0 : p1;
    if (slot) {
      return Status::error(where(calib_txt, line_no) + (is_p0 ? "P0" : "P1") +
                           " is given twice (first on line " + std::to_string(slot->first) + ")");
    }
    slot = std::make_pair(line_no, toMatrix34(values));
  }
  if (!p0 || !p1) {
    return Status::error(calib_txt + ": no " + std::string(!p0 ? "P0" : "P1") +
                         " (needs the left camera's P0 and the right camera's P1, as 'P0: ...' "
                         "lines or as the first two lines of 12 numbers)");
  }
  const Matrix34& P0 = p0->second;
  const Matrix34& P1 = p1->second;
  if (const std::string why = checkProjection(P0); !why.empty())
    return Status::error(where(calib_txt, p0->first) + "P0: " + why);
  if (const std::string why = checkProjection(P1); !why.empty())
    return Status::error(where(calib_txt, p1->first) + "P1: " + why);
  const double p0_scale = std::max(1.0, P0.cwiseAbs().maxCoeff());
  if (std::abs(P0(0, 3)) > kZeroTol * p0_scale || std::abs(P0(1, 3)) > kZeroTol * p0_scale) {
    return Status::error(where(calib_txt, p0->first) +
                         "P0's last column must be zero (camera 0 is the reference of the "
                         "rectified pair and of poses.txt)");
  }
  for (const auto& [r, c] : {std::pair{0, 0}, {1, 1}, {0, 2}, {1, 2}}) {
    if (!nearRel(P0(r, c), P1(r, c), kSameIntrinsicsRelTol)) {
      std::ostringstream os;
      os << where(calib_txt, p1->first) << "P1[" << r << "][" << c << "] = " << P1(r, c)
         << " differs from P0's " << P0(r, c)
         << ": the cameras are not a rectified pair with shared intrinsics";
      return Status::error(os.str());
    }
  }
  if (std::abs(P1(1, 3)) > kZeroTol * std::max(1.0, P1.cwiseAbs().maxCoeff())) {
    return Status::error(where(calib_txt, p1->first) +
                         "P1[1][3] must be zero (a rectified pair is offset along x only)");
  }
  StereoRig out;
  out.width_px = width_px;
  out.height_px = height_px;
  out.fx_px = P0(0, 0);
  out.fy_px = P0(1, 1);
  out.cx_px = P0(0, 2);
  out.cy_px = P0(1, 2);
  out.baseline_m = -P1(0, 3) / P1(0, 0);
  out.T_b_cl = kittiBodyFromLeftCamera();
  if (!(out.baseline_m > 0.0)) {
    std::ostringstream os;
    os << where(calib_txt, p1->first) << "baseline -P1[0][3] / P1[0][0] = " << out.baseline_m
       << " m; must be > 0 (camera 1 is the right camera, at +x of camera 0)";
    return Status::error(os.str());
  }
  if (Status s = out.validate(); !s) return Status::error(calib_txt + ": " + s.message());
  *rig = out;
  return Status::ok();
}

Status loadKittiPoses(const std::string& poses_txt, std::vector<Eigen::Isometry3d>* T_w_cam0) {
  if (T_w_cam0 == nullptr) return Status::error("loadKittiPoses: null output");
  std::vector<std::pair<int, std::string>> lines;
  if (Status s = readLines(poses_txt, &lines); !s) return s;
  std::vector<Eigen::Isometry3d> out;
  out.reserve(lines.size());
  std::vector<double> values;
  for (const auto& [line_no, text] : lines) {
    if (const std::string why = parseNumbers(text, 12, &values); !why.empty())
      return Status::error(where(poses_txt, line_no) + why + " (a 3x4 pose per line)");
    const Matrix34 M = toMatrix34(values);
    const Eigen::Matrix3d R = M.leftCols<3>();
    const double orthonormality_error =
        (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (!(orthonormality_error < kRotationTol) || !(R.determinant() > 0.0)) {
      std::ostringstream os;
      os << where(poses_txt, line_no)
         << "not a rigid transform (|R^T R - I|max = " << orthonormality_error
         << ", det = " << R.determinant() << ")";
      return Status::error(os.str());
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
    T.translation() = M.col(3);
    out.push_back(T);
  }
  *T_w_cam0 = std::move(out);
  return Status::ok();
}

Status loadKittiTimes(const std::string& times_txt, std::vector<int64_t>* t_ns) {
  if (t_ns == nullptr) return Status::error("loadKittiTimes: null output");
  std::vector<std::pair<int, std::string>> lines;
  if (Status s = readLines(times_txt, &lines); !s) return s;
  std::vector<int64_t> out;
  out.reserve(lines.size());
  std::vector<double> values;
  // Beyond ~292 years the nanoseconds overflow int64.
  constexpr double kMaxTimeS = 9.0e9;
  for (const auto& [line_no, text] : lines) {
    if (const std::string why = parseNumbers(text, 1, &values); !why.empty())
      return Status::error(where(times_txt, line_no) + why + " (one time stamp [s] per line)");
    const double t_s = values[0];
    if (!(t_s >= 0.0 && t_s < kMaxTimeS)) {
      return Status::error(where(times_txt, line_no) + "time " + text + " s must be in [0, 9e9) s");
    }
    const int64_t t = std::llround(t_s * 1e9);
    if (!out.empty() && t <= out.back()) {
      return Status::error(where(times_txt, line_no) + "time " + text +
                           " s does not increase (the previous line has " +
                           lines[out.size() - 1].second + " s)");
    }
    out.push_back(t);
  }
  *t_ns = std::move(out);
  return Status::ok();
}

std::vector<Eigen::Isometry3d> kittiBodyPoses(const std::vector<Eigen::Isometry3d>& T_w_cam0,
                                              const Eigen::Isometry3d& T_b_cl) {
  std::vector<Eigen::Isometry3d> out;
  if (T_w_cam0.empty()) return out;
  out.reserve(T_w_cam0.size());
  const Eigen::Isometry3d T_cam0_w = T_w_cam0.front().inverse();
  const Eigen::Isometry3d T_cl_b = T_b_cl.inverse();
  for (const Eigen::Isometry3d& T : T_w_cam0) out.push_back(T_b_cl * (T_cam0_w * T) * T_cl_b);
  return out;
}

Status KittiReadOptions::validate() const {
  if (max_frames && *max_frames < 1) {
    return Status::error("max_frames = " + std::to_string(*max_frames) + "; must be >= 1");
  }
  return Status::ok();
}

Status loadKittiSequence(const std::string& dir,
                         KittiSequence* sequence,
                         const KittiReadOptions& options) {
  if (sequence == nullptr) return Status::error("loadKittiSequence: null output");
  if (Status s = options.validate(); !s) return s;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return Status::error("input folder '" + dir + "' does not exist");
  if (!fs::is_directory(dir, ec)) return Status::error("input '" + dir + "' is not a folder");
  const fs::path root(dir);
  KittiSequence seq;
  seq.dir = dir;
  fs::path left_dir;
  fs::path right_dir;
  if (Status s = findImageDir(root, dir, "image_0", "image_l", "left", &left_dir); !s) return s;
  if (Status s = findImageDir(root, dir, "image_1", "image_r", "right", &right_dir); !s) return s;
  seq.left_dir = left_dir.string();
  seq.right_dir = right_dir.string();
  const std::vector<std::string> left = pngNames(left_dir);
  const std::vector<std::string> right = pngNames(right_dir);
  if (left.empty()) return Status::error("image folder " + seq.left_dir + " has no PNG images");
  if (right.empty()) return Status::error("image folder " + seq.right_dir + " has no PNG images");
  if (Status s = checkNames(left, right, left_dir, right_dir); !s) return s;
  seq.pairs_available = static_cast<int>(left.size());
  const int n =
      options.max_frames ? std::min(*options.max_frames, seq.pairs_available) : seq.pairs_available;
  const bool at_least = options.max_frames.has_value();
  for (int k = 0; k < n; ++k) {
    seq.left_paths.push_back((left_dir / left[static_cast<size_t>(k)]).string());
    seq.right_paths.push_back((right_dir / right[static_cast<size_t>(k)]).string());
  }

  cv::Mat first;
  {
    const QuietStderr quiet;  // libpng's own message for a corrupt file; ours follows
    try {
      first = cv::imread(seq.left_paths.front(), cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception&) {
      first = cv::Mat();
    }
  }
  if (first.empty()) return Status::error("cannot read image " + seq.left_paths.front());
  if (Status s =
          loadKittiCalibration((root / "calib.txt").string(), first.cols, first.rows, &seq.rig);
      !s)
    return s;

  const fs::path times = root / "times.txt";
  if (fs::exists(times, ec)) {
    std::vector<int64_t> t_ns;
    if (Status s = loadKittiTimes(times.string(), &t_ns); !s) return s;
    if (Status s =
            checkCount(times.string(), t_ns.size(), at_least ? n : seq.pairs_available, at_least);
        !s)
      return s;
    t_ns.resize(static_cast<size_t>(n));
    seq.t_ns = std::move(t_ns);
    seq.has_times = true;
  } else {
    for (int k = 0; k < n; ++k)
      seq.t_ns.push_back(std::llround(static_cast<double>(k) * 1e9 / kKittiFrameRateHz));
  }

  const fs::path poses = root / "poses.txt";
  if (fs::exists(poses, ec)) {
    std::vector<Eigen::Isometry3d> T_w_cam0;
    if (Status s = loadKittiPoses(poses.string(), &T_w_cam0); !s) return s;
    if (Status s = checkCount(
            poses.string(), T_w_cam0.size(), at_least ? n : seq.pairs_available, at_least);
        !s)
      return s;
    T_w_cam0.resize(static_cast<size_t>(n));
    seq.T_w_b = kittiBodyPoses(T_w_cam0, seq.rig.T_b_cl);
  }
  *sequence = std::move(seq);
  return Status::ok();
}

}  // namespace twocam::io
