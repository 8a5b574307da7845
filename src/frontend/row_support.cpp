#include "frontend/row_support.h"

#include <algorithm>
#include <cstdint>
#include <string>

#include "frontend/cost_curve.h"

namespace twocam::frontend {
namespace {

using internal::checkInputs;
using internal::costCurve;
using internal::CurveScratch;
using internal::kMaxDisparityPx;
using internal::kMaxPadded;
using internal::parabolaOffset;
using internal::StripSource;
using internal::windowCost;

/// Plain SAD of the w-px windows at win_a and win_b against the right-row pixels at ra + t and
/// rb + t, for t in [0, n): cost_a[t], cost_b[t] (the rows above and below, in one loop so
/// that the two chains overlap). SSE2 when w <= 16 and 16 bytes may be read at every window.
void shortSadCurves(const uint8_t* win_a,
                    const uint8_t* ra,
                    const uint8_t* win_b,
                    const uint8_t* rb,
                    int w,
                    int n,
                    bool wide_loads,
                    uint16_t* cost_a,
                    uint16_t* cost_b) {
#if defined(__SSE2__)
  if (wide_loads && w <= 16) {
    // kOnes[16 - w, 32 - w): w bytes 0xFF, then zeros, so only the window's w bytes count.
    alignas(16) static constexpr uint8_t kOnes[32] = {0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF,
                                                      0xFF};
    const __m128i mask =
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(kOnes + 16 - w));  // NOLINT
    const __m128i la =
        _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(win_a)), mask);  // NOLINT
    const __m128i lb =
        _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(win_b)), mask);  // NOLINT
    for (int t = 0; t < n; ++t) {
      const __m128i sa =
          _mm_sad_epu8(la,
                       _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(ra + t)),
                                     mask));  // NOLINT
      const __m128i sb =
          _mm_sad_epu8(lb,
                       _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(rb + t)),
                                     mask));  // NOLINT
      cost_a[t] =
          static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_add_epi32(sa, _mm_srli_si128(sa, 8))));
      cost_b[t] =
          static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_add_epi32(sb, _mm_srli_si128(sb, 8))));
    }
    return;
  }
#endif
  (void)wide_loads;
  for (int t = 0; t < n; ++t) {
    cost_a[t] = static_cast<uint16_t>(windowCost(win_a, ra + t, w, false));
    cost_b[t] = static_cast<uint16_t>(windowCost(win_b, rb + t, w, false));
  }
}

#if defined(TWOCAM_HAVE_AVX2_KERNEL)
/// Plain SAD of the w-px window at `win` (4 <= w <= 16) against rp + t for the 8 offsets
/// t = 0..7, as 8 uint16 lanes: one SSE4.1 mpsadbw per 4-pixel block of the window (a block
/// against 8 consecutive positions at once), minus the pixels of the last block beyond w.
/// Reads 16 bytes at win and 16 at rp + 4j for every block j.
/// Block kBlock (window pixels 4 kBlock .. 4 kBlock + 3) of l against rp + 4 kBlock + t.
template <int kBlock>
__attribute__((target("avx2"))) inline __m128i sadBlock(__m128i l, const uint8_t* rp) {
  const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(rp + 4 * kBlock));  // NOLINT
  return _mm_mpsadbw_epu8(a, l, kBlock);  // imm: a from its byte 0, b = block kBlock of l
}

__attribute__((target("avx2"))) inline __m128i sad8(const uint8_t* win, const uint8_t* rp, int w) {
  const __m128i l = _mm_loadu_si128(reinterpret_cast<const __m128i*>(win));  // NOLINT
  const int blocks = (w + 3) / 4;
  __m128i acc = sadBlock<0>(l, rp);
  if (blocks > 1) acc = _mm_add_epi16(acc, sadBlock<1>(l, rp));
  if (blocks > 2) acc = _mm_add_epi16(acc, sadBlock<2>(l, rp));
  if (blocks > 3) acc = _mm_add_epi16(acc, sadBlock<3>(l, rp));
  for (int i = w; i < 4 * blocks; ++i) {
    // Window pixel i is not part of the window: remove |R[t + i] - L[i]| from every lane.
    const __m128i r =
        _mm_cvtepu8_epi16(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(rp + i)));  // NOLINT
    acc = _mm_sub_epi16(acc, _mm_abs_epi16(_mm_sub_epi16(r, _mm_set1_epi16(win[i]))));
  }
  return acc;
}

/// The cheapest lane in [t_lo, t_hi] (within 0..7), lowest index on equal costs, and its cost.
__attribute__((target("avx2"))) inline int cheapestLane(__m128i costs, int t_lo, int t_hi) {
  alignas(16) static constexpr uint16_t kLane[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  const __m128i lane = _mm_load_si128(reinterpret_cast<const __m128i*>(kLane));  // NOLINT
  const __m128i outside =
      _mm_or_si128(_mm_cmplt_epi16(lane, _mm_set1_epi16(static_cast<int16_t>(t_lo))),
                   _mm_cmpgt_epi16(lane, _mm_set1_epi16(static_cast<int16_t>(t_hi))));
  return _mm_extract_epi16(_mm_minpos_epu16(_mm_or_si128(costs, outside)), 1);
}

/// Sub-pixel disparity of the cheapest of the 2R + 1 disparities d_top - 1 .. d_top - 2R - 1
/// of the window at win against rp + t (t = 0 .. 2R + 2, curve index t <-> disparity d_top - t;
/// R <= 3): the generic path's rowDisparity on the same costs, so both give the same result.
__attribute__((target("avx2"))) inline float rowDisparityAvx2(
    const uint8_t* win, const uint8_t* rp, int w, int radius, int d_top) {
  const __m128i costs = sad8(win, rp, w);
  const int t = cheapestLane(costs, 1, 2 * radius + 1);
  alignas(16) uint16_t c[9];
  _mm_store_si128(reinterpret_cast<__m128i*>(c), costs);  // NOLINT
  if (t == 7) {  // its upper neighbour, t = 8, is beyond sad8's lanes
    c[8] = static_cast<uint16_t>(windowCost(win, rp + 8, w, false));
  }
  // c[t + 1] is disparity d - 1, c[t - 1] is d + 1; t is in [1, 2R + 1], so both exist.
  return static_cast<float>(d_top - t) + parabolaOffset(c[t + 1], c[t], c[t - 1]);
}
#endif

/// Sub-pixel disparity of the cheapest curve entry in t in [t_lo, t_hi] (lowest t on equal
/// costs; curve index t <-> disparity d_top - t, n entries). Branch-free search (keys
/// cost * 64 + t, t < 2 * 16 + 3), because the minimum's position is random.
float rowDisparity(const uint16_t* cost, int n, int t_lo, int t_hi, int d_top) {
  uint32_t best_key = UINT32_MAX;
  for (int t = t_lo; t <= t_hi; ++t) {
    best_key = std::min(best_key, (static_cast<uint32_t>(cost[t]) << 6) | static_cast<uint32_t>(t));
  }
  const int best_t = static_cast<int>(best_key & 63u);
  float d = static_cast<float>(d_top - best_t);
  // cost[t + 1] is disparity d - 1, cost[t - 1] is d + 1.
  if (best_t > 0 && best_t + 1 < n)
    d += parabolaOffset(cost[best_t + 1], cost[best_t], cost[best_t - 1]);
  return d;
}

/// Row support of one hypothesis (see measureRowSupport), any options.
float rowSpan(const ImageU8& left,
              const ImageU8& right,
              const SalientSadOptions& options,
              Simd kernel,
              const Corner& corner,
              const DisparityHypothesis& hyp,
              CurveScratch* scratch) {
  const int w = options.window_width_px;
  const int radius = options.row_support_radius_px;
  const int width = left.width;
  const int height = left.height;
  const size_t size = left.data.size();
  const int start = corner.u_px + hyp.window_shift_px - w / 2;  // first column of the left window
  if (start < 0 || start + w > width) return 0.0f;
  const int centre_d = static_cast<int>(hyp.d_px + 0.5f);  // d_px >= 0: round half up
  // Curve index t <-> disparity d_top - t; right windows must start at column >= 0.
  const int d_top = std::min(centre_d + radius + 1, start);
  const int d_bottom = std::max(0, centre_d - radius - 1);
  const int n = d_top - d_bottom + 1;
  const int t_lo = std::max(0, d_top - (centre_d + radius));
  const int t_hi = std::min(n - 1, d_top - (centre_d - radius));
  if (n < 1 || t_lo > t_hi) return 0.0f;
  alignas(32) uint16_t cost[2][kMaxPadded];
  // Rows above (k = 0) and below (k = 1); a row outside either image is not matched.
  bool have[2];
  size_t left_at[2];
  size_t right_at[2];
  for (int k = 0; k < 2; ++k) {
    const int row = corner.v_px + (k == 0 ? -1 : 1);
    const int right_row = row + hyp.row_offset_px;
    have[k] = row >= 0 && row < height && right_row >= 0 && right_row < height;
    // Out-of-image rows read row v instead (valid memory); their result is not used.
    left_at[k] = static_cast<size_t>(have[k] ? row : corner.v_px) * width + start;
    right_at[k] = static_cast<size_t>(have[k] ? right_row : corner.v_px) * width + (start - d_top);
  }
  if (!have[0] && !have[1]) return 0.0f;
  if (options.zero_mean) {
    for (int k = 0; k < 2; ++k) {
      const int right_row = static_cast<int>(right_at[k] / width);
      costCurve(kernel,
                left.data.data() + left_at[k],
                w,
                StripSource{&right, nullptr, nullptr},
                right_row,
                start - d_top,
                n,
                true,
                scratch,
                cost[k]);
    }
  } else {
    const bool wide_loads =
        std::max(left_at[0], left_at[1]) + 16 <= size &&
        std::max(right_at[0], right_at[1]) + static_cast<size_t>(n - 1) + 16 <= size;
    shortSadCurves(left.data.data() + left_at[0],
                   right.data.data() + right_at[0],
                   left.data.data() + left_at[1],
                   right.data.data() + right_at[1],
                   w,
                   n,
                   wide_loads,
                   cost[0],
                   cost[1]);
  }
  float lo = hyp.d_px;
  float hi = hyp.d_px;
  for (int k = 0; k < 2; ++k) {
    if (!have[k]) continue;
    const float d_row = rowDisparity(cost[k], n, t_lo, t_hi, d_top);
    lo = std::min(lo, d_row);
    hi = std::max(hi, d_row);
  }
  return hi - lo;
}

#if defined(TWOCAM_HAVE_AVX2_KERNEL)
/// measureRowSupport's loop with the AVX2 / SSE4.1 fast path (plain SAD, 4 <= W <= 16): a
/// hypothesis away from the image borders, on its own row (row_offset_px = 0) and with a radius
/// <= 3 gets its 2 x 8 costs from sad8; any other goes through rowSpan. Same results.
__attribute__((target("avx2"))) void rowSupportAvx2(const ImageU8& left,
                                                    const ImageU8& right,
                                                    const SalientSadOptions& options,
                                                    StereoHypotheses* hyps) {
  const int w = options.window_width_px;
  const int h = w / 2;
  const int radius = options.row_support_radius_px;
  const int width = left.width;
  const int height = left.height;
  const size_t size = left.data.size();
  CurveScratch scratch;
  for (const SalientPoint& point : hyps->points) {
    const Corner& corner = point.corner;
    const bool rows_inside = corner.v_px >= 1 && corner.v_px + 1 < height;
    for (uint32_t j = point.first_hypothesis; j < point.first_hypothesis + point.num_hypotheses;
         ++j) {
      DisparityHypothesis& hyp = hyps->hypotheses[j];
      const int start = corner.u_px + hyp.window_shift_px - h;
      const int centre_d = static_cast<int>(hyp.d_px + 0.5f);
      const int d_top = centre_d + radius + 1;
      const size_t row_above = static_cast<size_t>(corner.v_px - 1) * width;
      const bool fast = rows_inside && radius <= 3 && hyp.row_offset_px == 0 &&
                        start + w <= width && centre_d - radius - 1 >= 0 && d_top <= start &&
                        row_above + 2 * width + start + 16 <= size &&
                        row_above + 2 * width + (start - d_top) + 32 <= size;
      if (!fast) {
        hyp.row_span_px = rowSpan(left, right, options, Simd::kAvx2, corner, hyp, &scratch);
        continue;
      }
      const uint8_t* la = left.data.data() + row_above + start;
      const uint8_t* ra = right.data.data() + row_above + (start - d_top);
      const float d_a = rowDisparityAvx2(la, ra, w, radius, d_top);
      const float d_b = rowDisparityAvx2(la + 2 * width, ra + 2 * width, w, radius, d_top);
      hyp.row_span_px = std::max({hyp.d_px, d_a, d_b}) - std::min({hyp.d_px, d_a, d_b});
    }
  }
}
#endif

}  // namespace

Status measureRowSupport(const ImageU8& left,
                         const ImageU8& right,
                         const SalientSadOptions& options,
                         StereoHypotheses* hyps) {
  const Status status = checkInputs(left, right, options, hyps);
  if (!status.isOk()) return status;
  for (size_t pi = 0; pi < hyps->points.size(); ++pi) {
    const SalientPoint& p = hyps->points[pi];
    if (static_cast<size_t>(p.first_hypothesis) + p.num_hypotheses > hyps->hypotheses.size()) {
      return Status::error("point " + std::to_string(pi) + " references hypotheses [" +
                           std::to_string(p.first_hypothesis) + ", +" +
                           std::to_string(p.num_hypotheses) + ") of " +
                           std::to_string(hyps->hypotheses.size()));
    }
    // Hypotheses that no matcher on this pair produces would overflow the column and row
    // arithmetic below (corner far outside, d_px NaN or huge).
    if (p.corner.u_px < 0 || p.corner.u_px >= left.width || p.corner.v_px < 0 ||
        p.corner.v_px >= left.height) {
      return Status::error("point " + std::to_string(pi) + " has its corner at (" +
                           std::to_string(p.corner.u_px) + ", " + std::to_string(p.corner.v_px) +
                           "), outside the " + std::to_string(left.width) + "x" +
                           std::to_string(left.height) + " images");
    }
    for (uint32_t j = p.first_hypothesis; j < p.first_hypothesis + p.num_hypotheses; ++j) {
      const float d = hyps->hypotheses[j].d_px;
      if (!(d >= 0.0f && d <= static_cast<float>(kMaxDisparityPx))) {
        return Status::error("hypothesis " + std::to_string(j) +
                             " has d_px = " + std::to_string(d) + "; must be in [0, " +
                             std::to_string(kMaxDisparityPx) + "]");
      }
    }
  }
  for (DisparityHypothesis& hyp : hyps->hypotheses) hyp.row_span_px = 0.0f;
  const Simd kernel = resolveSimd(options.simd);
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
  if (kernel == Simd::kAvx2 && !options.zero_mean && options.window_width_px >= 4 &&
      options.window_width_px <= 16) {
    rowSupportAvx2(left, right, options, hyps);
    return Status::ok();
  }
#endif
  CurveScratch scratch;
  for (const SalientPoint& point : hyps->points) {
    for (uint32_t j = point.first_hypothesis; j < point.first_hypothesis + point.num_hypotheses;
         ++j) {
      hyps->hypotheses[j].row_span_px =
          rowSpan(left, right, options, kernel, point.corner, hyps->hypotheses[j], &scratch);
    }
  }
  return Status::ok();
}

}  // namespace twocam::frontend
