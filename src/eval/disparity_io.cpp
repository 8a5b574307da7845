#include "eval/disparity_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string_view>
#include <system_error>

namespace twocam::eval {

namespace {

/// Largest PFM side we accept [px]: far above any stereo benchmark, small enough that
/// width * height * 4 cannot overflow and a corrupt header cannot ask for terabytes.
constexpr int64_t kMaxPfmSidePx = 1 << 16;

bool hostIsLittleEndian() {
  const uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

Status readWholeFile(const std::string& path, std::string* bytes) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return Status::error(path + ": no such file");
  std::ifstream f(path, std::ios::binary);
  if (!f) return Status::error(path + ": cannot open");
  bytes->assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  if (f.bad()) return Status::error(path + ": read error");
  return Status::ok();
}

bool isPfmSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

/// Next whitespace-separated header token starting at *pos (leading whitespace skipped).
std::string_view nextToken(const std::string& bytes, size_t* pos) {
  while (*pos < bytes.size() && isPfmSpace(bytes[*pos])) ++*pos;
  const size_t begin = *pos;
  while (*pos < bytes.size() && !isPfmSpace(bytes[*pos])) ++*pos;
  return std::string_view(bytes).substr(begin, *pos - begin);
}

bool parseInt(std::string_view token, int64_t* value) {
  if (token.empty()) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size();
}

bool parseDouble(std::string_view token, double* value) {
  if (token.empty()) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size();
}

Status parsePfm(const std::string& path, const std::string& bytes, ImageF32* image) {
  size_t pos = 0;
  const std::string_view magic = nextToken(bytes, &pos);
  if (magic == "PF") {
    return Status::error(path +
                         ": three-channel PFM (\"PF\"); a disparity map must be single-channel "
                         "(\"Pf\")");
  }
  if (magic != "Pf") return Status::error(path + ": not a PFM file (header does not start \"Pf\")");
  int64_t width = 0;
  int64_t height = 0;
  const std::string_view w_token = nextToken(bytes, &pos);
  const std::string_view h_token = nextToken(bytes, &pos);
  if (!parseInt(w_token, &width) || !parseInt(h_token, &height)) {
    return Status::error(path + ": PFM header has no valid \"width height\" line");
  }
  if (width <= 0 || height <= 0 || width > kMaxPfmSidePx || height > kMaxPfmSidePx) {
    return Status::error(path + ": PFM size " + std::to_string(width) + "x" +
                         std::to_string(height) + " out of range [1, " +
                         std::to_string(kMaxPfmSidePx) + "]");
  }
  double scale = 0.0;
  if (!parseDouble(nextToken(bytes, &pos), &scale) || !std::isfinite(scale) || scale == 0.0) {
    return Status::error(path + ": PFM scale/endianness field missing, zero or not a number");
  }
  // Exactly one whitespace byte separates the header from the raster.
  if (pos >= bytes.size() || !isPfmSpace(bytes[pos])) {
    return Status::error(path + ": PFM header not terminated (truncated file)");
  }
  ++pos;
  const uint64_t expected = static_cast<uint64_t>(width) * static_cast<uint64_t>(height) * 4u;
  const uint64_t available = bytes.size() - pos;
  if (available != expected) {
    return Status::error(path + ": PFM raster has " + std::to_string(available) +
                         " bytes, header says " + std::to_string(expected) +
                         (available < expected ? " (truncated file)" : " (trailing data)"));
  }
  const bool file_little = scale < 0.0;
  const bool swap = file_little != hostIsLittleEndian();
  const int w = static_cast<int>(width);
  const int h = static_cast<int>(height);
  *image = ImageF32(w, h);
  const char* src = bytes.data() + pos;
  for (int file_row = 0; file_row < h; ++file_row) {
    // PFM stores the bottom row first.
    float* dst = image->row(h - 1 - file_row);
    for (int u = 0; u < w; ++u, src += 4) {
      unsigned char b[4];
      std::memcpy(b, src, 4);
      if (swap) {
        std::swap(b[0], b[3]);
        std::swap(b[1], b[2]);
      }
      std::memcpy(dst + u, b, 4);
    }
  }
  return Status::ok();
}

bool looksLikePfm(const std::string& bytes) {
  return bytes.size() >= 3 && bytes[0] == 'P' && (bytes[1] == 'f' || bytes[1] == 'F') &&
         isPfmSpace(bytes[2]);
}

/// Decodes a PNG/PGM/... with OpenCV keeping its bit depth. Errors name the path.
Status decodeRaster(const std::string& path, const std::string& bytes, cv::Mat* mat) {
  if (bytes.empty()) return Status::error(path + ": empty file");
  try {
    const cv::Mat buffer(
        1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
    *mat = cv::imdecode(buffer, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return Status::error(path + ": cannot decode image (" + e.what() + ")");
  }
  if (mat->empty()) return Status::error(path + ": not a readable image file (or truncated)");
  return Status::ok();
}

void setInvalid(DisparityGroundTruth* gt, int u, int v) {
  gt->d_px(u, v) = 0.0f;
  gt->valid(u, v) = 0;
}

}  // namespace

Status readPfm(const std::string& path, ImageF32* image) {
  std::string bytes;
  if (Status s = readWholeFile(path, &bytes); !s) return s;
  return parsePfm(path, bytes, image);
}

Status writePfm(const std::string& path, const ImageF32& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.data.size() != static_cast<size_t>(image.width) * image.height) {
    return Status::error(path + ": cannot write an empty or inconsistent image as PFM");
  }
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) return Status::error(path + ": cannot open for writing");
  f << "Pf\n" << image.width << ' ' << image.height << "\n-1\n";
  const bool swap = !hostIsLittleEndian();
  std::string row(static_cast<size_t>(image.width) * 4u, '\0');
  for (int v = image.height - 1; v >= 0; --v) {
    const float* src = image.row(v);
    for (int u = 0; u < image.width; ++u) {
      unsigned char b[4];
      std::memcpy(b, src + u, 4);
      if (swap) {
        std::swap(b[0], b[3]);
        std::swap(b[1], b[2]);
      }
      std::memcpy(&row[static_cast<size_t>(u) * 4u], b, 4);
    }
    f.write(row.data(), static_cast<std::streamsize>(row.size()));
  }
  f.flush();
  if (!f) return Status::error(path + ": write failed");
  return Status::ok();
}

Status loadDisparityGroundTruth(const std::string& path,
                                double scale,
                                std::optional<double> invalid_value,
                                DisparityGroundTruth* gt) {
  if (!std::isfinite(scale) || scale <= 0.0) {
    return Status::error(path + ": scale = " + std::to_string(scale) + "; must be finite and > 0");
  }
  if (invalid_value && std::isnan(*invalid_value)) {
    return Status::error(path + ": invalid_value is NaN; give a number or none");
  }
  std::string bytes;
  if (Status s = readWholeFile(path, &bytes); !s) return s;

  if (looksLikePfm(bytes)) {
    ImageF32 raw;
    if (Status s = parsePfm(path, bytes, &raw); !s) return s;
    DisparityGroundTruth out{ImageF32(raw.width, raw.height), ImageU8(raw.width, raw.height, 1)};
    for (int v = 0; v < raw.height; ++v) {
      for (int u = 0; u < raw.width; ++u) {
        const float value = raw(u, v);
        const double d = static_cast<double>(value) / scale;
        if (!std::isfinite(value) || (invalid_value && value == *invalid_value) ||
            !std::isfinite(d) || d < 0.0) {
          setInvalid(&out, u, v);
        } else {
          out.d_px(u, v) = static_cast<float>(d);
        }
      }
    }
    *gt = std::move(out);
    return Status::ok();
  }

  cv::Mat mat;
  if (Status s = decodeRaster(path, bytes, &mat); !s) return s;
  if (mat.channels() != 1) {
    return Status::error(path + ": has " + std::to_string(mat.channels()) +
                         " channels; ground-truth disparity must be single-channel");
  }
  if (mat.depth() != CV_8U && mat.depth() != CV_16U) {
    return Status::error(path + ": unsupported pixel depth (want 8- or 16-bit unsigned, or PFM)");
  }
  const double invalid = invalid_value.value_or(0.0);
  DisparityGroundTruth out{ImageF32(mat.cols, mat.rows), ImageU8(mat.cols, mat.rows, 1)};
  for (int v = 0; v < mat.rows; ++v) {
    for (int u = 0; u < mat.cols; ++u) {
      const double value = mat.depth() == CV_8U ? mat.at<uint8_t>(v, u) : mat.at<uint16_t>(v, u);
      // Raw 0 stays invalid whatever invalid_value says: Middlebury v2 and KITTI write 0 for
      // unknown disparity, and an 8-bit map with --gt-invalid 255 would otherwise turn its
      // unknown pixels into valid disparity 0.
      if (value == invalid || value == 0.0) {
        setInvalid(&out, u, v);
      } else {
        out.d_px(u, v) = static_cast<float>(value / scale);
      }
    }
  }
  *gt = std::move(out);
  return Status::ok();
}

Status loadMask(const std::string& path, ImageU8* mask) {
  std::string bytes;
  if (Status s = readWholeFile(path, &bytes); !s) return s;
  cv::Mat mat;
  if (Status s = decodeRaster(path, bytes, &mat); !s) return s;
  if (mat.type() != CV_8UC1) {
    return Status::error(path + ": a mask must be an 8-bit single-channel image (255 = keep)");
  }
  ImageU8 out(mat.cols, mat.rows);
  for (int v = 0; v < mat.rows; ++v) std::copy_n(mat.ptr<uint8_t>(v), mat.cols, out.row(v));
  *mask = std::move(out);
  return Status::ok();
}

void nonOccludedMask(const DisparityGroundTruth& gt, ImageU8* mask) {
  const int w = gt.d_px.width;
  const int h = gt.d_px.height;
  ImageU8 out(w, h, 0);
  for (int v = 0; v < h; ++v) {
    double leftmost_landing = std::numeric_limits<double>::infinity();  // min_{u2>u} u2 - d(u2)
    for (int u = w - 1; u >= 0; --u) {
      if (gt.valid(u, v) == 0) continue;
      const double landing = static_cast<double>(u) - gt.d_px(u, v);
      const bool hidden = leftmost_landing <= landing - 0.5;
      out(u, v) = landing >= 0.0 && !hidden ? 255 : 128;
      leftmost_landing = std::min(leftmost_landing, landing);
    }
  }
  *mask = std::move(out);
}

Status disparityFromDepth(const ImageF32& depth_m, const StereoRig& rig, DisparityGroundTruth* gt) {
  if (depth_m.width <= 0 || depth_m.height <= 0 ||
      depth_m.data.size() != static_cast<size_t>(depth_m.width) * depth_m.height) {
    return Status::error("disparityFromDepth: depth image is empty or inconsistent");
  }
  if (!std::isfinite(rig.fx_px) || rig.fx_px <= 0.0 || !std::isfinite(rig.baseline_m) ||
      rig.baseline_m <= 0.0) {
    return Status::error("disparityFromDepth: rig fx_px = " + std::to_string(rig.fx_px) +
                         ", baseline_m = " + std::to_string(rig.baseline_m) +
                         "; both must be finite and > 0");
  }
  const int w = depth_m.width;
  const int h = depth_m.height;
  const double fx_b = rig.fx_px * rig.baseline_m;
  auto has_surface = [](float z) { return std::isfinite(z) && z > 0.0f; };
  DisparityGroundTruth out{ImageF32(w, h), ImageU8(w, h, 0)};
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float z = depth_m(u, v);
      if (!has_surface(z)) continue;
      float z_min = z;
      float z_max = z;
      bool edge_to_void = false;
      for (int dv = -1; dv <= 1 && !edge_to_void; ++dv) {
        const int vv = v + dv;
        if (vv < 0 || vv >= h) continue;
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du;
          if (uu < 0 || uu >= w) continue;
          const float zn = depth_m(uu, vv);
          if (!has_surface(zn)) {
            edge_to_void = true;
            break;
          }
          z_min = std::min(z_min, zn);
          z_max = std::max(z_max, zn);
        }
      }
      if (edge_to_void) continue;
      if (static_cast<double>(z_max) - z_min > kDepthDiscontinuityRelSpan * z_min) continue;
      out.d_px(u, v) = static_cast<float>(fx_b / z);
      out.valid(u, v) = 1;
    }
  }
  *gt = std::move(out);
  return Status::ok();
}

}  // namespace twocam::eval
