#include "frontend/support_value.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/options_check.h"
#include "frontend/support_value_internal.h"

namespace twocam::frontend {

namespace internal::support {

Status checkInputs(const ImageU8& left, const ImageU8& right, const SupportValueOptions& o) {
  if (left.empty() || right.empty()) return Status::error("support value: empty image");
  if (left.width != right.width || left.height != right.height) {
    return Status::error("support value: left (" + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ") and right (" +
                         std::to_string(right.width) + "x" + std::to_string(right.height) +
                         ") images differ in size");
  }
  if (left.data.size() != static_cast<size_t>(left.width) * left.height ||
      right.data.size() != static_cast<size_t>(right.width) * right.height) {
    return Status::error("support value: image buffer does not match its size");
  }
  if (Status s = o.validate(); !s) return s;
  if (o.max_disparity_px >= left.width) {
    return Status::error("max_disparity_px = " + std::to_string(o.max_disparity_px) +
                         "; must be below the image width " + std::to_string(left.width));
  }
  return Status::ok();
}

}  // namespace internal::support

// The matcher's pieces (support_value_internal.h) by their short names.
using namespace internal::support;

const char* toString(SupportFill fill) {
  switch (fill) {
    case SupportFill::kNone:
      return "none";
    case SupportFill::kLinear:
      return "linear";
    case SupportFill::kFarther:
      return "farther";
  }
  return "unknown";
}

Status parseSupportFill(const std::string& text, SupportFill* fill) {
  for (SupportFill f : {SupportFill::kNone, SupportFill::kLinear, SupportFill::kFarther}) {
    if (text == toString(f)) {
      *fill = f;
      return Status::ok();
    }
  }
  return Status::error("unknown fill '" + text + "'; expected none, linear or farther");
}

Status SupportValueOptions::validate() const {
  if (Status s = checkRange("window_px", window_px, 3, kMaxWindowPx, "px"); !s) return s;
  if (window_px % 2 == 0)
    return Status::error("window_px = " + std::to_string(window_px) + "; must be odd");
  if (!weights.empty()) {
    const size_t n = static_cast<size_t>(window_px) * window_px;
    if (weights.size() != n) {
      return Status::error("weights has " + std::to_string(weights.size()) +
                           " entries; must be empty or window_px^2 = " + std::to_string(n));
    }
    for (size_t k = 0; k < n; ++k) {
      if (Status s = checkRange("weights[" + std::to_string(k) + "]", weights[k], 0, 255); !s)
        return s;
    }
    if (std::all_of(weights.begin(), weights.end(), [](int w) { return w == 0; }))
      return Status::error("weights are all 0; at least one must be > 0");
  }
  if (Status s = checkRange("min_disparity_px", min_disparity_px, 0, 1 << 15, "px"); !s) return s;
  if (Status s = checkRange(
          "max_disparity_px", max_disparity_px, min_disparity_px, min_disparity_px + 255, "px");
      !s) {
    return s;
  }
  if (Status s = checkRange("candidate_margin", candidate_margin, 0.0, 1.0); !s) return s;
  if (Status s = checkRange("max_candidates", max_candidates, 1, kMaxCandidates); !s) return s;
  if (Status s = checkRange("shift_px", shift_px, 0, std::min(7, window_px / 2), "px"); !s)
    return s;
  if (Status s = checkRange("min_correlation", min_correlation, -1.0, 1.0); !s) return s;
  if (lr_tolerance_px > 4) {
    return Status::error("lr_tolerance_px = " + std::to_string(lr_tolerance_px) +
                         "; must be <= 4 (negative turns the check off) [px]");
  }
  if (Status s = checkRange("continuity_window_px", continuity_window_px, 3, 15, "px"); !s)
    return s;
  if (continuity_window_px % 2 == 0) {
    return Status::error("continuity_window_px = " + std::to_string(continuity_window_px) +
                         "; must be odd");
  }
  if (Status s = checkRange("continuity_min_neighbours",
                            continuity_min_neighbours,
                            0,
                            continuity_window_px * continuity_window_px - 1);
      !s) {
    return s;
  }
  if (fill != SupportFill::kNone && fill != SupportFill::kLinear && fill != SupportFill::kFarther)
    return Status::error("fill = " + std::to_string(static_cast<int>(fill)) + "; unknown value");
  if (Status s = checkRange("edge_erosion_px", edge_erosion_px, 0, 15, "px"); !s) return s;
  if (Status s = checkRange("max_fill_px", max_fill_px, 0, 1 << 15, "px"); !s) return s;
  if (Status s = checkRange("median_px", median_px, 1, 15, "px"); !s) return s;
  if (median_px % 2 == 0)
    return Status::error("median_px = " + std::to_string(median_px) + "; must be odd");
  if (Status s = checkRange("max_hypotheses", max_hypotheses, 1, 255); !s) return s;
  if (Status s = checkRange("hypothesis_margin", hypothesis_margin, candidate_margin, 1.0); !s)
    return s;
  if (Status s = checkSimd("simd", simd); !s) return s;
  return Status::ok();
}

Status SupportValueMatcher::compute(const ImageU8& left,
                                    const ImageU8& right,
                                    const SupportValueOptions& options,
                                    ImageF32* disparity) {
  if (disparity == nullptr) return Status::error("support value: disparity is null");
  if (Status s = checkInputs(left, right, options); !s) return s;

  const Geometry g = makeGeometry(left.width, left.height, options);
  const WeightPlanes planes = makePlanes(options);
  const Kernels kernels = kernelsFor(options.simd);
  const int width = g.width;
  const int height = g.height;

  padImage(left, g, &left_pad_);
  padImage(right, g, &right_pad_);
  integrate(left_pad_, g, &left_integral_, &left_integral_sq_);
  integrate(right_pad_, g, &right_integral_, &right_integral_sq_);
  const size_t pixels = static_cast<size_t>(width) * height;
  left_masks_.resize(pixels * g.words);
  right_masks_.resize(pixels * g.words);
  kernels.structures(left_pad_.data(), left_integral_, g, left_masks_.data());
  kernels.structures(right_pad_.data(), right_integral_, g, right_masks_.data());

  // Rows of support values and cross sums are kept in rings of 2 s + 1 rows (s = shift_px), so
  // that the shiftable windows of row v can look at rows v - s .. v + s.
  const int shift = options.shift_px;
  const int ring = 2 * shift + 1;
  const size_t volume = static_cast<size_t>(width) * g.nd;
  support_.resize(volume * ring);
  cross_.assign(volume * ring, 0);
  col_cross_.assign(static_cast<size_t>(g.wp) * g.nd, 0);
  best_support_.resize(volume);
  best_offset_.assign(volume, 0);  // stays 0 (centred windows) when shift = 0
  pixelStats(left_integral_, left_integral_sq_, g, &left_stats_);
  pixelStats(right_integral_, right_integral_sq_, g, &right_stats_);
  column_support_.resize(volume);
  column_offset_.resize(volume);
  left_d_.assign(pixels, kNoMatch);
  right_d_.assign(pixels, kNoMatch);
  left_score_.assign(pixels, kNoCorrelation);
  right_score_.assign(pixels, kNoCorrelation);
  std::vector<int> stack;
  stack.reserve(static_cast<size_t>(width));
  const float min_corr = static_cast<float>(options.min_correlation);
  SupportValueStats stats;
  stats.pixels = static_cast<int64_t>(pixels);
  int computed = 0;  // rows whose support values and cross sums are in the rings

  // Correlation of left pixel u of row v at disparity dmin + k, with the window moved by the
  // offset the support value chose (packed as (dv + s) * ring + du + s).
  // Offset decoding without divisions in the decision loops: column and row shift of each
  // packed offset, and the ring slot of each row of the window rows.
  std::vector<int> offset_du(static_cast<size_t>(ring) * ring);
  std::vector<int> offset_dv(offset_du.size());
  for (size_t i = 0; i < offset_du.size(); ++i) {
    offset_du[i] = static_cast<int>(i) % ring - shift;
    offset_dv[i] = static_cast<int>(i) / ring - shift;
  }
  std::vector<const int32_t*> cross_rows(static_cast<size_t>(ring));
  auto correlate = [&](int u, int v, int k, int offset) {
    const int x = u + offset_du[static_cast<size_t>(offset)];
    const int dv = offset_dv[static_cast<size_t>(offset)];
    const int d = g.dmin + k;
    const size_t row = static_cast<size_t>(v + dv) * width;
    return fastCorrelation(
        cross_rows[static_cast<size_t>(dv + shift)][static_cast<size_t>(k) * width + x],
        left_stats_[row + x],
        right_stats_[row + x - d],
        g.n);
  };

  for (int v = 0; v < height; ++v) {
    const size_t row0 = static_cast<size_t>(v) * width;
    for (; computed < std::min(height, v + shift + 1); ++computed) {
      const size_t c0 = static_cast<size_t>(computed) * width;
      const size_t slot = static_cast<size_t>(computed % ring) * volume;
      kernels.support(left_masks_.data() + c0 * g.words,
                      right_masks_.data() + c0 * g.words,
                      g,
                      planes,
                      support_.data() + slot);
      kernels.cross(left_pad_.data(),
                    right_pad_.data(),
                    g,
                    computed,
                    col_cross_.data(),
                    cross_.data() + slot);
    }
    // Shiftable windows: the best support value of the windows that contain the pixel within
    // +-s of the centre, i.e. the maximum of the centred support values over a (2s+1)^2
    // neighbourhood (columns whose search reaches d only), with the argmax as offset.
    for (int dv = -shift; dv <= shift; ++dv) {
      const int y = std::clamp(v + dv, 0, height - 1);  // rows outside are never chosen
      cross_rows[static_cast<size_t>(dv + shift)] =
          cross_.data() + static_cast<size_t>(y % ring) * volume;
    }
    const int32_t* support_row = shift == 0 ? support_.data() : best_support_.data();
    if (shift > 0) {
      const int v0 = std::max(0, v - shift);
      const int v1 = std::min(height - 1, v + shift);
      for (size_t i = 0; i < volume; ++i) {
        column_support_[i] = kNoMatch;
        column_offset_[i] = 0;
      }
      for (int y = v0; y <= v1; ++y) {
        const int32_t* src = support_.data() + static_cast<size_t>(y % ring) * volume;
        const uint8_t dv_code = static_cast<uint8_t>((y - v + shift) * ring);
        for (size_t i = 0; i < volume; ++i) {
          if (src[i] > column_support_[i]) {
            column_support_[i] = src[i];
            column_offset_[i] = dv_code;
          }
        }
      }
      for (int u = 0; u < width; ++u) {
        int32_t* best = best_support_.data() + static_cast<size_t>(u) * g.nd;
        uint8_t* best_off = best_offset_.data() + static_cast<size_t>(u) * g.nd;
        for (int k = 0; k < g.nd; ++k) {
          best[k] = kNoMatch;
          best_off[k] = 0;
        }
        for (int du = -shift; du <= shift; ++du) {
          const int x = u + du;
          if (x < 0 || x >= width) continue;
          const int32_t* col = column_support_.data() + static_cast<size_t>(x) * g.nd;
          const uint8_t* col_off = column_offset_.data() + static_cast<size_t>(x) * g.nd;
          const auto du_code = static_cast<uint8_t>(du + shift);
          for (int k = 0; k < g.nd; ++k) {
            // Only disparities the pixel itself can search (u - d >= 0) take part.
            if (u - g.dmin - k < 0) break;
            if (col[k] > best[k]) {
              best[k] = col[k];
              best_off[k] = static_cast<uint8_t>(col_off[k] + du_code);
            }
          }
        }
      }
    }
    // One pixel's decision: candidates from the support values at row_support[base + k * stride]
    // (k = 0 .. count - 1, disparity dmin + k, left pixel u_left0 + k * left_step), winner by
    // correlation. Writes the disparity and its correlation when it reaches min_correlation.
    auto decide = [&](size_t base,
                      size_t stride,
                      int count,
                      int u_left0,
                      int left_step,
                      int16_t* d_out,
                      float* score_out) {
      int cand[kMaxCandidates];
      bool dropped = false;
      const int n = selectCandidates(support_row + base,
                                     static_cast<int>(stride),
                                     count,
                                     options.candidate_margin,
                                     options.max_candidates,
                                     cand,
                                     &dropped);
      float best = kNoCorrelation;
      int best_d = kNoMatch;
      for (int c = 0; c < n; ++c) {
        const size_t i = base + static_cast<size_t>(cand[c]) * stride;
        const float r = correlate(u_left0 + cand[c] * left_step, v, cand[c], best_offset_[i]);
        if (r > best) {
          best = r;
          best_d = g.dmin + cand[c];
        }
      }
      if (best_d < 0 || best < min_corr) return false;
      *d_out = static_cast<int16_t>(best_d);
      *score_out = best;
      return true;
    };
    // Left view: pixel u, disparities dmin + k with k <= u - dmin.
    int16_t* ld = left_d_.data() + row0;
    float* ls = left_score_.data() + row0;
    for (int u = g.dmin; u < width; ++u) {
      const int count = std::min(g.nd, u - g.dmin + 1);
      if (decide(static_cast<size_t>(u) * g.nd, 1, count, u, 0, ld + u, ls + u)) ++stats.matched;
    }
    // Right view: pixel u_r meets left pixel u_r + d; its curve runs along the diagonal of the
    // row's support values (stride nd + 1).
    int16_t* rd = right_d_.data() + row0;
    float* rs = right_score_.data() + row0;
    for (int u_r = 0; u_r + g.dmin < width; ++u_r) {
      const int count = std::min(g.nd, width - u_r - g.dmin);
      decide(static_cast<size_t>(u_r + g.dmin) * g.nd,
             static_cast<size_t>(g.nd) + 1,
             count,
             u_r + g.dmin,
             1,
             rd + u_r,
             rs + u_r);
    }
    if (options.ordering) {
      orderRow(width, -1, ld, ls, &stack);
      orderRow(width, +1, rd, rs, &stack);
    }
    for (int u = 0; u < width; ++u) {
      if (ld[u] < 0) continue;
      ++stats.ordered;
      const int d_r = rd[u - ld[u]];
      const int diff = d_r < 0 ? std::numeric_limits<int>::max() : std::abs(d_r - ld[u]);
      if (diff == 0) ++stats.lr_exact;
      if (options.lr_tolerance_px >= 0 && diff > options.lr_tolerance_px) {
        ld[u] = kNoMatch;
      } else {
        ++stats.lr_relaxed;
      }
    }
  }

  std::vector<int16_t> continuous;
  continuityFilter(left_d_,
                   width,
                   height,
                   options.continuity_window_px,
                   options.continuity_min_neighbours,
                   &continuous);
  {
    const std::vector<int16_t> checked = continuous;
    erodeDepthEdges(checked, width, height, options.edge_erosion_px, &continuous);
  }
  ImageF32 out(width, height, kNoDisparity);
  right_disparity_ = ImageF32(width, height, kNoDisparity);
  for (size_t i = 0; i < pixels; ++i) {
    if (continuous[i] >= 0) {
      out.data[i] = static_cast<float>(continuous[i]);
      ++stats.validated;
    }
    if (right_d_[i] >= 0) right_disparity_.data[i] = static_cast<float>(right_d_[i]);
  }
  validated_ = out;
  fillRows(options.fill, options.max_fill_px, width, height, &out);
  if (options.median_px > 1) {
    if (Status s = medianFilterDisparity(options.median_px, options.median_px, &out); !s) return s;
  }
  for (float d : out.data) stats.filled += d >= 0.0f ? 1 : 0;
  stats_ = stats;
  *disparity = std::move(out);
  return Status::ok();
}

Status computeSupportValueDisparity(const ImageU8& left,
                                    const ImageU8& right,
                                    const SupportValueOptions& options,
                                    ImageF32* disparity) {
  SupportValueMatcher matcher;
  return matcher.compute(left, right, options, disparity);
}

}  // namespace twocam::frontend
