#include "frontend/ncc_scaled.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "frontend/dense_sad.h"  // kNoDisparity
#include "frontend/ncc_scaled_internal.h"

namespace twocam::frontend {

// The matcher's pieces (ncc_scaled_internal.h) by their short names.
using namespace internal::ncc_scaled;

namespace {

// The order in which scales compete: the square window first, so that ties keep it.
constexpr std::array<int, kNccScaleCount> kScaleOrder = {1, 0, 2};

/// NCC of a loaded primary window against reference samples at x_ref + scale * i (rows v + j),
/// linearly interpolated as a + f (b - a). NaN when a sample leaves the image or a window is
/// flat.
template <typename P>
float nccAgainst(const PrimaryWindow& w,
                 const P* ref,
                 int width,
                 int height,
                 int v,
                 double x_ref,
                 float scale,
                 int n,
                 float min_std) {
  const int h = n / 2;
  const double lo = x_ref - static_cast<double>(scale) * h;
  const double hi = x_ref + static_cast<double>(scale) * h;
  if (lo < -kPositionSlack || hi > width - 1 + kPositionSlack || v < h || v >= height - h) {
    return std::numeric_limits<float>::quiet_NaN();
  }
  if (w.inv_dev == 0.0f) return std::numeric_limits<float>::quiet_NaN();
  std::array<int, kMaxWindowPx> index{};
  std::array<float, kMaxWindowPx> frac{};
  for (int i = -h; i <= h; ++i) {
    const double x = std::clamp(x_ref + static_cast<double>(scale) * i, 0.0, width - 1.0);
    int ix = static_cast<int>(std::floor(x));
    float f = static_cast<float>(x - ix);
    if (ix >= width - 1) {
      ix = width - 1;
      f = 0.0f;
    }
    index[i + h] = ix;
    frac[i + h] = f;
  }
  float sum = 0.0f;
  float sum_sq = 0.0f;
  float cross = 0.0f;
  int k = 0;
  for (int j = -h; j <= h; ++j) {
    const P* row = ref + static_cast<size_t>(v + j) * width;
    for (int i = 0; i < n; ++i) {
      const int ix = index[i];
      const float a = centred(row[ix]);
      const float b = frac[i] > 0.0f ? centred(row[ix + 1]) : a;
      const float r = a + frac[i] * (b - a);
      sum += r;
      sum_sq += r * r;
      cross += w.values[k++] * r;
    }
  }
  const float inv_area = 1.0f / static_cast<float>(n * n);
  const float inv_ref = inverseDeviation(sum, sum_sq, inv_area, minVarianceSum(min_std, n * n));
  if (inv_ref == 0.0f) return std::numeric_limits<float>::quiet_NaN();
  return (cross - w.sum * sum * inv_area) * w.inv_dev * inv_ref;
}

}  // namespace

namespace internal::ncc_scaled {

Status checkPair(const ImageU8& left,
                 const ImageU8& right,
                 const NccScaledOptions& o,
                 const char* who) {
  if (Status s = o.validate(); !s) return Status::error("NccScaledOptions: " + s.message());
  if (left.empty() || right.empty() || left.width <= 0 || left.height <= 0) {
    return Status::error(std::string(who) + ": empty image");
  }
  if (left.width != right.width || left.height != right.height) {
    std::ostringstream msg;
    msg << who << ": left image is " << left.width << "x" << left.height << " but right image is "
        << right.width << "x" << right.height;
    return Status::error(msg.str());
  }
  const size_t pixels = static_cast<size_t>(left.width) * left.height;
  if (left.data.size() != pixels || right.data.size() != pixels) {
    return Status::error(std::string(who) + ": pixel count does not match the image size");
  }
  if (o.max_disparity_px >= left.width) {
    std::ostringstream msg;
    msg << who << ": max_disparity_px = " << o.max_disparity_px << " must be below the image width "
        << left.width;
    return Status::error(msg.str());
  }
  return Status::ok();
}

std::vector<int> activeScales(const NccScaledOptions& o) {
  if (!o.scaled_windows) return {1};
  return {kScaleOrder.begin(), kScaleOrder.end()};
}

}  // namespace internal::ncc_scaled

Status NccScaledOptions::validate() const {
  std::ostringstream msg;
  if (window_size_px < 3 || window_size_px > kMaxWindowPx || window_size_px % 2 == 0) {
    msg << "window_size_px = " << window_size_px << "; must be odd and in [3, " << kMaxWindowPx
        << "]";
  } else if (min_disparity_px < 0) {
    msg << "min_disparity_px = " << min_disparity_px << "; must be >= 0";
  } else if (max_disparity_px < min_disparity_px) {
    msg << "max_disparity_px = " << max_disparity_px
        << "; must be >= min_disparity_px = " << min_disparity_px;
  } else if (max_disparity_px > 4000) {
    msg << "max_disparity_px = " << max_disparity_px << "; must be <= 4000";
  } else if (!(ncc_threshold >= -1.0f && ncc_threshold <= 1.0f)) {
    msg << "ncc_threshold = " << ncc_threshold << "; must be in [-1, 1]";
  } else if (!(min_window_std >= 0.0f) || !std::isfinite(min_window_std)) {
    msg << "min_window_std = " << min_window_std << "; must be finite and >= 0 [grey levels]";
  } else if (subpixel_steps < 0 || subpixel_steps > kMaxSubpixelSteps) {
    msg << "subpixel_steps = " << subpixel_steps << "; must be in [0, " << kMaxSubpixelSteps << "]";
  } else if (median_size_px < 3 || median_size_px % 2 == 0 || median_size_px > 255) {
    msg << "median_size_px = " << median_size_px << "; must be odd and in [3, 255]";
  } else if (!(median_rejection_px > 0.0f) || !std::isfinite(median_rejection_px)) {
    msg << "median_rejection_px = " << median_rejection_px << "; must be finite and > 0 [px]";
  } else if (bilateral_size_px < 3 || bilateral_size_px % 2 == 0 || bilateral_size_px > 255) {
    msg << "bilateral_size_px = " << bilateral_size_px << "; must be odd and in [3, 255]";
  } else if (!(bilateral_sigma_space_px > 0.0f) || !std::isfinite(bilateral_sigma_space_px)) {
    msg << "bilateral_sigma_space_px = " << bilateral_sigma_space_px
        << "; must be finite and > 0 [px]";
  } else if (!(bilateral_sigma_range_px > 0.0f) || !std::isfinite(bilateral_sigma_range_px)) {
    msg << "bilateral_sigma_range_px = " << bilateral_sigma_range_px
        << "; must be finite and > 0 [px]";
  } else if (max_hypotheses < 1 || max_hypotheses > 255) {
    msg << "max_hypotheses = " << max_hypotheses << "; must be in [1, 255]";
  } else if (!(hypothesis_margin >= 0.0f && hypothesis_margin <= 2.0f)) {
    msg << "hypothesis_margin = " << hypothesis_margin << "; must be in [0, 2]";
  } else if (lr_tolerance_px < 0) {
    msg << "lr_tolerance_px = " << lr_tolerance_px << "; must be >= 0 [px]";
  } else {
    return Status::ok();
  }
  return Status::error(msg.str());
}

float nccAt(const ImageU8& left,
            const ImageU8& right,
            int u,
            int v,
            double x_right,
            float scale,
            int window_size_px,
            float min_std) {
  if (window_size_px < 3 || window_size_px > kMaxWindowPx || window_size_px % 2 == 0 ||
      left.width != right.width || left.height != right.height || left.empty() || !(scale > 0.0f)) {
    return std::numeric_limits<float>::quiet_NaN();
  }
  PrimaryWindow w;
  if (!loadPrimary(left.data.data(), left.width, left.height, u, v, window_size_px, min_std, &w)) {
    return std::numeric_limits<float>::quiet_NaN();
  }
  return nccAgainst(
      w, right.data.data(), right.width, right.height, v, x_right, scale, window_size_px, min_std);
}

Status NccScaledMatcher::compute(const ImageU8& left,
                                 const ImageU8& right,
                                 const NccScaledOptions& o,
                                 ImageF32* disparity) {
  constexpr const char* kWho = "NccScaledMatcher::compute";
  if (disparity == nullptr) return Status::error(std::string(kWho) + ": disparity is null");
  if (Status s = checkPair(left, right, o, kWho); !s) return s;
  const int width = left.width;
  const int height = left.height;
  const int n = o.window_size_px;
  const int h = n / 2;
  if (width < n || height < n) {
    std::ostringstream msg;
    msg << kWho << ": image " << width << "x" << height << " is smaller than the " << n << "x" << n
        << " window";
    return Status::error(msg.str());
  }
  const size_t pixels = static_cast<size_t>(width) * height;
  const float inv_area = 1.0f / static_cast<float>(n * n);
  const float min_var_sum = minVarianceSum(o.min_window_std, n * n);
  const std::vector<int> scales = activeScales(o);
  const int num_scales = static_cast<int>(scales.size());
  const int d_min = o.min_disparity_px;
  const int num_d = o.max_disparity_px - d_min + 1;

  // Centred float copies of both views.
  left_f_.resize(pixels);
  work_.resize(pixels);
  for (size_t i = 0; i < pixels; ++i) {
    left_f_[i] = centred(left.data[i]);
    work_[i] = centred(right.data[i]);
  }
  const float* right_f = work_.data();

  // Per active scale and window column i: the right samples a window centred at x uses,
  // R(x + s i) interpolated, as an image over x (clamped where the window would leave the
  // image; those columns never compete). Column validity range of the centre per scale.
  frac_images_.resize(static_cast<size_t>(num_scales) * n * pixels);
  std::vector<int> x_lo(num_scales);
  std::vector<int> x_hi(num_scales);
  for (int sl = 0; sl < num_scales; ++sl) {
    const double s = kNccScales[scales[sl]];
    int lo_off = 0;
    int hi_off = 0;
    for (int i = -h; i <= h; ++i) {
      const double pos = s * i;
      int k = static_cast<int>(std::floor(pos));
      float f = static_cast<float>(pos - k);
      if (f < 1e-6f) f = 0.0f;
      if (f > 1.0f - 1e-6f) {
        f = 0.0f;
        ++k;
      }
      lo_off = std::min(lo_off, k);
      hi_off = std::max(hi_off, f > 0.0f ? k + 1 : k);
      float* img = frac_images_.data() + (static_cast<size_t>(sl) * n + (i + h)) * pixels;
      for (int y = 0; y < height; ++y) {
        const float* src = right_f + static_cast<size_t>(y) * width;
        float* dst = img + static_cast<size_t>(y) * width;
        for (int x = 0; x < width; ++x) {
          const int a = std::clamp(x + k, 0, width - 1);
          const int b = std::clamp(x + k + 1, 0, width - 1);
          const float va = src[a];
          const float vb = f > 0.0f ? src[b] : va;
          dst[x] = va + f * (vb - va);
        }
      }
    }
    x_lo[sl] = -lo_off;
    x_hi[sl] = width - 1 - hi_off;
  }

  // Window sums: left per pixel, right per scale and centre column.
  left_sum_.assign(pixels, 0.0f);
  left_inv_.assign(pixels, 0.0f);
  right_sum_.assign(static_cast<size_t>(num_scales) * pixels, 0.0f);
  right_inv_.assign(static_cast<size_t>(num_scales) * pixels, 0.0f);
  {
    std::vector<float> row_sum(pixels);
    std::vector<float> row_sq(pixels);
    auto box = [&](float* sum_out, float* inv_out) {
      for (int v = h; v < height - h; ++v) {
        float* so = sum_out + static_cast<size_t>(v) * width;
        float* io = inv_out + static_cast<size_t>(v) * width;
        for (int x = 0; x < width; ++x) {
          float s1 = 0.0f;
          float s2 = 0.0f;
          for (int j = -h; j <= h; ++j) {
            s1 += row_sum[static_cast<size_t>(v + j) * width + x];
            s2 += row_sq[static_cast<size_t>(v + j) * width + x];
          }
          so[x] = s1;
          io[x] = inverseDeviation(s1, s2, inv_area, min_var_sum);
        }
      }
    };
    std::fill(row_sum.begin(), row_sum.end(), 0.0f);
    std::fill(row_sq.begin(), row_sq.end(), 0.0f);
    for (int y = 0; y < height; ++y) {
      const float* src = left_f_.data() + static_cast<size_t>(y) * width;
      for (int x = h; x < width - h; ++x) {
        float s1 = 0.0f;
        float s2 = 0.0f;
        for (int i = -h; i <= h; ++i) {
          s1 += src[x + i];
          s2 += src[x + i] * src[x + i];
        }
        row_sum[static_cast<size_t>(y) * width + x] = s1;
        row_sq[static_cast<size_t>(y) * width + x] = s2;
      }
    }
    box(left_sum_.data(), left_inv_.data());
    for (int sl = 0; sl < num_scales; ++sl) {
      std::fill(row_sum.begin(), row_sum.end(), 0.0f);
      std::fill(row_sq.begin(), row_sq.end(), 0.0f);
      for (int i = 0; i < n; ++i) {
        const float* img = frac_images_.data() + (static_cast<size_t>(sl) * n + i) * pixels;
        for (size_t p = 0; p < pixels; ++p) {
          row_sum[p] += img[p];
          row_sq[p] += img[p] * img[p];
        }
      }
      box(right_sum_.data() + sl * pixels, right_inv_.data() + sl * pixels);
    }
  }

  // Integer search: correlation rows in a ring of n rows per (scale, disparity).
  const size_t combos = static_cast<size_t>(num_scales) * num_d;
  ring_.assign(static_cast<size_t>(n) * combos * width, 0.0f);
  best_ncc_.assign(pixels, kNoNcc);
  best_code_.assign(pixels, -1);
  for (int y = 0; y < height; ++y) {
    const int slot = y % n;
    const float* lrow = left_f_.data() + static_cast<size_t>(y) * width;
    for (int sl = 0; sl < num_scales; ++sl) {
      for (int dd = 0; dd < num_d; ++dd) {
        const int d = d_min + dd;
        const int u_lo = std::max(h, d + x_lo[sl]);
        const int u_hi = std::min(width - 1 - h, d + x_hi[sl]);
        if (u_lo > u_hi) continue;
        float* c = ring_.data() + ((static_cast<size_t>(slot) * combos) + sl * num_d + dd) * width;
        std::fill(c + u_lo, c + u_hi + 1, 0.0f);
        for (int i = 0; i < n; ++i) {
          const float* rrow = frac_images_.data() + (static_cast<size_t>(sl) * n + i) * pixels +
                              static_cast<size_t>(y) * width;
          // Offsets stay inside the rows: u - h + i >= 0 and u - d is a valid centre.
          const int shift = i - h;
          for (int u = u_lo; u <= u_hi; ++u) c[u] += lrow[u + shift] * rrow[u - d];
        }
      }
    }
    if (y < n - 1) continue;
    const int v = y - h;
    float* best = best_ncc_.data() + static_cast<size_t>(v) * width;
    int32_t* code = best_code_.data() + static_cast<size_t>(v) * width;
    const float* ls = left_sum_.data() + static_cast<size_t>(v) * width;
    const float* li = left_inv_.data() + static_cast<size_t>(v) * width;
    for (int sl = 0; sl < num_scales; ++sl) {
      const float* rs_row = right_sum_.data() + sl * pixels + static_cast<size_t>(v) * width;
      const float* ri_row = right_inv_.data() + sl * pixels + static_cast<size_t>(v) * width;
      for (int dd = 0; dd < num_d; ++dd) {
        const int d = d_min + dd;
        const int u_lo = std::max(h, d + x_lo[sl]);
        const int u_hi = std::min(width - 1 - h, d + x_hi[sl]);
        if (u_lo > u_hi) continue;
        const int32_t this_code = sl * num_d + dd;

        const float* rows[kMaxWindowPx];
        for (int k = 0; k < n; ++k) {
          rows[k] = ring_.data() + ((static_cast<size_t>(k) * combos) + sl * num_d + dd) * width;
        }
        for (int u = u_lo; u <= u_hi; ++u) {
          float cross = 0.0f;
          for (int k = 0; k < n; ++k) cross += rows[k][u];
          const float ncc = (cross - ls[u] * rs_row[u - d] * inv_area) * li[u] * ri_row[u - d];
          const bool better = ncc > best[u];
          best[u] = better ? ncc : best[u];
          code[u] = better ? this_code : code[u];
        }
      }
    }
  }

  // Threshold, sub-pixel search, outputs.
  std::vector<FastSubpixel> subpixel;
  if (o.subpixel_steps > 0) {
    for (int sl = 0; sl < num_scales; ++sl) subpixel.emplace_back(kNccScales[scales[sl]], o);
  }
  PrimaryWindow w;  // reused: its value array is large enough for the widest window
  ImageF32 out(width, height, kNoDisparity);
  ncc_ = ImageF32(width, height, kNoNcc);
  scale_index_ = ImageU8(width, height, kNoScale);
  for (int v = h; v < height - h; ++v) {
    for (int u = h; u < width - h; ++u) {
      const size_t p = static_cast<size_t>(v) * width + u;
      const int32_t c = best_code_[p];
      if (c < 0) continue;
      const int sl = c / num_d;
      const int d = d_min + c % num_d;
      float ncc = best_ncc_[p];
      ncc_.data[p] = ncc;
      if (!(ncc >= o.ncc_threshold) || left_inv_[p] == 0.0f) continue;
      float d_px = static_cast<float>(d);
      if (o.subpixel_steps > 0) {
        loadPrimary(left_f_.data(), width, height, u, v, n, o.min_window_std, &w);
        subpixel[sl].refine(w, right_f, width, u, v, d, ncc, &d_px, &ncc);
        ncc_.data[p] = ncc;
      }
      out.data[p] = d_px;
      scale_index_.data[p] = static_cast<uint8_t>(scales[sl]);
    }
  }
  if (o.median_rejection) {
    if (Status s = medianRejectDisparity(
            o.median_size_px, o.median_rejection_px, std::max(1, o.subpixel_steps), &out);
        !s) {
      return Status::error(std::string(kWho) + ": " + s.message());
    }
  }
  if (o.bilateral) {
    if (Status s = nccBilateralFilter(ncc_,
                                      o.bilateral_size_px,
                                      o.bilateral_sigma_space_px,
                                      o.bilateral_sigma_range_px,
                                      &out);
        !s) {
      return Status::error(std::string(kWho) + ": " + s.message());
    }
  }
  for (size_t p = 0; p < pixels; ++p) {
    if (!(out.data[p] >= 0.0f)) scale_index_.data[p] = kNoScale;
  }
  *disparity = std::move(out);
  return Status::ok();
}

Status computeNccScaledDisparity(const ImageU8& left,
                                 const ImageU8& right,
                                 const NccScaledOptions& options,
                                 ImageF32* disparity) {
  NccScaledMatcher matcher;
  return matcher.compute(left, right, options, disparity);
}

}  // namespace twocam::frontend
