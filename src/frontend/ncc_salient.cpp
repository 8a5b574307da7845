#include "frontend/ncc_scaled.h"
/// Scaled-window NCC matching at salient points (matchNccSalient, ncc_scaled.h).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "frontend/ncc_scaled_internal.h"

namespace twocam::frontend {

// The matcher's pieces (ncc_scaled_internal.h) by their short names.
using namespace internal::ncc_scaled;

namespace {

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

}  // namespace

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
