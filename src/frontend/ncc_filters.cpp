#include "frontend/ncc_scaled.h"
/// The scaled-window NCC matcher's post-filters: median rejection and the NCC-weighted bilateral
/// filter (ncc_scaled.h).

#include <algorithm>
#include <cmath>
#include <sstream>

#include "frontend/dense_sad.h"  // kNoDisparity
#include "frontend/ncc_scaled_internal.h"

namespace twocam::frontend {

namespace {

using internal::ncc_scaled::kMaxSubpixelSteps;

// Largest disparity value the median-rejection histogram accepts [px].
constexpr float kMaxMedianValuePx = 4096.0f;
// Range weights of the bilateral filter are tabulated in steps of 1/kRangeLutPerPx px up to
// kRangeLutSigmas sigmas (the weight there is exp(-18) ~ 1.5e-8; beyond, 0).
constexpr float kRangeLutPerPx = 256.0f;
constexpr float kRangeLutSigmas = 6.0f;

Status checkMap(const ImageF32* map, const char* who) {
  if (map == nullptr) return Status::error(std::string(who) + ": disparity is null");
  if (map->empty() || map->width <= 0 || map->height <= 0 ||
      map->data.size() != static_cast<size_t>(map->width) * map->height) {
    return Status::error(std::string(who) + ": disparity map is empty or inconsistent");
  }
  return Status::ok();
}

}  // namespace

Status medianRejectDisparity(int size_px, float threshold_px, int steps, ImageF32* disparity) {
  constexpr const char* kWho = "medianRejectDisparity";
  if (Status s = checkMap(disparity, kWho); !s) return s;
  if (size_px < 1 || size_px % 2 == 0) {
    return Status::error(std::string(kWho) + ": size_px = " + std::to_string(size_px) +
                         "; must be odd and >= 1");
  }
  if (steps < 1 || steps > kMaxSubpixelSteps) {
    return Status::error(std::string(kWho) + ": steps = " + std::to_string(steps) +
                         "; must be in [1, 64]");
  }
  if (!(threshold_px > 0.0f) || !std::isfinite(threshold_px)) {
    std::ostringstream msg;
    msg << kWho << ": threshold_px = " << threshold_px << "; must be finite and > 0";
    return Status::error(msg.str());
  }
  const int width = disparity->width;
  const int height = disparity->height;
  const size_t pixels = disparity->data.size();
  std::vector<int32_t> codes(pixels, -1);
  int32_t max_code = 0;
  for (size_t p = 0; p < pixels; ++p) {
    const float d = disparity->data[p];
    if (!(d >= 0.0f)) continue;
    if (!(d <= kMaxMedianValuePx)) {
      std::ostringstream msg;
      msg << kWho << ": disparity " << d << " px at pixel (" << p % width << ", " << p / width
          << ") exceeds " << kMaxMedianValuePx << " px";
      return Status::error(msg.str());
    }
    codes[p] = static_cast<int32_t>(std::lround(d * static_cast<float>(steps)));
    max_code = std::max(max_code, codes[p]);
  }
  const int r = size_px / 2;
  std::vector<int32_t> hist(static_cast<size_t>(max_code) + 1);
  ImageF32 out = *disparity;
  for (int v = 0; v < height; ++v) {
    const int y0 = std::max(0, v - r);
    const int y1 = std::min(height - 1, v + r);
    std::fill(hist.begin(), hist.end(), 0);
    int count = 0;
    int below = 0;  // values in bins < m
    int m = 0;
    auto column = [&](int x, int delta) {
      for (int y = y0; y <= y1; ++y) {
        const int32_t c = codes[static_cast<size_t>(y) * width + x];
        if (c < 0) continue;
        hist[c] += delta;
        count += delta;
        if (c < m) below += delta;
      }
    };
    for (int x = 0; x < std::min(r, width); ++x) column(x, +1);
    for (int u = 0; u < width; ++u) {
      if (u + r < width) column(u + r, +1);
      if (u - r - 1 >= 0) column(u - r - 1, -1);
      const int32_t c = codes[static_cast<size_t>(v) * width + u];
      if (c < 0) continue;
      const int need = (count + 1) / 2;  // rank of the (lower) median, 1-based
      while (below + hist[m] < need) below += hist[m++];
      while (below >= need) below -= hist[--m];
      const float median = static_cast<float>(m) / static_cast<float>(steps);
      if (std::abs(disparity->data[static_cast<size_t>(v) * width + u] - median) > threshold_px) {
        out.data[static_cast<size_t>(v) * width + u] = kNoDisparity;
      }
    }
  }
  *disparity = std::move(out);
  return Status::ok();
}

Status nccBilateralFilter(const ImageF32& ncc,
                          int size_px,
                          float sigma_space_px,
                          float sigma_range_px,
                          ImageF32* disparity) {
  constexpr const char* kWho = "nccBilateralFilter";
  if (Status s = checkMap(disparity, kWho); !s) return s;
  if (ncc.width != disparity->width || ncc.height != disparity->height ||
      ncc.data.size() != disparity->data.size()) {
    return Status::error(std::string(kWho) + ": NCC image and disparity map differ in size");
  }
  if (size_px < 1 || size_px % 2 == 0) {
    return Status::error(std::string(kWho) + ": size_px = " + std::to_string(size_px) +
                         "; must be odd and >= 1");
  }
  if (!(sigma_space_px > 0.0f) || !(sigma_range_px > 0.0f) || !std::isfinite(sigma_space_px) ||
      !std::isfinite(sigma_range_px)) {
    std::ostringstream msg;
    msg << kWho << ": sigma_space_px = " << sigma_space_px
        << ", sigma_range_px = " << sigma_range_px << "; both must be finite and > 0";
    return Status::error(msg.str());
  }
  const int width = disparity->width;
  const int height = disparity->height;
  const int r = size_px / 2;
  std::vector<float> space(static_cast<size_t>(size_px) * size_px);
  for (int j = -r; j <= r; ++j) {
    for (int i = -r; i <= r; ++i) {
      space[static_cast<size_t>(j + r) * size_px + (i + r)] =
          std::exp(-static_cast<float>(i * i + j * j) / (2.0f * sigma_space_px * sigma_space_px));
    }
  }
  const int range_bins =
      static_cast<int>(std::ceil(kRangeLutSigmas * sigma_range_px * kRangeLutPerPx)) + 2;
  std::vector<float> range(range_bins, 0.0f);
  for (int b = 0; b + 1 < range_bins; ++b) {
    const float x = static_cast<float>(b) / kRangeLutPerPx / sigma_range_px;
    range[b] = std::exp(-0.5f * x * x);
  }
  // Confidence per pixel: max(NCC, 0) where there is an estimate, 0 elsewhere, so the inner
  // loop needs no test.
  const size_t pixels = disparity->data.size();
  std::vector<float> conf(pixels);
  std::vector<float> value(pixels);
  for (size_t p = 0; p < pixels; ++p) {
    const float d = disparity->data[p];
    const bool has = d >= 0.0f && std::isfinite(d);
    conf[p] = has ? std::max(0.0f, ncc.data[p]) : 0.0f;
    value[p] = has ? d : 0.0f;
  }
  ImageF32 out = *disparity;
  const float lut_scale = kRangeLutPerPx;
  const float lut_max = static_cast<float>(range_bins - 1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const size_t p = static_cast<size_t>(v) * width + u;
      const float dp = disparity->data[p];
      if (!(dp >= 0.0f) || !std::isfinite(dp)) continue;
      float sum = 0.0f;
      float wsum = 0.0f;
      const int y0 = std::max(0, v - r);
      const int y1 = std::min(height - 1, v + r);
      const int x0 = std::max(0, u - r);
      const int x1 = std::min(width - 1, u + r);
      for (int y = y0; y <= y1; ++y) {
        const float* vr = value.data() + static_cast<size_t>(y) * width;
        const float* cr = conf.data() + static_cast<size_t>(y) * width;
        const float* sr = space.data() + static_cast<size_t>(y - v + r) * size_px + (r - u);
        for (int x = x0; x <= x1; ++x) {
          const float bin = std::min(std::abs(vr[x] - dp) * lut_scale + 0.5f, lut_max);
          const float w = sr[x] * cr[x] * range[static_cast<int>(bin)];
          sum += w * vr[x];
          wsum += w;
        }
      }
      if (wsum > 0.0f) out.data[p] = sum / wsum;
    }
  }
  *disparity = std::move(out);
  return Status::ok();
}

}  // namespace twocam::frontend
