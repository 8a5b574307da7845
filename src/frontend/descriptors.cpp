#include "frontend/descriptors.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/features2d.hpp>

#include "common/options_check.h"
#include "frontend/cv_interop.h"

namespace twocam::frontend {

namespace {

/// OpenCV ORB's defaults for the descriptor: a 31 px sampling patch, and the edge threshold it
/// drops keypoints within (>= the patch's radius rotated).
constexpr int kOrbPatchSizePx = 31;
constexpr int kOrbEdgeThresholdPx = 31;
constexpr int kOrbBytes = 32;
constexpr int kPatchValues = kPatchGrid * kPatchGrid;
/// Quantisation: the largest |value| of a zero-mean patch maps to +-127.
constexpr double kInt8Max = 127.0;

bool patchDescriptor(const ImageU8& image,
                     const Corner& c,
                     const DescriptorOptions& o,
                     Descriptor* out) {
  const int half = o.patch_size_px / 2;
  const int cell = o.patch_size_px / kPatchGrid;
  const int u0 = c.u_px - half, v0 = c.v_px - half;
  std::array<double, kPatchValues> cells{};
  double sum = 0.0, sum2 = 0.0;
  for (int y = 0; y < o.patch_size_px; ++y) {
    const uint8_t* row = image.row(v0 + y) + u0;
    for (int x = 0; x < o.patch_size_px; ++x) {
      const double g = row[x];
      cells[static_cast<size_t>((y / cell) * kPatchGrid + x / cell)] += g;
      sum += g;
      sum2 += g * g;
    }
  }
  const double n = static_cast<double>(o.patch_size_px) * o.patch_size_px;
  const double mean = sum / n;
  const double var = std::max(0.0, sum2 / n - mean * mean);
  if (std::sqrt(var) < o.min_patch_std_grey) return false;
  const double cell_mean = mean * cell * cell;
  double max_abs = 0.0;
  for (double& v : cells) {
    v -= cell_mean;
    max_abs = std::max(max_abs, std::abs(v));
  }
  if (max_abs <= 0.0) return false;
  out->kind = DescriptorKind::kPatch;
  out->bytes.fill(0);
  for (int i = 0; i < kPatchValues; ++i) {
    const auto q =
        static_cast<int8_t>(std::lround(cells[static_cast<size_t>(i)] / max_abs * kInt8Max));
    out->bytes[static_cast<size_t>(i)] = static_cast<uint8_t>(q);
  }
  return true;
}

}  // namespace

Status parseDescriptorKind(const std::string& name, DescriptorKind* kind) {
  if (name == "orb") {
    *kind = DescriptorKind::kOrb;
  } else if (name == "patch") {
    *kind = DescriptorKind::kPatch;
  } else {
    return Status::error("descriptor '" + name + "': must be orb or patch");
  }
  return Status::ok();
}

const char* descriptorKindName(DescriptorKind kind) {
  return kind == DescriptorKind::kOrb ? "orb" : "patch";
}

int descriptorBytes(DescriptorKind kind) {
  return kind == DescriptorKind::kOrb ? kOrbBytes : kPatchValues;
}

Status DescriptorOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "patch_size_px", patch_size_px, kPatchGrid, 8 * kPatchGrid, "px");
      !s)
    return s;
  if (patch_size_px % kPatchGrid != 0) {
    return Status::error(p + "patch_size_px = " + std::to_string(patch_size_px) +
                         "; must be a multiple of " + std::to_string(kPatchGrid));
  }
  return checkRange(p + "min_patch_std_grey", min_patch_std_grey, 0.0, 128.0, "grey");
}

int descriptorBorderPx(const DescriptorOptions& options) {
  return options.kind == DescriptorKind::kOrb ? kOrbEdgeThresholdPx : options.patch_size_px / 2;
}

Status describeCorners(const ImageU8& left,
                       const std::vector<Corner>& corners,
                       const DescriptorOptions& options,
                       DescribedCorners* out) {
  if (Status s = options.validate(); !s) return s;
  if (left.empty()) return Status::error("describeCorners: the image is empty");
  out->descriptors.clear();
  out->kept.clear();
  out->dropped.clear();
  const int border = descriptorBorderPx(options);
  auto inside = [&](const Corner& c) {
    return c.u_px >= border && c.v_px >= border && c.u_px + border <= left.width &&
           c.v_px + border <= left.height;
  };

  if (options.kind == DescriptorKind::kPatch) {
    Descriptor d;
    for (size_t i = 0; i < corners.size(); ++i) {
      if (inside(corners[i]) && patchDescriptor(left, corners[i], options, &d)) {
        out->descriptors.push_back(d);
        out->kept.push_back(static_cast<uint32_t>(i));
      } else {
        out->dropped.push_back(static_cast<uint32_t>(i));
      }
    }
    return Status::ok();
  }

  // ORB: one pyramid level, the given corners as keypoints at angle 0. OpenCV drops keypoints
  // within its edge threshold; class_id carries the input index through.
  std::vector<cv::KeyPoint> keypoints;
  keypoints.reserve(corners.size());
  std::vector<uint8_t> has(corners.size(), 0);
  for (size_t i = 0; i < corners.size(); ++i) {
    cv::KeyPoint k(static_cast<float>(corners[i].u_px),
                   static_cast<float>(corners[i].v_px),
                   static_cast<float>(kOrbPatchSizePx),
                   0.0f,
                   corners[i].response,
                   0,
                   static_cast<int>(i));
    keypoints.push_back(k);
  }
  cv::Ptr<cv::ORB> orb = cv::ORB::create(static_cast<int>(std::max<size_t>(1, corners.size())),
                                         1.2f,
                                         1,
                                         kOrbEdgeThresholdPx,
                                         0,
                                         2,
                                         cv::ORB::HARRIS_SCORE,
                                         kOrbPatchSizePx);
  cv::Mat desc;
  if (!keypoints.empty()) orb->compute(asMat(left), keypoints, desc);
  TWOCAM_CHECK(desc.empty() ||
               (desc.cols == kOrbBytes && desc.rows == static_cast<int>(keypoints.size())))
      << "ORB returned " << desc.rows << " x " << desc.cols;
  std::vector<int> row_of(corners.size(), -1);
  for (size_t r = 0; r < keypoints.size() && !desc.empty(); ++r) {
    const int i = keypoints[r].class_id;
    TWOCAM_CHECK(i >= 0 && static_cast<size_t>(i) < corners.size()) << "class_id " << i;
    row_of[static_cast<size_t>(i)] = static_cast<int>(r);
  }
  for (size_t i = 0; i < corners.size(); ++i) {
    if (row_of[i] < 0) {
      out->dropped.push_back(static_cast<uint32_t>(i));
      continue;
    }
    Descriptor d;
    d.kind = DescriptorKind::kOrb;
    const uint8_t* src = desc.ptr<uint8_t>(row_of[i]);
    std::copy(src, src + kOrbBytes, d.bytes.begin());
    out->descriptors.push_back(d);
    out->kept.push_back(static_cast<uint32_t>(i));
  }
  return Status::ok();
}

int hammingDistance(const Descriptor& a, const Descriptor& b) {
  int bits = 0;
  for (int i = 0; i < kOrbBytes; i += 8) {
    uint64_t x = 0, y = 0;
    std::memcpy(&x, a.bytes.data() + i, 8);
    std::memcpy(&y, b.bytes.data() + i, 8);
    bits += __builtin_popcountll(x ^ y);
  }
  return bits;
}

double patchDistance(const Descriptor& a, const Descriptor& b) {
  int32_t ab = 0, aa = 0, bb = 0;
  for (int i = 0; i < kPatchValues; ++i) {
    const int32_t x = static_cast<int8_t>(a.bytes[static_cast<size_t>(i)]);
    const int32_t y = static_cast<int8_t>(b.bytes[static_cast<size_t>(i)]);
    ab += x * y;
    aa += x * x;
    bb += y * y;
  }
  if (aa == 0 || bb == 0) return 1.0;
  return 1.0 - ab / std::sqrt(static_cast<double>(aa) * static_cast<double>(bb));
}

double descriptorDistance(const Descriptor& a, const Descriptor& b) {
  TWOCAM_CHECK(a.kind == b.kind) << "descriptor kinds differ: " << descriptorKindName(a.kind)
                                 << " vs " << descriptorKindName(b.kind);
  if (a.kind == DescriptorKind::kOrb) return hammingDistance(a, b) / (8.0 * kOrbBytes);
  return patchDistance(a, b);
}

}  // namespace twocam::frontend
