#include "frontend/salient_sad.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define TWOCAM_HAVE_AVX2_KERNEL 1
#endif

namespace twocam::frontend {
namespace {

constexpr int kMinWindow = 3;
constexpr int kMaxWindow = 63;
constexpr int kMaxDisparities = 256;
constexpr int kMaxRowTolerance = 8;
constexpr int kMaxHypothesesLimit = 255;
constexpr int kMaxRowSupportRadius = 16;
/// Largest padded curve length: 256 is already a multiple of every kernel's vector width.
constexpr int kMaxPadded = kMaxDisparities;
/// Bytes a kernel may read from a strip: padded length + 2W - 2 (the fused shiftable
/// windows span 2W - 1 columns), rounded up.
constexpr int kStripCapacity = kMaxPadded + 2 * kMaxWindow;
/// round(2^16 / W) turns the window-sum difference into a rounded mean difference without a
/// division per disparity; |sum| <= 63 * 255 keeps the product inside int32.
constexpr int kMeanShift = 16;

int roundUp(int n, int multiple) { return (n + multiple - 1) / multiple * multiple; }

int meanReciprocal(int w) { return ((1 << kMeanShift) + w / 2) / w; }

/// round((sum_r - sum_l) / W) via the fixed-point reciprocal (arithmetic shift = floor).
int16_t roundedMeanDiff(int sum_diff, int reciprocal) {
  return static_cast<int16_t>((sum_diff * reciprocal + (1 << (kMeanShift - 1))) >> kMeanShift);
}

// ---------------------------------------------------------------------------------------------
// Cost-curve kernels. Plain SAD is computed as prefix curves: outs[k][j] = sum over
// i < ends[k] of |win[i] - strip[i + j]|, so one pass over 2W-1 offsets yields the left-,
// centre- and right-aligned windows (differences of prefixes). Zero-mean SAD has its own
// kernels: cost[j] = sum_i |win[i] - strip[i + j] + offsets[j]|.

/// Plain SAD when strip_hi is null; otherwise the distance of win[i] to the interval
/// [strip[i + j], strip_hi[i + j]]: max(0, lo - l, l - hi) (Birchfield-Tomasi).
void prefixScalar(const uint8_t* win,
                  const uint8_t* strip,
                  const uint8_t* strip_hi,
                  int n,
                  const int* ends,
                  int num_ends,
                  uint16_t* const* outs) {
  uint16_t acc[kMaxPadded] = {};
  int i = 0;
  for (int k = 0; k < num_ends; ++k) {
    for (; i < ends[k]; ++i) {
      const int l = win[i];
      const uint8_t* s = strip + i;
      if (strip_hi == nullptr) {
        for (int j = 0; j < n; ++j) acc[j] = static_cast<uint16_t>(acc[j] + std::abs(l - s[j]));
      } else {
        const uint8_t* t = strip_hi + i;
        for (int j = 0; j < n; ++j) {
          acc[j] = static_cast<uint16_t>(acc[j] + std::max({0, s[j] - l, l - t[j]}));
        }
      }
    }
    std::copy(acc, acc + n, outs[k]);
  }
}

/// Zero-mean cost: |l + offset - s|, or with strip_hi the distance of l + offset to the
/// interval [strip, strip_hi].
void zeroMeanScalar(const uint8_t* win,
                    int w,
                    const uint8_t* strip,
                    const uint8_t* strip_hi,
                    const int16_t* offsets,
                    int n,
                    uint16_t* cost) {
  std::fill(cost, cost + n, uint16_t{0});
  for (int i = 0; i < w; ++i) {
    const int l = win[i];
    const uint8_t* s = strip + i;
    if (strip_hi == nullptr) {
      for (int j = 0; j < n; ++j) {
        cost[j] = static_cast<uint16_t>(cost[j] + std::abs(l - s[j] + offsets[j]));
      }
    } else {
      const uint8_t* t = strip_hi + i;
      for (int j = 0; j < n; ++j) {
        const int x = l + offsets[j];
        cost[j] = static_cast<uint16_t>(cost[j] + std::max({0, s[j] - x, x - t[j]}));
      }
    }
  }
}

#if defined(__SSE2__)
/// NC chunks of 16 disparities with the accumulators in registers; |a - b| of bytes by two
/// saturating subtractions, widened to uint16 lanes (125 offsets x 255 < 2^15).
/// kInterval: strip is the interval's low end and strip_hi its high end, and
/// subs(lo, l) | subs(l, hi) is the distance to the interval (at most one term is non-zero).
template <int NC, bool kInterval>
inline void sse2PrefixGroup(const uint8_t* win,
                            const uint8_t* strip,
                            const uint8_t* strip_hi,
                            const int* ends,
                            int num_ends,
                            uint16_t* const* outs,
                            int g) {
  const __m128i zero = _mm_setzero_si128();
  __m128i acc[2 * NC];
  for (int c = 0; c < 2 * NC; ++c) acc[c] = zero;
  int i = 0;
  for (int k = 0; k < num_ends; ++k) {
    for (; i < ends[k]; ++i) {
      const __m128i b = _mm_set1_epi8(static_cast<char>(win[i]));
      for (int c = 0; c < NC; ++c) {
        const __m128i s =
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(strip + i + 16 * c));  // NOLINT
        const __m128i t = kInterval ? _mm_loadu_si128(reinterpret_cast<const __m128i*>(
                                          strip_hi + i + 16 * c))  // NOLINT
                                    : s;
        const __m128i ad = _mm_or_si128(_mm_subs_epu8(s, b), _mm_subs_epu8(b, t));
        acc[2 * c] = _mm_add_epi16(acc[2 * c], _mm_unpacklo_epi8(ad, zero));
        acc[2 * c + 1] = _mm_add_epi16(acc[2 * c + 1], _mm_unpackhi_epi8(ad, zero));
      }
    }
    for (int c = 0; c < 2 * NC; ++c) {
      _mm_storeu_si128(reinterpret_cast<__m128i*>(outs[k] + g + 8 * c), acc[c]);  // NOLINT
    }
  }
}

/// Zero-mean variant in int16 lanes: |l - s + offset| <= 510, times W <= 63 fits. kInterval:
/// max(lo - x, x - hi, 0) with x = l + offset, strip = lo, strip_hi = hi.
template <int NC, bool kInterval>
inline void sse2ZeroMeanGroup(const uint8_t* win,
                              int w,
                              const uint8_t* strip,
                              const uint8_t* strip_hi,
                              const int16_t* offsets,
                              uint16_t* cost) {
  const __m128i zero = _mm_setzero_si128();
  __m128i acc[2 * NC];
  __m128i off[2 * NC];
  for (int c = 0; c < 2 * NC; ++c) {
    acc[c] = zero;
    off[c] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(offsets + 8 * c));  // NOLINT
  }
  for (int i = 0; i < w; ++i) {
    const __m128i b = _mm_set1_epi16(static_cast<int16_t>(win[i]));
    for (int c = 0; c < NC; ++c) {
      const __m128i s =
          _mm_loadu_si128(reinterpret_cast<const __m128i*>(strip + i + 16 * c));  // NOLINT
      const __m128i x0 = _mm_add_epi16(b, off[2 * c]);
      const __m128i x1 = _mm_add_epi16(b, off[2 * c + 1]);
      __m128i t0 = _mm_sub_epi16(x0, _mm_unpacklo_epi8(s, zero));
      __m128i t1 = _mm_sub_epi16(x1, _mm_unpackhi_epi8(s, zero));
      if constexpr (kInterval) {
        const __m128i hi =
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(strip_hi + i + 16 * c));  // NOLINT
        // t = x - lo; lo - x = -t; x - hi; the largest, floored at 0.
        t0 = _mm_max_epi16(
            _mm_max_epi16(_mm_sub_epi16(zero, t0), _mm_sub_epi16(x0, _mm_unpacklo_epi8(hi, zero))),
            zero);
        t1 = _mm_max_epi16(
            _mm_max_epi16(_mm_sub_epi16(zero, t1), _mm_sub_epi16(x1, _mm_unpackhi_epi8(hi, zero))),
            zero);
      } else {
        t0 = _mm_max_epi16(t0, _mm_sub_epi16(zero, t0));
        t1 = _mm_max_epi16(t1, _mm_sub_epi16(zero, t1));
      }
      acc[2 * c] = _mm_add_epi16(acc[2 * c], t0);
      acc[2 * c + 1] = _mm_add_epi16(acc[2 * c + 1], t1);
    }
  }
  for (int c = 0; c < 2 * NC; ++c) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(cost + 8 * c), acc[c]);  // NOLINT
  }
}

template <bool kInterval>
void prefixSse2(const uint8_t* win,
                const uint8_t* strip,
                const uint8_t* strip_hi,
                int n,
                const int* ends,
                int num_ends,
                uint16_t* const* outs) {
  const int padded = roundUp(n, 16);
  for (int g = 0; g < padded; g += 64) {
    const uint8_t* s = strip + g;
    const uint8_t* t = kInterval ? strip_hi + g : nullptr;
    switch (std::min(4, (padded - g) / 16)) {
      case 1:
        sse2PrefixGroup<1, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
      case 2:
        sse2PrefixGroup<2, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
      case 3:
        sse2PrefixGroup<3, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
      default:
        sse2PrefixGroup<4, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
    }
  }
}

template <bool kInterval>
void zeroMeanSse2(const uint8_t* win,
                  int w,
                  const uint8_t* strip,
                  const uint8_t* strip_hi,
                  const int16_t* offsets,
                  int n,
                  uint16_t* cost) {
  const int padded = roundUp(n, 16);
  for (int g = 0; g < padded; g += 64) {
    const uint8_t* s = strip + g;
    const uint8_t* t = kInterval ? strip_hi + g : nullptr;
    const int16_t* o = offsets + g;
    switch (std::min(4, (padded - g) / 16)) {
      case 1:
        sse2ZeroMeanGroup<1, kInterval>(win, w, s, t, o, cost + g);
        break;
      case 2:
        sse2ZeroMeanGroup<2, kInterval>(win, w, s, t, o, cost + g);
        break;
      case 3:
        sse2ZeroMeanGroup<3, kInterval>(win, w, s, t, o, cost + g);
        break;
      default:
        sse2ZeroMeanGroup<4, kInterval>(win, w, s, t, o, cost + g);
        break;
    }
  }
}
#endif  // __SSE2__

#if defined(TWOCAM_HAVE_AVX2_KERNEL)
/// NC chunks of 32 disparities. unpacklo/hi work per 128-bit lane, so acc[2c] holds
/// disparities 0-7 and 16-23 of the chunk, acc[2c+1] 8-15 and 24-31; the stores undo it.
template <int NC, bool kInterval>
__attribute__((target("avx2"))) inline void avx2PrefixGroup(const uint8_t* win,
                                                            const uint8_t* strip,
                                                            const uint8_t* strip_hi,
                                                            const int* ends,
                                                            int num_ends,
                                                            uint16_t* const* outs,
                                                            int g) {
  const __m256i zero = _mm256_setzero_si256();
  __m256i acc[2 * NC];
  for (int c = 0; c < 2 * NC; ++c) acc[c] = zero;
  int i = 0;
  for (int k = 0; k < num_ends; ++k) {
    for (; i < ends[k]; ++i) {
      const __m256i b = _mm256_set1_epi8(static_cast<char>(win[i]));
      for (int c = 0; c < NC; ++c) {
        const __m256i s =
            _mm256_loadu_si256(reinterpret_cast<const __m256i*>(strip + i + 32 * c));  // NOLINT
        __m256i ad;
        if constexpr (kInterval) {
          const __m256i t = _mm256_loadu_si256(
              reinterpret_cast<const __m256i*>(strip_hi + i + 32 * c));  // NOLINT
          ad = _mm256_or_si256(_mm256_subs_epu8(s, b), _mm256_subs_epu8(b, t));
        } else {
          ad = _mm256_sub_epi8(_mm256_max_epu8(s, b), _mm256_min_epu8(s, b));
        }
        acc[2 * c] = _mm256_add_epi16(acc[2 * c], _mm256_unpacklo_epi8(ad, zero));
        acc[2 * c + 1] = _mm256_add_epi16(acc[2 * c + 1], _mm256_unpackhi_epi8(ad, zero));
      }
    }
    for (int c = 0; c < NC; ++c) {
      uint16_t* out = outs[k] + g + 32 * c;
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out),  // NOLINT
                          _mm256_permute2x128_si256(acc[2 * c], acc[2 * c + 1], 0x20));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + 16),  // NOLINT
                          _mm256_permute2x128_si256(acc[2 * c], acc[2 * c + 1], 0x31));
    }
  }
}

/// Zero-mean variant: NC chunks of 16 disparities, bytes zero-extended in order.
template <int NC, bool kInterval>
__attribute__((target("avx2"))) inline void avx2ZeroMeanGroup(const uint8_t* win,
                                                              int w,
                                                              const uint8_t* strip,
                                                              const uint8_t* strip_hi,
                                                              const int16_t* offsets,
                                                              uint16_t* cost) {
  __m256i acc[NC];
  __m256i off[NC];
  for (int c = 0; c < NC; ++c) {
    acc[c] = _mm256_setzero_si256();
    off[c] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(offsets + 16 * c));  // NOLINT
  }
  for (int i = 0; i < w; ++i) {
    const __m256i b = _mm256_set1_epi16(static_cast<int16_t>(win[i]));
    for (int c = 0; c < NC; ++c) {
      const __m256i s = _mm256_cvtepu8_epi16(
          _mm_loadu_si128(reinterpret_cast<const __m128i*>(strip + i + 16 * c)));  // NOLINT
      const __m256i x = _mm256_add_epi16(b, off[c]);
      if constexpr (kInterval) {
        const __m256i hi = _mm256_cvtepu8_epi16(
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(strip_hi + i + 16 * c)));  // NOLINT
        const __m256i d = _mm256_max_epi16(_mm256_sub_epi16(s, x), _mm256_sub_epi16(x, hi));
        acc[c] = _mm256_add_epi16(acc[c], _mm256_max_epi16(d, _mm256_setzero_si256()));
      } else {
        acc[c] = _mm256_add_epi16(acc[c], _mm256_abs_epi16(_mm256_sub_epi16(x, s)));
      }
    }
  }
  for (int c = 0; c < NC; ++c) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(cost + 16 * c), acc[c]);  // NOLINT
  }
}

template <bool kInterval>
__attribute__((target("avx2"))) void prefixAvx2(const uint8_t* win,
                                                const uint8_t* strip,
                                                const uint8_t* strip_hi,
                                                int n,
                                                const int* ends,
                                                int num_ends,
                                                uint16_t* const* outs) {
  const int padded = roundUp(n, 32);
  for (int g = 0; g < padded; g += 128) {
    const uint8_t* s = strip + g;
    const uint8_t* t = kInterval ? strip_hi + g : nullptr;
    switch (std::min(4, (padded - g) / 32)) {
      case 1:
        avx2PrefixGroup<1, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
      case 2:
        avx2PrefixGroup<2, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
      case 3:
        avx2PrefixGroup<3, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
      default:
        avx2PrefixGroup<4, kInterval>(win, s, t, ends, num_ends, outs, g);
        break;
    }
  }
}

template <bool kInterval>
__attribute__((target("avx2"))) void zeroMeanAvx2(const uint8_t* win,
                                                  int w,
                                                  const uint8_t* strip,
                                                  const uint8_t* strip_hi,
                                                  const int16_t* offsets,
                                                  int n,
                                                  uint16_t* cost) {
  const int padded = roundUp(n, 32);
  for (int g = 0; g < padded; g += 64) {
    const uint8_t* t = kInterval ? strip_hi + g : nullptr;
    // padded is a multiple of 32, so the tail group has 2 or 4 chunks of 16.
    if (padded - g >= 64) {
      avx2ZeroMeanGroup<4, kInterval>(win, w, strip + g, t, offsets + g, cost + g);
    } else {
      avx2ZeroMeanGroup<2, kInterval>(win, w, strip + g, t, offsets + g, cost + g);
    }
  }
}
#endif  // TWOCAM_HAVE_AVX2_KERNEL

bool cpuHasAvx2() {
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

// ---------------------------------------------------------------------------------------------
// Shared plumbing of both matchers.

Status checkInputs(const ImageU8& left,
                   const ImageU8& right,
                   const SalientSadOptions& options,
                   const StereoHypotheses* out) {
  if (out == nullptr) return Status::error("out is null");
  if (left.empty() || right.empty()) {
    return Status::error("empty image: left is " + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ", right is " + std::to_string(right.width) +
                         "x" + std::to_string(right.height));
  }
  if (left.width != right.width || left.height != right.height) {
    return Status::error("image sizes differ: left is " + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ", right is " + std::to_string(right.width) +
                         "x" + std::to_string(right.height));
  }
  const size_t pixels = static_cast<size_t>(left.width) * static_cast<size_t>(left.height);
  if (left.width <= 0 || left.height <= 0 || left.data.size() != pixels ||
      right.data.size() != pixels) {
    return Status::error("image buffer size does not match width x height");
  }
  const Status valid = options.validate();
  if (!valid.isOk()) return valid;
  if (options.max_disparity_px + options.window_width_px > left.width) {
    return Status::error("max_disparity_px + window_width_px = " +
                         std::to_string(options.max_disparity_px + options.window_width_px) +
                         " exceeds the image width " + std::to_string(left.width) +
                         "; no pixel can be matched");
  }
  return Status::ok();
}

/// Largest cost a hypothesis may have under the max_cost_per_px gate [grey levels].
int costGate(const SalientSadOptions& options) {
  const double gate = static_cast<double>(options.max_cost_per_px) * options.window_width_px;
  return static_cast<int>(std::min(gate, static_cast<double>(INT_MAX / 2)));
}

/// Scratch for one cost curve: a zero-padded copy of the strip when the kernel's padded reads
/// would run past the image buffer, and the zero-mean offsets.
struct CurveScratch {
  alignas(32) uint8_t strip[kStripCapacity];
  alignas(32) uint8_t strip_hi[kStripCapacity];
  alignas(32) int16_t offsets[kMaxPadded];
};

/// Per-disparity rounded mean difference mean(strip[j..j+w)) - mean(win), j < n; 0 up to padded.
void windowOffsets(
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
const uint8_t* stripFor(const ImageU8& image, int row, int base, size_t need, uint8_t* copy) {
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
void costCurve(SadKernel kernel,
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
int windowCost(const uint8_t* a, const uint8_t* b, int w, bool zero_mean) {
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
int minCost(const uint16_t* c, int n) {
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
void forEachLocalMinimum(const uint16_t* c, int n, int limit, F&& f) {
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
void setGuards(uint16_t* c, int n) {
  c[-1] = kNoCost;
  std::fill(c + n, c + n + 2 * kGuard, kNoCost);
}

/// One cost curve of a corner: right row v + row_offset_px, window columns
/// u + align_px - h .. u + align_px + h (align_px = 0 is the centred window).
struct Curve {
  int row_offset_px = 0;
  int align_px = 0;
  int d_hi = 0;  // curve index t <-> disparity d_hi - t
  int n = 0;
  uint16_t* cost = nullptr;
};

/// A local minimum of one curve.
struct Candidate {
  int cost;
  int d_px;
  int t;      // index in the curve
  int curve;  // index of the curve; curves are ordered by preference for equal costs
};

bool cheaper(const Candidate& a, const Candidate& b) {
  if (a.cost != b.cost) return a.cost < b.cost;
  if (a.curve != b.curve) return a.curve < b.curve;
  return a.d_px < b.d_px;
}

/// Vertex offset of the parabola through (-1, c_minus), (0, c0), (1, c_plus), in [-0.5, 0.5].
float parabolaOffset(int c_minus, int c0, int c_plus) {
  const int denom = c_minus - 2 * c0 + c_plus;
  if (denom <= 0) return 0.0f;
  const float x = static_cast<float>(c_minus - c_plus) / (2.0f * static_cast<float>(denom));
  return std::clamp(x, -0.5f, 0.5f);
}

}  // namespace

// -------------------------------------------------------------------------------------------------

namespace internal {

SadKernel resolveKernel(SadKernel kernel) {
  if (kernel != SadKernel::kAuto) return kernel;
  if (cpuHasAvx2()) return SadKernel::kAvx2;
#if defined(__SSE2__)
  return SadKernel::kSse2;
#else
  return SadKernel::kScalar;
#endif
}

int paddedLength(int n, SadKernel kernel) {
  switch (resolveKernel(kernel)) {
    case SadKernel::kSse2:
      return roundUp(n, 16);
    case SadKernel::kAvx2:
      return roundUp(n, 32);
    default:
      return n;
  }
}

void sadPrefixCurves(SadKernel kernel,
                     const uint8_t* win,
                     const uint8_t* strip,
                     int n,
                     const int* ends,
                     int num_ends,
                     uint16_t* const* outs) {
  intervalPrefixCurves(kernel, win, strip, nullptr, n, ends, num_ends, outs);
}

void intervalPrefixCurves(SadKernel kernel,
                          const uint8_t* win,
                          const uint8_t* strip_lo,
                          const uint8_t* strip_hi,
                          int n,
                          const int* ends,
                          int num_ends,
                          uint16_t* const* outs) {
  const bool interval = strip_hi != nullptr;
  switch (resolveKernel(kernel)) {
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
    case SadKernel::kAvx2:
      if (interval) {
        prefixAvx2<true>(win, strip_lo, strip_hi, n, ends, num_ends, outs);
      } else {
        prefixAvx2<false>(win, strip_lo, nullptr, n, ends, num_ends, outs);
      }
      return;
#endif
#if defined(__SSE2__)
    case SadKernel::kSse2:
      if (interval) {
        prefixSse2<true>(win, strip_lo, strip_hi, n, ends, num_ends, outs);
      } else {
        prefixSse2<false>(win, strip_lo, nullptr, n, ends, num_ends, outs);
      }
      return;
#endif
    default:
      prefixScalar(win, strip_lo, strip_hi, n, ends, num_ends, outs);
      return;
  }
}

void samplingIntervals(const ImageU8& image, ImageU8* lo, ImageU8* hi) {
  const int width = image.width;
  const int height = image.height;
  for (ImageU8* out : {lo, hi}) {
    out->width = width;
    out->height = height;
    out->data.resize(image.data.size());
  }
  if (width <= 0 || height <= 0) return;
  // Half-pixel value between columns a and b: (I(a) + I(b) + 1) / 2, as _mm_avg_epu8 rounds.
  auto half = [](int a, int b) { return static_cast<uint8_t>((a + b + 1) >> 1); };
  for (int v = 0; v < height; ++v) {
    const uint8_t* in = image.row(v);
    uint8_t* l = lo->data.data() + static_cast<size_t>(v) * width;
    uint8_t* h = hi->data.data() + static_cast<size_t>(v) * width;
    // The end columns have one half-pixel neighbour.
    auto scalar = [&](int x) {
      uint8_t a = in[x];
      uint8_t b = in[x];
      if (x > 0) {
        a = std::min(a, half(in[x - 1], in[x]));
        b = std::max(b, half(in[x - 1], in[x]));
      }
      if (x + 1 < width) {
        a = std::min(a, half(in[x], in[x + 1]));
        b = std::max(b, half(in[x], in[x + 1]));
      }
      l[x] = a;
      h[x] = b;
    };
    int x = 1;
#if defined(__SSE2__)
    for (; x + 17 <= width; x += 16) {
      const __m128i c = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + x));      // NOLINT
      const __m128i p = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + x - 1));  // NOLINT
      const __m128i n = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + x + 1));  // NOLINT
      const __m128i hp = _mm_avg_epu8(p, c);
      const __m128i hn = _mm_avg_epu8(c, n);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(l + x),  // NOLINT
                       _mm_min_epu8(c, _mm_min_epu8(hp, hn)));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(h + x),  // NOLINT
                       _mm_max_epu8(c, _mm_max_epu8(hp, hn)));
    }
#endif
    scalar(0);
    for (; x < width; ++x) scalar(x);
  }
}

void sadCurve(SadKernel kernel,
              const uint8_t* win,
              int w,
              const uint8_t* strip,
              const int16_t* offsets,
              int n,
              uint16_t* cost) {
  intervalCurve(kernel, win, w, strip, nullptr, offsets, n, cost);
}

void intervalCurve(SadKernel kernel,
                   const uint8_t* win,
                   int w,
                   const uint8_t* strip_lo,
                   const uint8_t* strip_hi,
                   const int16_t* offsets,
                   int n,
                   uint16_t* cost) {
  if (offsets == nullptr) {
    intervalPrefixCurves(kernel, win, strip_lo, strip_hi, n, &w, 1, &cost);
    return;
  }
  const bool interval = strip_hi != nullptr;
  switch (resolveKernel(kernel)) {
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
    case SadKernel::kAvx2:
      if (interval) {
        zeroMeanAvx2<true>(win, w, strip_lo, strip_hi, offsets, n, cost);
      } else {
        zeroMeanAvx2<false>(win, w, strip_lo, nullptr, offsets, n, cost);
      }
      return;
#endif
#if defined(__SSE2__)
    case SadKernel::kSse2:
      if (interval) {
        zeroMeanSse2<true>(win, w, strip_lo, strip_hi, offsets, n, cost);
      } else {
        zeroMeanSse2<false>(win, w, strip_lo, nullptr, offsets, n, cost);
      }
      return;
#endif
    default:
      zeroMeanScalar(win, w, strip_lo, strip_hi, offsets, n, cost);
      return;
  }
}

}  // namespace internal

bool sadKernelAvailable(SadKernel kernel) {
  switch (kernel) {
    case SadKernel::kAuto:
    case SadKernel::kScalar:
      return true;
    case SadKernel::kSse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
    case SadKernel::kAvx2:
      return cpuHasAvx2();
  }
  return false;
}

Status SalientSadOptions::validate() const {
  auto fail = [](const std::string& what) { return Status::error(what); };
  if (window_width_px < kMinWindow || window_width_px > kMaxWindow || window_width_px % 2 == 0) {
    return fail("window_width_px = " + std::to_string(window_width_px) +
                "; must be odd and in [3, 63]");
  }
  if (min_disparity_px < 0) {
    return fail("min_disparity_px = " + std::to_string(min_disparity_px) + "; must be >= 0");
  }
  if (max_disparity_px < min_disparity_px) {
    return fail("max_disparity_px = " + std::to_string(max_disparity_px) +
                "; must be >= min_disparity_px = " + std::to_string(min_disparity_px));
  }
  if (max_disparity_px - min_disparity_px + 1 > kMaxDisparities) {
    return fail("max_disparity_px - min_disparity_px + 1 = " +
                std::to_string(max_disparity_px - min_disparity_px + 1) + "; must be <= 256");
  }
  if (row_tolerance_px < 0 || row_tolerance_px > kMaxRowTolerance) {
    return fail("row_tolerance_px = " + std::to_string(row_tolerance_px) + "; must be in [0, 8]");
  }
  if (max_hypotheses < 1 || max_hypotheses > kMaxHypothesesLimit) {
    return fail("max_hypotheses = " + std::to_string(max_hypotheses) + "; must be in [1, 255]");
  }
  if (!std::isfinite(cost_ratio) || cost_ratio < 1.0f) {
    return fail("cost_ratio = " + std::to_string(cost_ratio) + "; must be finite and >= 1");
  }
  if (!std::isfinite(complete_cost_ratio) || complete_cost_ratio < cost_ratio) {
    return fail("complete_cost_ratio = " + std::to_string(complete_cost_ratio) +
                "; must be finite and >= cost_ratio");
  }
  if (min_separation_px < 1) {
    return fail("min_separation_px = " + std::to_string(min_separation_px) + "; must be >= 1");
  }
  if (lr_tolerance_px < 0) {
    return fail("lr_tolerance_px = " + std::to_string(lr_tolerance_px) + "; must be >= 0");
  }
  if (!std::isfinite(max_cost_per_px) || max_cost_per_px <= 0.0f) {
    return fail("max_cost_per_px = " + std::to_string(max_cost_per_px) +
                "; must be finite and > 0");
  }
  if (row_support_radius_px < 1 || row_support_radius_px > kMaxRowSupportRadius) {
    return fail("row_support_radius_px = " + std::to_string(row_support_radius_px) +
                "; must be in [1, 16]");
  }
  if (!sadKernelAvailable(kernel)) {
    return fail("kernel = " + std::to_string(static_cast<int>(kernel)) +
                " is not available on this CPU or build");
  }
  return Status::ok();
}

Status matchSalient(const ImageU8& left,
                    const ImageU8& right,
                    const std::vector<Corner>& corners,
                    const SalientSadOptions& options,
                    StereoHypotheses* out) {
  const Status status = checkInputs(left, right, options, out);
  if (!status.isOk()) return status;
  out->clear();
  out->points.reserve(corners.size());

  const SadKernel kernel = internal::resolveKernel(options.kernel);
  const int w = options.window_width_px;
  const int h = w / 2;
  const int m = options.row_tolerance_px;
  const int d_min = options.min_disparity_px;
  const int d_max = options.max_disparity_px;
  const int width = left.width;
  const int height = left.height;
  const int gate = costGate(options);
  const size_t max_k = static_cast<size_t>(options.max_hypotheses);
  // Window alignments, centred first (preferred on equal cost): ending at u, starting at u.
  const int alignments[3] = {0, -h, h};
  const int num_alignments = options.shiftable_windows ? 3 : 1;

  // Birchfield-Tomasi: forward curves read the right image's intervals, the right-to-left
  // check the left image's. Reused across calls on this thread (4 images' worth of bytes).
  thread_local ImageU8 intervals[4];
  StripSource forward{&right, nullptr, nullptr};
  StripSource backward{&left, nullptr, nullptr};
  if (options.birchfield_tomasi) {
    internal::samplingIntervals(right, &intervals[0], &intervals[1]);
    forward.lo = &intervals[0];
    forward.hi = &intervals[1];
    if (options.lr_check) {
      internal::samplingIntervals(left, &intervals[2], &intervals[3]);
      backward.lo = &intervals[2];
      backward.hi = &intervals[3];
    }
  }

  CurveScratch scratch;
  constexpr int kMaxCurves = (2 * kMaxRowTolerance + 1) * 3;
  std::vector<uint16_t> curve_storage(static_cast<size_t>(kMaxCurves) * kCurveStride);
  Curve curves[kMaxCurves];
  alignas(32) uint16_t back[kMaxPadded];
  alignas(32) uint16_t prefix[4][kMaxPadded];
  std::vector<Candidate> candidates;
  candidates.reserve(64);
  Candidate chosen[kMaxHypothesesLimit];

  for (const Corner& corner : corners) {
    const int u = corner.u_px;
    const int v = corner.v_px;
    if (u < h || u >= width - h || v < 0 || v >= height) continue;
    const auto point_index = static_cast<uint32_t>(out->points.size());
    SalientPoint point;
    point.corner = corner;
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());

    // One pass over the 2W-1 columns u-2h..u+2h gives all three alignments when they share
    // the full disparity range (plain SAD; zero-mean offsets differ per window).
    const bool fused =
        num_alignments == 3 && !options.zero_mean && u - 2 * h >= d_max && u + 2 * h < width;

    // Rows in the order 0, -1, +1, -2, +2, ... so that equal costs prefer small offsets.
    int num_curves = 0;
    int best = INT_MAX;
    // A window that does not fit or a curve cut short by the image border leaves disparities
    // unsearched: the hypotheses found are then not known to be all there are.
    bool cut_short = false;
    for (int ri = 0; ri <= 2 * m; ++ri) {
      const int r = (ri % 2 == 1) ? -(ri + 1) / 2 : ri / 2;
      if (v + r < 0 || v + r >= height) {
        cut_short = true;
        continue;
      }
      if (fused) {
        const int n = d_max - d_min + 1;
        const int span = 4 * h + 1;
        const auto need = static_cast<size_t>(internal::paddedLength(n, kernel) + span - 1);
        const int base = u - 2 * h - d_max;
        const uint8_t* strip =
            stripFor(forward.lo != nullptr ? *forward.lo : right, v + r, base, need, scratch.strip);
        const uint8_t* strip_hi = forward.hi == nullptr
                                      ? nullptr
                                      : stripFor(*forward.hi, v + r, base, need, scratch.strip_hi);
        Curve* centre = &curves[num_curves];
        Curve* ends_at_u = &curves[num_curves + 1];
        Curve* starts_at_u = &curves[num_curves + 2];
        for (int k = 0; k < 3; ++k) {
          Curve& curve = curves[num_curves + k];
          curve.row_offset_px = r;
          curve.align_px = alignments[k];
          curve.d_hi = d_max;
          curve.n = n;
          curve.cost =
              curve_storage.data() + static_cast<size_t>(num_curves + k) * kCurveStride + kGuard;
        }
        // Prefix ends: h, 2h, 2h+1 (= window ending at u), 3h+1, 4h+1.
        const int ends[5] = {h, 2 * h, 2 * h + 1, 3 * h + 1, 4 * h + 1};
        uint16_t* const outs[5] = {prefix[0], prefix[1], ends_at_u->cost, prefix[2], prefix[3]};
        internal::intervalPrefixCurves(
            kernel, left.row(v) + (u - 2 * h), strip, strip_hi, n, ends, 5, outs);
        for (int j = 0; j < n; ++j) {
          centre->cost[j] = static_cast<uint16_t>(prefix[2][j] - prefix[0][j]);
          starts_at_u->cost[j] = static_cast<uint16_t>(prefix[3][j] - prefix[1][j]);
        }
        for (int k = 0; k < 3; ++k) {
          setGuards(curves[num_curves + k].cost, n);
          best = std::min(best, minCost(curves[num_curves + k].cost, n));
        }
        num_curves += 3;
        continue;
      }
      for (int ai = 0; ai < num_alignments; ++ai) {
        const int a = alignments[ai];
        const int start = u + a - h;  // first column of the left window
        if (start < 0 || start + w > width) {
          cut_short = true;
          continue;
        }
        // Disparities whose right window starts left of column 0 are not searched.
        const int d_hi = std::min(d_max, start);
        if (d_hi < d_max) cut_short = true;
        if (d_hi < d_min) continue;
        Curve& curve = curves[num_curves];
        curve.row_offset_px = r;
        curve.align_px = a;
        curve.d_hi = d_hi;
        curve.n = d_hi - d_min + 1;
        curve.cost = curve_storage.data() + static_cast<size_t>(num_curves) * kCurveStride + kGuard;
        costCurve(kernel,
                  left.row(v) + start,
                  w,
                  forward,
                  v + r,
                  start - d_hi,
                  curve.n,
                  options.zero_mean,
                  &scratch,
                  curve.cost);
        setGuards(curve.cost, curve.n);
        // Cut short by the image border, the curve's end at d_hi is not a minimum of the
        // matching cost, only of what could be searched: the true disparity may lie beyond
        // (a corner nearer the left edge than its disparity). A zero guard keeps t = 0 from
        // ever passing the local-minimum test. Measured on the office world: such end points
        // were a quarter of the wrongly confirmed landmarks (d = u exactly, 1-2 px short).
        if (d_hi < d_max) curve.cost[-1] = 0;
        best = std::min(best, minCost(curve.cost, curve.n));
        ++num_curves;
      }
    }
    if (num_curves == 0 || best > gate) {
      out->points.push_back(point);
      continue;
    }
    const double ratio_limit = static_cast<double>(best) * options.cost_ratio;
    const int threshold = std::min(gate, static_cast<int>(std::min(ratio_limit, 1e9)));
    if (gate < ratio_limit) cut_short = true;  // max_cost_per_px hides minima within cost_ratio

    candidates.clear();
    for (int k = 0; k < num_curves; ++k) {
      const Curve& curve = curves[k];
      const uint16_t* c = curve.cost;
      forEachLocalMinimum(c, curve.n, threshold, [&](int t) {
        candidates.push_back({static_cast<int>(c[t]), curve.d_hi - t, t, k});
      });
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      return cheaper(a, b);
    });

    size_t num_chosen = 0;
    bool dropped = false;  // a minimum that may be the real disparity is not in the list
    for (const Candidate& cand : candidates) {
      bool distinct = true;
      for (size_t k = 0; k < num_chosen; ++k) {
        if (std::abs(cand.d_px - chosen[k].d_px) < options.min_separation_px) {
          distinct = false;
          break;
        }
      }
      if (!distinct) continue;
      if (num_chosen == max_k) {
        dropped = true;  // no room in the list
        break;
      }
      chosen[num_chosen++] = cand;
    }
    if (!dropped && !cut_short && num_chosen >= 2) {
      // A periodic texture's real disparity may sit half a pixel off the grid, its aliases on
      // it, and cost up to complete_cost_ratio x the best (taken as at least 1 grey level per
      // pixel): a local minimum that cheap where the list's period continues (2 d_i - d_j,
      // within 1 px) and not in the list leaves it incomplete.
      const double complete_limit =
          static_cast<double>(std::max(best, w)) * options.complete_cost_ratio;
      const int limit = static_cast<int>(std::min(complete_limit, 1e9));
      if (gate < complete_limit) dropped = true;  // max_cost_per_px could hide it
      for (size_t i = 0; i < num_chosen && !dropped; ++i) {
        for (size_t j = 0; j < num_chosen && !dropped; ++j) {
          const int next = 2 * chosen[i].d_px - chosen[j].d_px;
          if (i == j || next + 1 < d_min || next - 1 > d_max) continue;
          bool listed = false;
          for (size_t k = 0; k < num_chosen; ++k)
            listed = listed || std::abs(chosen[k].d_px - next) <= 1;
          if (listed) continue;
          for (int k = 0; k < num_curves && !dropped; ++k) {
            const Curve& curve = curves[k];
            const uint16_t* c = curve.cost;
            for (int d = next - 1; d <= next + 1 && !dropped; ++d) {
              const int t = curve.d_hi - d;  // cost index of disparity d
              if (t < 0 || t >= curve.n) continue;
              dropped = c[t] <= limit && c[t] < c[t - 1] && c[t] <= c[t + 1];
            }
          }
        }
      }
    }
    point.complete = !dropped && !cut_short;

    for (size_t k = 0; k < num_chosen; ++k) {
      const Candidate& cand = chosen[k];
      const Curve& curve = curves[cand.curve];
      const uint16_t* c = curve.cost;
      float offset = 0.0f;
      if (cand.t > 0 && cand.t + 1 < curve.n) {
        // c[t + 1] is disparity d - 1, c[t - 1] is d + 1.
        offset = parabolaOffset(c[cand.t + 1], c[cand.t], c[cand.t - 1]);
      }
      DisparityHypothesis hyp;
      hyp.d_px = static_cast<float>(cand.d_px) + offset;
      hyp.cost = static_cast<float>(cand.cost);
      hyp.point_index = point_index;
      hyp.row_offset_px = static_cast<int8_t>(curve.row_offset_px);
      hyp.window_shift_px = static_cast<int8_t>(curve.align_px);
      hyp.rank = static_cast<uint8_t>(k);
      if (options.lr_check) {
        // The right window (same alignment) at u - d on row v + r, searched along left row v:
        // back curve index t <-> disparity d_min + t.
        const int right_start = u - cand.d_px + curve.align_px - h;
        const int back_hi = std::min(d_max, width - w - right_start);
        const int back_n = back_hi - d_min + 1;
        costCurve(kernel,
                  right.row(v + curve.row_offset_px) + right_start,
                  w,
                  backward,
                  v,
                  right_start + d_min,
                  back_n,
                  options.zero_mean,
                  &scratch,
                  back);
        const int t_lo = std::max(0, cand.d_px - options.lr_tolerance_px - d_min);
        const int t_hi = std::min(back_n - 1, cand.d_px + options.lr_tolerance_px - d_min);
        int near_best = INT_MAX;
        for (int t = t_lo; t <= t_hi; ++t)
          near_best = std::min(near_best, static_cast<int>(back[t]));
        hyp.lr_consistent = near_best == minCost(back, back_n);
      }
      out->hypotheses.push_back(hyp);
    }
    point.num_hypotheses = static_cast<uint32_t>(num_chosen);
    out->points.push_back(point);
  }
  return Status::ok();
}

namespace {

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

}  // namespace

namespace {

/// Row support of one hypothesis (see measureRowSupport), any options.
float rowSpan(const ImageU8& left,
              const ImageU8& right,
              const SalientSadOptions& options,
              SadKernel kernel,
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
        hyp.row_span_px = rowSpan(left, right, options, SadKernel::kAvx2, corner, hyp, &scratch);
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
  }
  for (DisparityHypothesis& hyp : hyps->hypotheses) hyp.row_span_px = 0.0f;
  const SadKernel kernel = internal::resolveKernel(options.kernel);
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
  if (kernel == SadKernel::kAvx2 && !options.zero_mean && options.window_width_px >= 4 &&
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

const DisparityHypothesis* confidentBest(const StereoHypotheses& hyps,
                                         const SalientPoint& point,
                                         float agree_px) {
  if (point.num_hypotheses == 0) return nullptr;
  TWOCAM_CHECK(static_cast<size_t>(point.first_hypothesis) + point.num_hypotheses <=
               hyps.hypotheses.size())
      << "point's hypotheses [" << point.first_hypothesis << ", +" << point.num_hypotheses
      << ") outside the " << hyps.hypotheses.size() << " of this StereoHypotheses";
  const DisparityHypothesis* first = &hyps.hypotheses[point.first_hypothesis];
  if (!first->lr_consistent) return nullptr;
  for (uint32_t k = 1; k < point.num_hypotheses; ++k) {
    if (first[k].lr_consistent && std::abs(first[k].d_px - first->d_px) > agree_px) {
      return nullptr;
    }
  }
  return first;
}

Status pairCorners(const ImageU8& left,
                   const ImageU8& right,
                   const std::vector<Corner>& left_corners,
                   const std::vector<Corner>& right_corners,
                   const SalientSadOptions& options,
                   StereoHypotheses* out) {
  const Status status = checkInputs(left, right, options, out);
  if (!status.isOk()) return status;
  out->clear();
  out->points.reserve(left_corners.size());

  const int w = options.window_width_px;
  const int h = w / 2;
  const int m = options.row_tolerance_px;
  const int width = left.width;
  const int height = left.height;
  const int gate = costGate(options);

  // Row index of the right corners whose window fits: row_begin[v]..row_begin[v + 1] in
  // `by_row`, sorted by column.
  std::vector<uint32_t> row_begin(static_cast<size_t>(height) + 1, 0);
  for (const Corner& c : right_corners) {
    if (c.u_px >= h && c.u_px < width - h && c.v_px >= 0 && c.v_px < height) {
      ++row_begin[static_cast<size_t>(c.v_px) + 1];
    }
  }
  for (int v = 0; v < height; ++v) row_begin[v + 1] += row_begin[v];
  std::vector<uint32_t> by_row(row_begin[height]);
  {
    std::vector<uint32_t> fill(row_begin.begin(), row_begin.end() - 1);
    for (size_t i = 0; i < right_corners.size(); ++i) {
      const Corner& c = right_corners[i];
      if (c.u_px >= h && c.u_px < width - h && c.v_px >= 0 && c.v_px < height) {
        by_row[fill[c.v_px]++] = static_cast<uint32_t>(i);
      }
    }
  }
  auto column_less = [&right_corners](uint32_t a, uint32_t b) {
    return right_corners[a].u_px < right_corners[b].u_px ||
           (right_corners[a].u_px == right_corners[b].u_px && a < b);
  };
  for (int v = 0; v < height; ++v) {
    std::sort(by_row.begin() + row_begin[v], by_row.begin() + row_begin[v + 1], column_less);
  }

  struct Pair {
    int cost;
    int d_px;
    int row_offset_px;
    uint32_t right_index;
  };
  std::vector<Pair> pairs;
  std::vector<uint32_t> pair_begin;  // per point, into pairs
  pair_begin.reserve(left_corners.size() + 1);
  std::vector<int> right_best(right_corners.size(), INT_MAX);

  for (const Corner& corner : left_corners) {
    const int u = corner.u_px;
    const int v = corner.v_px;
    if (u < h || u >= width - h || v < 0 || v >= height) continue;
    pair_begin.push_back(static_cast<uint32_t>(pairs.size()));
    SalientPoint point;
    point.corner = corner;
    out->points.push_back(point);
    const uint8_t* win = left.row(v) + (u - h);
    const int u_lo = u - options.max_disparity_px;
    const int u_hi = u - options.min_disparity_px;
    for (int r = -m; r <= m; ++r) {
      const int vr = v + r;
      if (vr < 0 || vr >= height) continue;
      const auto first = by_row.begin() + row_begin[vr];
      const auto last = by_row.begin() + row_begin[vr + 1];
      auto it = std::lower_bound(first, last, u_lo, [&right_corners](uint32_t i, int col) {
        return right_corners[i].u_px < col;
      });
      for (; it != last && right_corners[*it].u_px <= u_hi; ++it) {
        const int ur = right_corners[*it].u_px;
        int cost = windowCost(win, right.row(vr) + (ur - h), w, options.zero_mean);
        if (options.shiftable_windows) {
          for (const int a : {-h, h}) {
            if (std::min(u, ur) + a - h < 0 || std::max(u, ur) + a + h >= width) continue;
            cost = std::min(
                cost,
                windowCost(
                    left.row(v) + (u + a - h), right.row(vr) + (ur + a - h), w, options.zero_mean));
          }
        }
        pairs.push_back({cost, u - ur, r, *it});
        right_best[*it] = std::min(right_best[*it], cost);
      }
    }
  }
  pair_begin.push_back(static_cast<uint32_t>(pairs.size()));

  auto pair_less = [](const Pair& a, const Pair& b) {
    if (a.cost != b.cost) return a.cost < b.cost;
    if (a.d_px != b.d_px) return a.d_px < b.d_px;
    if (std::abs(a.row_offset_px) != std::abs(b.row_offset_px)) {
      return std::abs(a.row_offset_px) < std::abs(b.row_offset_px);
    }
    return a.row_offset_px < b.row_offset_px;
  };
  for (size_t p = 0; p < out->points.size(); ++p) {
    const auto first = pairs.begin() + pair_begin[p];
    const auto last = pairs.begin() + pair_begin[p + 1];
    const auto kept_end =
        std::partition(first, last, [gate](const Pair& pr) { return pr.cost <= gate; });
    const auto count = std::min<std::ptrdiff_t>(kept_end - first, options.max_hypotheses);
    std::partial_sort(first, first + count, kept_end, pair_less);
    SalientPoint& point = out->points[p];
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    point.num_hypotheses = static_cast<uint32_t>(count);
    for (std::ptrdiff_t k = 0; k < count; ++k) {
      const Pair& pr = first[k];
      DisparityHypothesis hyp;
      hyp.d_px = static_cast<float>(pr.d_px);
      hyp.cost = static_cast<float>(pr.cost);
      hyp.point_index = static_cast<uint32_t>(p);
      hyp.row_offset_px = static_cast<int8_t>(pr.row_offset_px);
      hyp.rank = static_cast<uint8_t>(k);
      hyp.lr_consistent = options.lr_check && pr.cost == right_best[pr.right_index];
      out->hypotheses.push_back(hyp);
    }
  }
  return Status::ok();
}

}  // namespace twocam::frontend
