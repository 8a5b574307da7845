#pragma once
/// The scaled-window NCC matcher's internals (ncc_scaled.h), shared by its files: ncc_scaled.cpp
/// (options, nccAt and the dense matcher), ncc_salient.cpp (salient points) and, for
/// kMaxSubpixelSteps, ncc_filters.cpp (median rejection, NCC-weighted bilateral filter).
/// Exposed for those files and their tests only.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "frontend/ncc_scaled.h"

// FastSubpixel::refine runs once per estimate inside the dense matcher's output loop and the
// salient matcher's hypothesis loop; it is inlined there as when one file held it and its callers
// (out of line, the dense matcher was about 6 % slower).
#if defined(__GNUC__) || defined(__clang__)
#define TWOCAM_NCC_INLINE inline __attribute__((always_inline))
#else
#define TWOCAM_NCC_INLINE inline
#endif

namespace twocam::frontend::internal::ncc_scaled {

constexpr int kMaxWindowPx = 31;
constexpr int kMaxWindowArea = kMaxWindowPx * kMaxWindowPx;
constexpr int kMaxSubpixelSteps = 64;
constexpr float kNoNcc = -1.0f;
// Grey levels are centred on 128 before any sum, so the sums of squares stay small next to
// float's 24-bit mantissa and the variance differences lose little to cancellation.
constexpr float kGreyCentre = 128.0f;
// Smallest window variance x N^2 accepted when min_window_std is 0 (division by zero guard).
constexpr float kMinVarianceSum = 1e-6f;
// Slack on "inside the image" tests of interpolated sample positions [px].
constexpr double kPositionSlack = 1e-9;

inline float centred(uint8_t p) { return static_cast<float>(p) - kGreyCentre; }
inline float centred(float p) { return p; }

inline float minVarianceSum(float min_std, int area) {
  return std::max(kMinVarianceSum, static_cast<float>(area) * min_std * min_std);
}

/// Inverse of sqrt(N^2 var) from the window sums, 0 for a window flatter than allowed.
inline float inverseDeviation(float sum, float sum_sq, float inv_area, float min_var_sum) {
  const float var_sum = sum_sq - sum * sum * inv_area;
  return var_sum >= min_var_sum ? 1.0f / std::sqrt(var_sum) : 0.0f;
}

/// The left (primary) window of one pixel: centred values, their sum and 1/sqrt(N^2 var).
struct PrimaryWindow {
  std::array<float, kMaxWindowArea> values{};
  float sum = 0.0f;
  float inv_dev = 0.0f;  // 0: flat
};

template <typename P>
bool loadPrimary(
    const P* image, int width, int height, int u, int v, int n, float min_std, PrimaryWindow* out) {
  const int h = n / 2;
  if (u < h || v < h || u >= width - h || v >= height - h) return false;
  float sum = 0.0f;
  float sum_sq = 0.0f;
  int k = 0;
  for (int j = -h; j <= h; ++j) {
    const P* row = image + static_cast<size_t>(v + j) * width;
    for (int i = -h; i <= h; ++i) {
      const float x = centred(row[u + i]);
      out->values[k++] = x;
      sum += x;
      sum_sq += x * x;
    }
  }
  out->sum = sum;
  out->inv_dev = inverseDeviation(
      sum, sum_sq, 1.0f / static_cast<float>(n * n), minVarianceSum(min_std, n * n));
  return true;
}

/// The paper's sub-pixel local search: NCC at d + k/steps, k = +-1..+-steps, inside
/// [d_min, d_max] and the image; the best wins (the integer d on ties). Organised so that the 2n
/// candidates share the window's products. Linear interpolation is linear in R: with the
/// column sums P_i(c) = sum_j L(u+i, v+j) R(x_r+c, v+j), C1(c) = sum_j R(x_r+c, v+j),
/// C2(c) = sum_j R^2 and C11(c) = sum_j R(c) R(c+1) over the window's rows, a candidate whose
/// column i samples x_r + a_i + f_i (x_r = u - d) has
///   cross  = sum_i (1-f_i) P_i(a_i) + f_i P_i(a_i+1),
///   sum    = sum_i (1-f_i) C1(a_i) + f_i C1(a_i+1),
///   sum_sq = sum_i (1-f_i)^2 C2(a_i) + 2 f_i (1-f_i) C11(a_i) + f_i^2 C2(a_i+1),
/// exactly the sums over the interpolated samples. The a_i, f_i of a candidate depend only on
/// the scale and the step k, so the weights are tabulated once per scale, stored column-major
/// (one row of 2n candidate weights per P_i(c) or C(c)), and all candidates' sums come from
/// three small matrix-vector products whose inner loop runs over the candidates.
class FastSubpixel {
 public:
  FastSubpixel(float scale, const NccScaledOptions& o) : o_(o), n_(o.window_size_px) {
    const int h = n_ / 2;
    const int steps = o.subpixel_steps;
    struct Sample {
      int a;
      float f;
    };
    std::vector<std::vector<Sample>> samples;
    for (int k = -steps; k <= steps; ++k) {
      if (k == 0) continue;
      const double offset = -static_cast<double>(k) / steps;  // disparity d + k/steps
      std::vector<Sample> row;
      for (int i = -h; i <= h; ++i) {
        const double x = offset + static_cast<double>(scale) * i;
        const int a = static_cast<int>(std::floor(x));
        row.push_back({a, static_cast<float>(x - a)});
        c_lo_ = std::min(c_lo_, a);
        c_hi_ = std::max(c_hi_, a + 1);
      }
      samples.push_back(row);
      ks_.push_back(k);
      reach_lo_.push_back(offset - static_cast<double>(scale) * h);
      reach_hi_.push_back(offset + static_cast<double>(scale) * h);
    }
    cols_ = c_hi_ - c_lo_ + 1;
    cand_ = static_cast<int>(ks_.size());
    w_cross_.assign(static_cast<size_t>(n_) * cols_ * cand_, 0.0f);
    w_sum_.assign(static_cast<size_t>(cols_) * cand_, 0.0f);
    w_sq_.assign(static_cast<size_t>(cols_) * cand_, 0.0f);
    w_adj_.assign(static_cast<size_t>(cols_) * cand_, 0.0f);
    for (int q = 0; q < cand_; ++q) {
      for (int i = 0; i < n_; ++i) {
        const int a = samples[q][i].a - c_lo_;
        const float f = samples[q][i].f;
        const float g = 1.0f - f;
        w_cross_[(static_cast<size_t>(i) * cols_ + a) * cand_ + q] += g;
        w_cross_[(static_cast<size_t>(i) * cols_ + a + 1) * cand_ + q] += f;
        w_sum_[static_cast<size_t>(a) * cand_ + q] += g;
        w_sum_[static_cast<size_t>(a + 1) * cand_ + q] += f;
        w_sq_[static_cast<size_t>(a) * cand_ + q] += g * g;
        w_sq_[static_cast<size_t>(a + 1) * cand_ + q] += f * f;
        w_adj_[static_cast<size_t>(a) * cand_ + q] += 2.0f * f * g;
      }
    }
    p_.resize(static_cast<size_t>(n_) * cols_);
    c1_.resize(cols_);
    c2_.resize(cols_);
    c11_.resize(cols_);
    col_.resize(cols_ + 1);
    cross_.resize(cand_);
    sum_.resize(cand_);
    sq_.resize(cand_);
  }

  /// Refines (d, ncc_int) of pixel (u, v); w is its loaded left window.
  template <typename P>
  TWOCAM_NCC_INLINE void refine(const PrimaryWindow& w,
                                const P* right,
                                int width,
                                int u,
                                int v,
                                int d,
                                float ncc_int,
                                float* d_out,
                                float* ncc_out) {
    const int h = n_ / 2;
    const int xr = u - d;
    const float inv_area = 1.0f / static_cast<float>(n_ * n_);
    const float min_var_sum = minVarianceSum(o_.min_window_std, n_ * n_);
    std::fill(p_.begin(), p_.end(), 0.0f);
    std::fill(c1_.begin(), c1_.end(), 0.0f);
    std::fill(c2_.begin(), c2_.end(), 0.0f);
    std::fill(c11_.begin(), c11_.end(), 0.0f);
    for (int j = -h; j <= h; ++j) {
      const P* row = right + static_cast<size_t>(v + j) * width;
      // Columns beyond the image serve only candidates that are skipped below.
      for (int c = 0; c <= cols_; ++c) {
        col_[c] = centred(row[std::clamp(xr + c_lo_ + c, 0, width - 1)]);
      }
      const float* lw = w.values.data() + static_cast<size_t>(j + h) * n_;
      for (int c = 0; c < cols_; ++c) {
        c1_[c] += col_[c];
        c2_[c] += col_[c] * col_[c];
        c11_[c] += col_[c] * col_[c + 1];
      }
      for (int i = 0; i < n_; ++i) {
        float* pi = p_.data() + static_cast<size_t>(i) * cols_;
        const float li = lw[i];
        for (int c = 0; c < cols_; ++c) pi[c] += li * col_[c];
      }
    }
    std::fill(cross_.begin(), cross_.end(), 0.0f);
    std::fill(sum_.begin(), sum_.end(), 0.0f);
    std::fill(sq_.begin(), sq_.end(), 0.0f);
    const int rows = n_ * cols_;
    for (int r = 0; r < rows; ++r) {
      const float x = p_[r];
      const float* wr = w_cross_.data() + static_cast<size_t>(r) * cand_;
      for (int q = 0; q < cand_; ++q) cross_[q] += wr[q] * x;
    }
    for (int c = 0; c < cols_; ++c) {
      const float x1 = c1_[c];
      const float x2 = c2_[c];
      const float x11 = c11_[c];
      const float* ws = w_sum_.data() + static_cast<size_t>(c) * cand_;
      const float* wq = w_sq_.data() + static_cast<size_t>(c) * cand_;
      const float* wa = w_adj_.data() + static_cast<size_t>(c) * cand_;
      for (int q = 0; q < cand_; ++q) {
        sum_[q] += ws[q] * x1;
        sq_[q] += wq[q] * x2 + wa[q] * x11;
      }
    }
    float best = ncc_int;
    int best_k = 0;
    for (int q = 0; q < cand_; ++q) {
      const int k = ks_[q];
      const double dk = d + static_cast<double>(k) / o_.subpixel_steps;
      if (dk < o_.min_disparity_px || dk > o_.max_disparity_px) continue;
      if (xr + reach_lo_[q] < -kPositionSlack || xr + reach_hi_[q] > width - 1 + kPositionSlack) {
        continue;
      }
      const float inv_ref = inverseDeviation(sum_[q], sq_[q], inv_area, min_var_sum);
      if (inv_ref == 0.0f) continue;
      const float c = (cross_[q] - w.sum * sum_[q] * inv_area) * w.inv_dev * inv_ref;
      if (c > best || (c == best && std::abs(k) < std::abs(best_k))) {
        best = c;
        best_k = k;
      }
    }
    *d_out = static_cast<float>(d + static_cast<double>(best_k) / o_.subpixel_steps);
    *ncc_out = best;
  }

 private:
  const NccScaledOptions& o_;
  int n_;
  int c_lo_ = 0;
  int c_hi_ = 0;
  int cols_ = 0;
  int cand_ = 0;
  std::vector<int> ks_;
  std::vector<double> reach_lo_;  // leftmost sample of each candidate relative to x_r
  std::vector<double> reach_hi_;  // rightmost
  std::vector<float> w_cross_;
  std::vector<float> w_sum_;
  std::vector<float> w_sq_;
  std::vector<float> w_adj_;
  std::vector<float> p_;
  std::vector<float> c1_;
  std::vector<float> c2_;
  std::vector<float> c11_;
  std::vector<float> col_;
  std::vector<float> cross_;
  std::vector<float> sum_;
  std::vector<float> sq_;
};

/// Input checks of both matchers (ncc_scaled.cpp): valid options, images of one size that match
/// their buffers, max_disparity_px below the image width; messages start with `who`.
Status checkPair(const ImageU8& left,
                 const ImageU8& right,
                 const NccScaledOptions& o,
                 const char* who);

/// Indices into kNccScales of the scales that compete, in competition order (ncc_scaled.cpp).
std::vector<int> activeScales(const NccScaledOptions& o);

}  // namespace twocam::frontend::internal::ncc_scaled
