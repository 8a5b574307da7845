#include "frontend/sad_kernels.h"

#include <algorithm>
#include <cstdlib>

#include "frontend/cost_curve.h"

namespace twocam::frontend {
namespace {

using internal::kMaxPadded;
using internal::roundUp;

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

}  // namespace

// -------------------------------------------------------------------------------------------------

namespace internal {

int paddedLength(int n, Simd kernel) {
  switch (resolveSimd(kernel)) {
    case Simd::kSse2:
      return roundUp(n, 16);
    case Simd::kAvx2:
      return roundUp(n, 32);
    default:
      return n;
  }
}

void sadPrefixCurves(Simd kernel,
                     const uint8_t* win,
                     const uint8_t* strip,
                     int n,
                     const int* ends,
                     int num_ends,
                     uint16_t* const* outs) {
  intervalPrefixCurves(kernel, win, strip, nullptr, n, ends, num_ends, outs);
}

void intervalPrefixCurves(Simd kernel,
                          const uint8_t* win,
                          const uint8_t* strip_lo,
                          const uint8_t* strip_hi,
                          int n,
                          const int* ends,
                          int num_ends,
                          uint16_t* const* outs) {
  const bool interval = strip_hi != nullptr;
  switch (resolveSimd(kernel)) {
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
    case Simd::kAvx2:
      if (interval) {
        prefixAvx2<true>(win, strip_lo, strip_hi, n, ends, num_ends, outs);
      } else {
        prefixAvx2<false>(win, strip_lo, nullptr, n, ends, num_ends, outs);
      }
      return;
#endif
#if defined(__SSE2__)
    case Simd::kSse2:
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

void sadCurve(Simd kernel,
              const uint8_t* win,
              int w,
              const uint8_t* strip,
              const int16_t* offsets,
              int n,
              uint16_t* cost) {
  intervalCurve(kernel, win, w, strip, nullptr, offsets, n, cost);
}

void intervalCurve(Simd kernel,
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
  switch (resolveSimd(kernel)) {
#if defined(TWOCAM_HAVE_AVX2_KERNEL)
    case Simd::kAvx2:
      if (interval) {
        zeroMeanAvx2<true>(win, w, strip_lo, strip_hi, offsets, n, cost);
      } else {
        zeroMeanAvx2<false>(win, w, strip_lo, nullptr, offsets, n, cost);
      }
      return;
#endif
#if defined(__SSE2__)
    case Simd::kSse2:
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

}  // namespace twocam::frontend
