#include "frontend/ncc_scaled.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "frontend/dense_sad.h"  // kNoDisparity

namespace twocam::frontend {

namespace {

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
// Largest disparity value the median-rejection histogram accepts [px].
constexpr float kMaxMedianValuePx = 4096.0f;
// Range weights of the bilateral filter are tabulated in steps of 1/kRangeLutPerPx px up to
// kRangeLutSigmas sigmas (the weight there is exp(-18) ~ 1.5e-8; beyond, 0).
constexpr float kRangeLutPerPx = 256.0f;
constexpr float kRangeLutSigmas = 6.0f;

// The order in which scales compete: the square window first, so that ties keep it.
constexpr std::array<int, kNccScaleCount> kScaleOrder = {1, 0, 2};

inline float centred(uint8_t p) { return static_cast<float>(p) - kGreyCentre; }
inline float centred(float p) { return p; }

float minVarianceSum(float min_std, int area) {
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
  void refine(const PrimaryWindow& w,
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

/// NCC of one primary window against the reference windows centred on a span of integer columns
/// of the same rows, at every scale, from per-column sums (the identity FastSubpixel uses): the
/// salient matcher's search and right-to-left check. Same values as nccAgainst up to float
/// rounding.
class RowCorrelator {
 public:
  explicit RowCorrelator(int n) : n_(n) {
    const int h = n / 2;
    for (int si = 0; si < kNccScaleCount; ++si) {
      Pattern& p = patterns_[si];
      for (int i = -h; i <= h; ++i) {
        const double x = static_cast<double>(kNccScales[si]) * i;
        const int a = static_cast<int>(std::floor(x));
        p.a[i + h] = a;
        p.f[i + h] = static_cast<float>(x - a);
        a_min_ = std::min(a_min_, a);
        a_max_ = std::max(a_max_, a + 1);
      }
      p.reach = static_cast<double>(kNccScales[si]) * h;
    }
  }

  /// Column sums for windows centred on reference columns [x_lo, x_hi] of rows v - h..v + h.
  template <typename P>
  void load(const PrimaryWindow& w, const P* ref, int width, int v, int x_lo, int x_hi) {
    const int h = n_ / 2;
    c0_ = x_lo + a_min_;
    cols_ = x_hi + a_max_ - c0_ + 1;
    p_.assign(static_cast<size_t>(n_) * cols_, 0.0f);
    c1_.assign(cols_, 0.0f);
    c2_.assign(cols_, 0.0f);
    c11_.assign(cols_, 0.0f);
    col_.resize(cols_ + 1);
    for (int j = -h; j <= h; ++j) {
      const P* row = ref + static_cast<size_t>(v + j) * width;
      // Columns beyond the image serve only windows that ncc() refuses.
      for (int c = 0; c <= cols_; ++c) col_[c] = centred(row[std::clamp(c0_ + c, 0, width - 1)]);
      for (int c = 0; c < cols_; ++c) {
        c1_[c] += col_[c];
        c2_[c] += col_[c] * col_[c];
        c11_[c] += col_[c] * col_[c + 1];
      }
      const float* lw = w.values.data() + static_cast<size_t>(j + h) * n_;
      for (int i = 0; i < n_; ++i) {
        float* pi = p_.data() + static_cast<size_t>(i) * cols_;
        const float li = lw[i];
        for (int c = 0; c < cols_; ++c) pi[c] += li * col_[c];
      }
    }
  }

  /// NCC of the loaded window against the reference window centred at column x (in the loaded
  /// span) at scale index si; NaN when a sample leaves the image or a window is flat.
  [[nodiscard]] float ncc(const PrimaryWindow& w, int si, int x, int width, float min_std) const {
    const Pattern& p = patterns_[si];
    if (x - p.reach < -kPositionSlack || x + p.reach > width - 1 + kPositionSlack ||
        w.inv_dev == 0.0f) {
      return std::numeric_limits<float>::quiet_NaN();
    }
    float cross = 0.0f;
    float sum = 0.0f;
    float sum_sq = 0.0f;
    for (int i = 0; i < n_; ++i) {
      const int c = x + p.a[i] - c0_;
      const float f = p.f[i];
      const float g = 1.0f - f;
      const float* pi = p_.data() + static_cast<size_t>(i) * cols_;
      cross += g * pi[c] + f * pi[c + 1];
      sum += g * c1_[c] + f * c1_[c + 1];
      sum_sq += g * g * c2_[c] + 2.0f * f * g * c11_[c] + f * f * c2_[c + 1];
    }
    const float inv_area = 1.0f / static_cast<float>(n_ * n_);
    const float inv_ref = inverseDeviation(sum, sum_sq, inv_area, minVarianceSum(min_std, n_ * n_));
    if (inv_ref == 0.0f) return std::numeric_limits<float>::quiet_NaN();
    return (cross - w.sum * sum * inv_area) * w.inv_dev * inv_ref;
  }

 private:
  struct Pattern {
    std::array<int, kMaxWindowPx> a{};
    std::array<float, kMaxWindowPx> f{};
    double reach = 0.0;
  };
  int n_;
  int a_min_ = 0;
  int a_max_ = 0;
  int c0_ = 0;
  int cols_ = 0;
  std::array<Pattern, kNccScaleCount> patterns_{};
  std::vector<float> p_;
  std::vector<float> c1_;
  std::vector<float> c2_;
  std::vector<float> c11_;
  std::vector<float> col_;
};

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

Status checkMap(const ImageF32* map, const char* who) {
  if (map == nullptr) return Status::error(std::string(who) + ": disparity is null");
  if (map->empty() || map->width <= 0 || map->height <= 0 ||
      map->data.size() != static_cast<size_t>(map->width) * map->height) {
    return Status::error(std::string(who) + ": disparity map is empty or inconsistent");
  }
  return Status::ok();
}

std::vector<int> activeScales(const NccScaledOptions& o) {
  if (!o.scaled_windows) return {1};
  return {kScaleOrder.begin(), kScaleOrder.end()};
}

}  // namespace

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

Status matchNccSalient(const ImageU8& left,
                       const ImageU8& right,
                       const std::vector<Corner>& corners,
                       const NccScaledOptions& o,
                       StereoHypotheses* out,
                       std::vector<uint8_t>* scale_index) {
  constexpr const char* kWho = "matchNccSalient";
  if (out == nullptr) return Status::error(std::string(kWho) + ": out is null");
  if (Status s = checkPair(left, right, o, kWho); !s) return s;
  const int width = left.width;
  const int height = left.height;
  const int n = o.window_size_px;
  const int h = n / 2;
  const std::vector<int> scales = activeScales(o);
  const int d_min = o.min_disparity_px;
  const int num_d = o.max_disparity_px - d_min + 1;
  const uint8_t* lp = left.data.data();
  const uint8_t* rp = right.data.data();

  out->clear();
  if (scale_index != nullptr) scale_index->clear();
  std::vector<float> curve(num_d);
  std::vector<int> curve_scale(num_d);
  std::vector<int> peaks;
  PrimaryWindow w;   // reused: the value arrays are large enough for the widest window
  PrimaryWindow rw;  // the right window of the right-to-left check
  RowCorrelator forward(n);
  RowCorrelator backward(n);
  std::vector<FastSubpixel> subpixel;  // per scale index
  if (o.subpixel_steps > 0) {
    for (int si = 0; si < kNccScaleCount; ++si) subpixel.emplace_back(kNccScales[si], o);
  }
  for (const Corner& corner : corners) {
    const int u = corner.u_px;
    const int v = corner.v_px;
    if (!loadPrimary(lp, width, height, u, v, n, o.min_window_std, &w)) continue;
    SalientPoint point;
    point.corner = corner;
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    const auto point_index = static_cast<uint32_t>(out->points.size());
    bool range_cut = false;
    float best = -std::numeric_limits<float>::infinity();
    forward.load(w, rp, width, v, u - o.max_disparity_px, u - d_min);
    for (int dd = 0; dd < num_d; ++dd) {
      const int d = d_min + dd;
      curve[dd] = -std::numeric_limits<float>::infinity();
      curve_scale[dd] = 1;
      for (const int si : scales) {
        const float c = forward.ncc(w, si, u - d, width, o.min_window_std);
        const double reach = static_cast<double>(kNccScales[si]) * h;
        if (u - d - reach < 0.0 || u - d + reach > width - 1.0) range_cut = true;
        if (std::isnan(c)) continue;
        if (c > curve[dd]) {
          curve[dd] = c;
          curve_scale[dd] = si;
        }
      }
      best = std::max(best, curve[dd]);
    }
    peaks.clear();
    if (best >= o.ncc_threshold) {
      for (int dd = 0; dd < num_d; ++dd) {
        const float c = curve[dd];
        if (!(c >= o.ncc_threshold) || c < best - o.hypothesis_margin) continue;
        if (dd > 0 && !(c > curve[dd - 1])) continue;
        if (dd + 1 < num_d && !(c >= curve[dd + 1])) continue;
        peaks.push_back(dd);
      }
    }
    std::stable_sort(peaks.begin(), peaks.end(), [&](int a, int b) { return curve[a] > curve[b]; });
    const bool dropped = static_cast<int>(peaks.size()) > o.max_hypotheses;
    if (dropped) peaks.resize(o.max_hypotheses);
    struct Candidate {
      float d_px;
      float ncc;
      int d_int;
      int scale;
    };
    std::vector<Candidate> found;
    found.reserve(peaks.size());
    for (const int dd : peaks) {
      Candidate c{static_cast<float>(d_min + dd), curve[dd], d_min + dd, curve_scale[dd]};
      if (o.subpixel_steps > 0) {
        subpixel[c.scale].refine(w, rp, width, u, v, c.d_int, c.ncc, &c.d_px, &c.ncc);
      }
      found.push_back(c);
    }
    // The sub-pixel search may reorder close peaks.
    std::stable_sort(found.begin(), found.end(), [](const Candidate& a, const Candidate& b) {
      return a.ncc > b.ncc;
    });
    for (size_t rank = 0; rank < found.size(); ++rank) {
      const Candidate& c = found[rank];
      DisparityHypothesis hyp;
      hyp.d_px = c.d_px;
      hyp.cost = 1.0f - c.ncc;
      hyp.point_index = point_index;
      hyp.rank = static_cast<uint8_t>(rank);
      // Right-to-left: the right window at the integer match, square, against the left row
      // at every scale; consistent when its best lies within lr_tolerance_px.
      const int xr = u - c.d_int;
      if (loadPrimary(rp, width, height, xr, v, n, o.min_window_std, &rw) && rw.inv_dev > 0.0f) {
        float back_best = -std::numeric_limits<float>::infinity();
        int back_d = -1;
        backward.load(rw, lp, width, v, xr + d_min, xr + o.max_disparity_px);
        for (int dd = 0; dd < num_d; ++dd) {
          const int d = d_min + dd;
          for (const int si : scales) {
            const float b = backward.ncc(rw, si, xr + d, width, o.min_window_std);
            if (b > back_best) {
              back_best = b;
              back_d = d;
            }
          }
        }
        hyp.lr_consistent = back_d >= 0 && std::abs(back_d - c.d_int) <= o.lr_tolerance_px;
      }
      out->hypotheses.push_back(hyp);
      if (scale_index != nullptr) scale_index->push_back(static_cast<uint8_t>(c.scale));
    }
    point.num_hypotheses = static_cast<uint32_t>(found.size());
    point.complete = !dropped && !range_cut && best >= o.ncc_threshold;
    out->points.push_back(point);
  }
  return Status::ok();
}

}  // namespace twocam::frontend
