#include "io/euroc.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <sstream>
#include <utility>
#include <vector>

namespace twocam::io {

namespace {

namespace fs = std::filesystem;

Status keyError(const std::string& file, const std::string& key, const std::string& what) {
  return Status::error(file + ": key '" + key + "' " + what);
}

// OpenCV FileStorage reads EuRoC's "%YAML:1.0" dialect natively (EuRoC wrote its files for
// it) and throws on syntax errors, but refuses a file without a %YAML directive; MRPT's yaml
// accepts all variants but warns on every "%YAML:1.0" file and continues after syntax errors.
// So: OpenCV, with the directive supplied when a file lacks one.
Status openYaml(const std::string& path, cv::FileStorage* storage) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::error(path + ": cannot open file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  if (text.empty()) return Status::error(path + ": file is empty");
  const bool add_directive = text.compare(0, 5, "%YAML") != 0;
  if (add_directive) text = "%YAML:1.0\n" + text;
  try {
    if (!storage->open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY)) {
      return Status::error(path + ": not a readable YAML file");
    }
  } catch (const cv::Exception& e) {
    // OpenCV 4.6's parser puts "(<line>): <what>" in `func` and its own function name in `err`.
    const std::string& detail = e.code == cv::Error::StsParseError ? e.func : e.err;
    int line = 0;
    char what[256] = {};
    if (e.code == cv::Error::StsParseError &&
        std::sscanf(detail.c_str(), "(%d): %255[^\n]", &line, what) == 2) {
      return Status::error(path + ":" + std::to_string(add_directive ? line - 1 : line) +
                           ": not valid YAML (" + what + ")");
    }
    return Status::error(path + ": not valid YAML (" + detail + ")");
  }
  if (storage->root().empty() || !storage->root().isMap()) {
    return Status::error(path + ": YAML top level is not a map of keys");
  }
  return Status::ok();
}

bool isNumber(const cv::FileNode& node) { return node.isInt() || node.isReal(); }

// The helpers below look `key` up in `parent` and name it `path` (e.g. "T_BS.data") in errors.

// A sequence of exactly n numbers.
Status readNumbers(const cv::FileNode& parent,
                   const std::string& file,
                   const std::string& key,
                   const std::string& path,
                   size_t n,
                   std::vector<double>* values) {
  const cv::FileNode node = parent[key];
  if (node.empty()) return keyError(file, path, "is missing");
  if (!node.isSeq()) return keyError(file, path, "must be a sequence of numbers");
  if (node.size() != n) {
    return keyError(
        file,
        path,
        "has " + std::to_string(node.size()) + " values; expected " + std::to_string(n));
  }
  values->clear();
  for (size_t i = 0; i < n; ++i) {
    const cv::FileNode item = node[static_cast<int>(i)];
    if (!isNumber(item)) {
      return keyError(file, path, "element " + std::to_string(i) + " is not a number");
    }
    values->push_back(static_cast<double>(item));
  }
  return Status::ok();
}

Status readInt(const cv::FileNode& parent,
               const std::string& file,
               const std::string& key,
               const std::string& path,
               int* value) {
  const cv::FileNode node = parent[key];
  if (node.empty()) return keyError(file, path, "is missing");
  if (!node.isInt()) return keyError(file, path, "must be an integer");
  *value = static_cast<int>(node);
  return Status::ok();
}

Status readString(const cv::FileNode& parent,
                  const std::string& file,
                  const std::string& key,
                  std::string* value) {
  const cv::FileNode node = parent[key];
  if (node.empty()) return keyError(file, key, "is missing");
  if (!node.isString()) return keyError(file, key, "must be a string");
  *value = static_cast<std::string>(node);
  return Status::ok();
}

Status readTransform(const cv::FileNode& root, const std::string& file, Eigen::Isometry3d* T) {
  const std::string key = "T_BS";
  const cv::FileNode node = root[key];
  if (node.empty()) return keyError(file, key, "is missing");
  if (!node.isMap()) return keyError(file, key, "must be a map with rows, cols and data");
  int rows = 0;
  int cols = 0;
  if (Status s = readInt(node, file, "rows", key + ".rows", &rows); !s) return s;
  if (Status s = readInt(node, file, "cols", key + ".cols", &cols); !s) return s;
  if (rows != 4 || cols != 4) {
    return keyError(
        file, key, "is " + std::to_string(rows) + "x" + std::to_string(cols) + "; expected 4x4");
  }
  std::vector<double> d;
  if (Status s = readNumbers(node, file, "data", key + ".data", 16, &d); !s) return s;
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = d[static_cast<size_t>(4 * r + c)];
  // Rigid transforms end in the row 0 0 0 1; EuRoC prints it exactly.
  constexpr double kBottomRowTol = 1e-9;
  if (!M.allFinite() ||
      !((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() < kBottomRowTol)) {
    return keyError(file, key, "is not a rigid transform (last row must be 0 0 0 1)");
  }
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  // Calibration files print ~10 significant digits; 1e-6 accepts that rounding and rejects
  // matrices that are not rotations.
  constexpr double kRotationTol = 1e-6;
  const double orthonormality_error =
      (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthonormality_error < kRotationTol) || !(R.determinant() > 0.0)) {
    std::ostringstream os;
    os << "is not a rigid transform (rotation part: |R^T R - I|max = " << orthonormality_error
       << ", det = " << R.determinant() << ")";
    return keyError(file, key, os.str());
  }
  T->setIdentity();
  // Remove the print rounding so that inverses and products stay exact rotations.
  T->linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T->translation() = M.topRightCorner<3, 1>();
  return Status::ok();
}

// Splits "a,b" into trimmed fields; returns false unless there are exactly two.
bool splitCsvLine(const std::string& line, std::string* first, std::string* second) {
  const size_t comma = line.find(',');
  if (comma == std::string::npos || line.find(',', comma + 1) != std::string::npos) return false;
  auto trim = [](std::string s) {
    const char* ws = " \t\r\n";
    const size_t b = s.find_first_not_of(ws);
    if (b == std::string::npos) return std::string();
    return s.substr(b, s.find_last_not_of(ws) - b + 1);
  };
  *first = trim(line.substr(0, comma));
  *second = trim(line.substr(comma + 1));
  return !first->empty() && !second->empty();
}

struct CameraList {
  std::vector<int64_t> t_ns;
  std::vector<std::string> paths;
};

Status readDataCsv(const fs::path& cam_dir, CameraList* list) {
  const fs::path csv = cam_dir / "data.csv";
  const std::string file = csv.string();
  std::ifstream in(csv);
  if (!in) return Status::error(file + ": cannot open file");
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::string where = file + ":" + std::to_string(line_no) + ": ";
    std::string stamp;
    std::string name;
    if (!splitCsvLine(line, &stamp, &name)) {
      return Status::error(where + "expected '<timestamp [ns]>,<filename>', got '" + line + "'");
    }
    char* end = nullptr;
    errno = 0;
    const long long t = std::strtoll(stamp.c_str(), &end, 10);
    if (errno != 0 || end == stamp.c_str() || *end != '\0' || t < 0) {
      return Status::error(where + "timestamp '" + stamp + "' is not a non-negative integer [ns]");
    }
    if (!list->t_ns.empty() && t <= list->t_ns.back()) {
      return Status::error(where + "timestamp " + stamp + " does not increase (previous " +
                           std::to_string(list->t_ns.back()) + ")");
    }
    const fs::path image = cam_dir / "data" / name;
    if (!fs::is_regular_file(image)) {
      return Status::error(where + "listed image " + image.string() + " does not exist");
    }
    list->t_ns.push_back(static_cast<int64_t>(t));
    list->paths.push_back(image.string());
  }
  if (list->t_ns.empty()) return Status::error(file + ": lists no images");
  return Status::ok();
}

}  // namespace

Status loadEurocCamera(const std::string& sensor_yaml, CameraCalibration* calibration) {
  if (calibration == nullptr) return Status::error("loadEurocCamera: null output");
  const std::string& file = sensor_yaml;
  cv::FileStorage storage;
  if (Status s = openYaml(file, &storage); !s) return s;
  const cv::FileNode root = storage.root();

  CameraCalibration cal;
  std::string text;
  if (!root["sensor_type"].empty()) {
    if (Status s = readString(root, file, "sensor_type", &text); !s) return s;
    if (text != "camera")
      return keyError(file, "sensor_type", "is '" + text + "'; expected 'camera'");
  }
  if (!root["camera_model"].empty()) {
    if (Status s = readString(root, file, "camera_model", &text); !s) return s;
    if (text != "pinhole") {
      return keyError(file, "camera_model", "is '" + text + "'; only 'pinhole' is supported");
    }
  }
  std::vector<double> values;
  if (Status s = readNumbers(root, file, "resolution", "resolution", 2, &values); !s) return s;
  if (values[0] != static_cast<int>(values[0]) || values[1] != static_cast<int>(values[1]) ||
      !(values[0] > 0) || !(values[1] > 0)) {
    return keyError(file, "resolution", "must be two positive integers [width, height]");
  }
  cal.width = static_cast<int>(values[0]);
  cal.height = static_cast<int>(values[1]);

  if (Status s = readNumbers(root, file, "intrinsics", "intrinsics", 4, &values); !s) return s;
  cal.fx = values[0];
  cal.fy = values[1];
  cal.cx = values[2];
  cal.cy = values[3];

  if (Status s = readString(root, file, "distortion_model", &text); !s) return s;
  if (text != "radial-tangential" && text != "radtan" && text != "plumb_bob") {
    return keyError(file,
                    "distortion_model",
                    "is '" + text + "'; only 'radial-tangential' (4 coefficients) is supported");
  }
  if (Status s =
          readNumbers(root, file, "distortion_coefficients", "distortion_coefficients", 4, &values);
      !s)
    return s;
  std::copy(values.begin(), values.end(), cal.radtan.begin());

  if (Status s = readTransform(root, file, &cal.T_b_c); !s) return s;

  if (!root["rate_hz"].empty()) {
    if (!isNumber(root["rate_hz"]) || !(static_cast<double>(root["rate_hz"]) >= 0.0)) {
      return keyError(file, "rate_hz", "must be a non-negative number");
    }
    cal.rate_hz = static_cast<double>(root["rate_hz"]);
  }
  if (Status s = cal.validate(); !s) return Status::error(file + ": " + s.message());
  *calibration = cal;
  return Status::ok();
}

Status loadEurocStereoCalibration(const std::string& mav0_dir,
                                  CameraCalibration* left,
                                  CameraCalibration* right) {
  if (left == nullptr || right == nullptr)
    return Status::error("loadEurocStereoCalibration: null output");
  const fs::path root(mav0_dir);
  if (!fs::is_directory(root)) return Status::error(mav0_dir + ": not a directory");
  CameraCalibration l;
  CameraCalibration r;
  if (Status s = loadEurocCamera((root / "cam0" / "sensor.yaml").string(), &l); !s) return s;
  if (Status s = loadEurocCamera((root / "cam1" / "sensor.yaml").string(), &r); !s) return s;
  if (l.width != r.width || l.height != r.height) {
    std::ostringstream os;
    os << mav0_dir << ": cam0 is " << l.width << "x" << l.height << " px but cam1 is " << r.width
       << "x" << r.height << " px; a stereo pair needs equal image sizes";
    return Status::error(os.str());
  }
  *left = l;
  *right = r;
  return Status::ok();
}

Status EurocIndexOptions::validate() const {
  if (max_pair_offset_ns < 0) {
    return Status::error("max_pair_offset_ns = " + std::to_string(max_pair_offset_ns) +
                         "; must be >= 0");
  }
  return Status::ok();
}

Status loadEurocStereoIndex(const std::string& mav0_dir,
                            EurocStereoIndex* index,
                            const EurocIndexOptions& options) {
  if (index == nullptr) return Status::error("loadEurocStereoIndex: null output");
  if (Status s = options.validate(); !s) return s;
  const fs::path root(mav0_dir);
  if (!fs::is_directory(root)) return Status::error(mav0_dir + ": not a directory");
  CameraList left;
  CameraList right;
  if (Status s = readDataCsv(root / "cam0", &left); !s) return s;
  if (Status s = readDataCsv(root / "cam1", &right); !s) return s;

  // Both lists increase strictly: a merge pairs each stamp with at most one partner.
  EurocStereoIndex out;
  size_t i = 0;
  size_t j = 0;
  while (i < left.t_ns.size() && j < right.t_ns.size()) {
    const int64_t dt = left.t_ns[i] - right.t_ns[j];
    if (std::abs(dt) <= options.max_pair_offset_ns) {
      out.t_ns.push_back(left.t_ns[i]);
      out.left_paths.push_back(left.paths[i]);
      out.right_paths.push_back(right.paths[j]);
      ++i;
      ++j;
    } else if (dt < 0) {
      out.unmatched_left_t_ns.push_back(left.t_ns[i++]);
    } else {
      out.unmatched_right_t_ns.push_back(right.t_ns[j++]);
    }
  }
  for (; i < left.t_ns.size(); ++i) out.unmatched_left_t_ns.push_back(left.t_ns[i]);
  for (; j < right.t_ns.size(); ++j) out.unmatched_right_t_ns.push_back(right.t_ns[j]);
  if (out.t_ns.empty()) {
    return Status::error(mav0_dir + ": no cam0 and cam1 images share a time stamp (within " +
                         std::to_string(options.max_pair_offset_ns) + " ns)");
  }
  *index = std::move(out);
  return Status::ok();
}

}  // namespace twocam::io
