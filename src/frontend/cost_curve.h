#pragma once
/// Cost-curve plumbing shared by the salient matcher (salient_sad.cpp), row support
/// (row_support.cpp) and corner pairing (corner_pairing.cpp): the limits every matcher option is
/// checked against, input checks, the zero-padded strips and zero-mean offsets a kernel reads,
/// one curve's kernel call, and the scans over a finished curve (minimum, local minima with
/// guards, parabola vertex). Internal: not part of the frontend's API.

#include <algorithm>
#include <climits>
#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <cstdlib>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define TWOCAM_HAVE_AVX2_KERNEL 1
#endif

#include "common/image.h"
#include "common/status.h"
#include "frontend/salient_sad.h"

namespace twocam::frontend::internal {

constexpr int kMinWindow = 3;
constexpr int kMaxWindow = 63;
constexpr int kMaxDisparities = 256;
constexpr int kMaxRowTolerance = 8;
constexpr int kMaxHypothesesLimit = 255;
constexpr int kMaxRowSupportRadius = 16;
/// Largest min/max_disparity_px: wider than any image matched here, and small enough that
/// max_disparity_px + window_width_px and the curve-index arithmetic stay far inside int.
constexpr int kMaxDisparityPx = 1 << 15;
/// Largest padded curve length: 256 is already a multiple of every kernel's vector width.
constexpr int kMaxPadded = kMaxDisparities;
/// Bytes a kernel may read from a strip: padded length + 2W - 2 (the fused shiftable
/// windows span 2W - 1 columns), rounded up.
constexpr int kStripCapacity = kMaxPadded + 2 * kMaxWindow;
/// round(2^16 / W) turns the window-sum difference into a rounded mean difference without a
/// division per disparity; |sum| <= 63 * 255 keeps the product inside int32.
constexpr int kMeanShift = 16;

inline int roundUp(int n, int multiple) { return (n + multiple - 1) / multiple * multiple; }

inline int meanReciprocal(int w) { return ((1 << kMeanShift) + w / 2) / w; }

/// round((sum_r - sum_l) / W) via the fixed-point reciprocal (arithmetic shift = floor).
inline int16_t roundedMeanDiff(int sum_diff, int reciprocal) {
  return static_cast<int16_t>((sum_diff * reciprocal + (1 << (kMeanShift - 1))) >> kMeanShift);
}

/// OK, or why the inputs of matchSalient / pairCorners / measureRowSupport are unusable
/// (null out, empty or differently sized images, invalid options, window past the image).
Status checkInputs(const ImageU8& left,
                   const ImageU8& right,
                   const SalientSadOptions& options,
                   const StereoHypotheses* out);

/// Largest cost a hypothesis may have under the max_cost_per_px gate [grey levels].
int costGate(const SalientSadOptions& options);

/// Scratch for one cost curve: a zero-padded copy of the strip when the kernel's padded reads
/// would run past the image buffer, and the zero-mean offsets.
struct CurveScratch {
  alignas(32) uint8_t strip[kStripCapacity];
  alignas(32) uint8_t strip_hi[kStripCapacity];
  alignas(32) int16_t offsets[kMaxPadded];
};

/// Per-disparity rounded mean difference mean(strip[j..j+w)) - mean(win), j < n; 0 up to padded.
inline void windowOffsets(
    const uint8_t* win, int w, const uint8_t* strip, int n, int padded, int16_t* offsets) {
  const int reciprocal = meanReciprocal(w);
  int sum_l = 0;
  int sum_r = 0;
  for (int i = 0; i < w; ++i) {
    sum_l += win[i];
    sum_r += strip[i];
  }
  for (int j = 0; j < n; ++j) {
    offsets[j] = roundedMeanDiff(sum_r - sum_l, reciprocal);
    if (j + 1 < n) sum_r += strip[j + w] - strip[j];
  }
  std::fill(offsets + n, offsets + padded, int16_t{0});
}

/// Columns [base, base + need) of `image` row `row` for a kernel: the image's own pixels, or a
/// zero-padded copy when the padded reads would run past the end of the buffer. The caller
/// guarantees that the columns the valid lanes read exist.
inline const uint8_t* stripFor(
    const ImageU8& image, int row, int base, size_t need, uint8_t* copy) {
  const size_t start = static_cast<size_t>(row) * static_cast<size_t>(image.width) + base;
  const uint8_t* strip = image.data.data() + start;
  if (start + need <= image.data.size()) return strip;
  const size_t avail = image.data.size() - start;
  std::memcpy(copy, strip, avail);
  std::memset(copy + avail, 0, need - avail);
  return copy;
}

/// The image a curve's strip comes from, and its Birchfield-Tomasi intervals (lo, hi; both
/// null for plain or zero-mean SAD). Zero-mean offsets always use the image's own pixels.
struct StripSource {
  const ImageU8* image = nullptr;
  const ImageU8* lo = nullptr;
  const ImageU8* hi = nullptr;
};

/// Runs the kernel for window `win` against columns [base, base + n + w - 1) of `image` row
/// `row` (the caller guarantees they exist). cost[j], j < n, is valid afterwards.
inline void costCurve(Simd kernel,
                      const uint8_t* win,
                      int w,
                      const StripSource& source,
                      int row,
                      int base,
                      int n,
                      bool zero_mean,
                      CurveScratch* scratch,
                      uint16_t* cost) {
  const int padded = internal::paddedLength(n, kernel);
  const auto need = static_cast<size_t>(padded + w - 1);
  const int16_t* offsets = nullptr;
  if (zero_mean) {
    // The means read only the n + w - 1 columns that exist.
    const uint8_t* pixels = source.image->row(row) + base;
    windowOffsets(win, w, pixels, n, padded, scratch->offsets);
    offsets = scratch->offsets;
  }
  if (source.lo != nullptr) {
    const uint8_t* lo = stripFor(*source.lo, row, base, need, scratch->strip);
    const uint8_t* hi = stripFor(*source.hi, row, base, need, scratch->strip_hi);
    internal::intervalCurve(kernel, win, w, lo, hi, offsets, n, cost);
    return;
  }
  const uint8_t* strip = stripFor(*source.image, row, base, need, scratch->strip);
  internal::sadCurve(kernel, win, w, strip, offsets, n, cost);
}

/// SAD of two 1xW windows (plain or zero-mean), for corner pairing.
inline int windowCost(const uint8_t* a, const uint8_t* b, int w, bool zero_mean) {
  int offset = 0;
  if (zero_mean) {
    int sum_a = 0;
    int sum_b = 0;
    for (int i = 0; i < w; ++i) {
      sum_a += a[i];
      sum_b += b[i];
    }
    offset = roundedMeanDiff(sum_b - sum_a, meanReciprocal(w));
  }
  int cost = 0;
  for (int i = 0; i < w; ++i) cost += std::abs(a[i] - b[i] + offset);
  return cost;
}

/// Smallest of c[0, n). Costs stay below 2^15 (W <= 63 and |difference| <= 510), so signed
/// 16-bit SIMD minima are exact.
inline int minCost(const uint16_t* c, int n) {
  int t = 0;
  int best = INT_MAX;
#if defined(__SSE2__)
  if (n >= 8) {
    __m128i m = _mm_loadu_si128(reinterpret_cast<const __m128i*>(c));  // NOLINT
    for (t = 8; t + 8 <= n; t += 8) {
      m = _mm_min_epi16(m, _mm_loadu_si128(reinterpret_cast<const __m128i*>(c + t)));  // NOLINT
    }
    m = _mm_min_epi16(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(1, 0, 3, 2)));
    m = _mm_min_epi16(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(2, 3, 0, 1)));
    m = _mm_min_epi16(m, _mm_shufflelo_epi16(m, _MM_SHUFFLE(2, 3, 0, 1)));
    best = _mm_extract_epi16(m, 0);
  }
#endif
  for (; t < n; ++t) best = std::min(best, static_cast<int>(c[t]));
  return best;
}

/// Guard entries around every stored cost curve: c[-1] and c[n .. n + kGuard) hold kNoCost, so
/// the local-minimum test needs no special case at the ends and its vector loads stay inside
/// the curve's slot.
constexpr int kGuard = 8;
constexpr uint16_t kNoCost = 0x7FFF;  // above every real cost (< 2^15)
constexpr int kCurveStride = kGuard + kMaxPadded + 2 * kGuard;

/// Calls f(t), in increasing t, for every local minimum of c[0, n) at most `limit`: c[t] <
/// c[t - 1] and c[t] <= c[t + 1] (a plateau reports its first index). c must carry the guards.
template <typename F>
inline void forEachLocalMinimum(const uint16_t* c, int n, int limit, F&& f) {
  limit = std::min(limit, kNoCost - 1);
#if defined(__SSE2__)
  // Branch-free pass over up to 64 entries builds a bit mask; only the set bits (the few
  // local minima under the limit) are visited.
  const __m128i lim = _mm_set1_epi16(static_cast<int16_t>(limit));
  auto pass8 = [&lim](const uint16_t* p) {
    const __m128i cur = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));       // NOLINT
    const __m128i prev = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p - 1));  // NOLINT
    const __m128i next = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 1));  // NOLINT
    const __m128i reject = _mm_or_si128(_mm_cmpgt_epi16(cur, next), _mm_cmpgt_epi16(cur, lim));
    return _mm_andnot_si128(reject, _mm_cmplt_epi16(cur, prev));
  };
  for (int t0 = 0; t0 < n; t0 += 64) {
    uint64_t bits = 0;
    // Lanes at t >= n read guards (kNoCost > limit) and never pass.
    for (int q = 0; q < 4 && t0 + 16 * q < n; ++q) {
      const uint16_t* p = c + t0 + 16 * q;
      const auto m16 =
          static_cast<uint64_t>(_mm_movemask_epi8(_mm_packs_epi16(pass8(p), pass8(p + 8))));
      bits |= m16 << (16 * q);
    }
    while (bits != 0) {
      f(t0 + __builtin_ctzll(bits));
      bits &= bits - 1;
    }
  }
#else
  for (int t = 0; t < n; ++t) {
    if (c[t] <= limit && c[t] < c[t - 1] && c[t] <= c[t + 1]) f(t);
  }
#endif
}

/// Writes the guards of a curve of length n (after the kernel, which may scribble on the
/// padded lanes).
inline void setGuards(uint16_t* c, int n) {
  c[-1] = kNoCost;
  std::fill(c + n, c + n + 2 * kGuard, kNoCost);
}

/// Vertex offset of the parabola through (-1, c_minus), (0, c0), (1, c_plus), in [-0.5, 0.5].
inline float parabolaOffset(int c_minus, int c0, int c_plus) {
  const int denom = c_minus - 2 * c0 + c_plus;
  if (denom <= 0) return 0.0f;
  const float x = static_cast<float>(c_minus - c_plus) / (2.0f * static_cast<float>(denom));
  return std::clamp(x, -0.5f, 0.5f);
}

}  // namespace twocam::frontend::internal
