#include "frontend/support_value_internal.h"
/// Geometry, weights, padded images, window sums and the hot loops of the support-value matcher
/// (support_value_internal.h).

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

// The hot loops (binary structures, support values, correlation sums) are always-inline bodies
// compiled twice on x86-64: the baseline copy and a target("avx2,popcnt") copy, chosen at run
// time by SupportValueOptions::simd (frontend/simd.h). The population count is what pays:
// without POPCNT the baseline's __builtin_popcountll is a bit-twiddling sequence.
// The kernels below (the out-of-line copies) start on a 64-byte boundary, so that their hot
// loops do not move with the code that the linker happens to place before them.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define TWOCAM_SV_HAVE_AVX2 1
#define TWOCAM_SV_INLINE inline __attribute__((always_inline))
#define TWOCAM_SV_KERNEL __attribute__((aligned(64)))
#else
#define TWOCAM_SV_HAVE_AVX2 0
#define TWOCAM_SV_INLINE inline
#define TWOCAM_SV_KERNEL
#endif

namespace twocam::frontend::internal::support {

// ---------------------------------------------------------------------------------------------
// Geometry and weights.

Geometry makeGeometry(int width, int height, const SupportValueOptions& o) {
  Geometry g;
  g.width = width;
  g.height = height;
  g.win = o.window_px;
  g.half = o.window_px / 2;
  g.n = g.win * g.win;
  g.words = (g.n + 63) / 64;
  g.wp = width + 2 * g.half;
  g.hp = height + 2 * g.half;
  g.dmin = o.min_disparity_px;
  g.nd = o.max_disparity_px - o.min_disparity_px + 1;
  return g;
}

namespace {

std::vector<int> weightMatrix(const SupportValueOptions& o) {
  const int win = o.window_px;
  if (!o.weights.empty()) return o.weights;
  std::vector<int> w(static_cast<size_t>(win) * win, 1);
  if (o.weighting == SupportWeighting::kDecreasing) {
    const int h = win / 2;
    for (int i = 0; i < win; ++i) {
      for (int j = 0; j < win; ++j) {
        const int ring = std::max(std::abs(i - h), std::abs(j - h));
        w[static_cast<size_t>(i) * win + j] = h + 1 - ring;
      }
    }
  }
  return w;
}

}  // namespace

WeightPlanes makePlanes(const SupportValueOptions& o) {
  const std::vector<int> w = weightMatrix(o);
  WeightPlanes p;
  p.equal = std::all_of(w.begin(), w.end(), [](int x) { return x == 1; });
  int max_w = 0;
  for (int x : w) {
    max_w = std::max(max_w, x);
    p.total += x;
  }
  while (p.count < kMaxPlanes && (max_w >> p.count) != 0) ++p.count;
  for (size_t k = 0; k < w.size(); ++k) {
    for (int b = 0; b < p.count; ++b) {
      if ((w[k] >> b) & 1) p.mask[b][k / 64] |= uint64_t{1} << (k % 64);
    }
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// Padded images and window sums.

void padImage(const ImageU8& image, const Geometry& g, std::vector<uint8_t>* pad) {
  pad->assign(static_cast<size_t>(g.wp) * g.hp + kPadSlack, 0);
  for (int y = 0; y < g.hp; ++y) {
    const int v = std::clamp(y - g.half, 0, g.height - 1);
    const uint8_t* src = image.row(v);
    uint8_t* dst = pad->data() + static_cast<size_t>(y) * g.wp;
    std::memset(dst, src[0], static_cast<size_t>(g.half));
    std::memcpy(dst + g.half, src, static_cast<size_t>(g.width));
    std::memset(dst + g.half + g.width, src[g.width - 1], static_cast<size_t>(g.half));
  }
}

// Integral images of the padded image and of its squares, (wp + 1) x (hp + 1).
void integrate(const std::vector<uint8_t>& pad,
               const Geometry& g,
               std::vector<int64_t>* sum,
               std::vector<int64_t>* sq) {
  const int iw = g.wp + 1;
  sum->assign(static_cast<size_t>(iw) * (g.hp + 1), 0);
  sq->assign(static_cast<size_t>(iw) * (g.hp + 1), 0);
  for (int y = 0; y < g.hp; ++y) {
    int64_t row_sum = 0;
    int64_t row_sq = 0;
    const uint8_t* src = pad.data() + static_cast<size_t>(y) * g.wp;
    int64_t* s_prev = sum->data() + static_cast<size_t>(y) * iw;
    int64_t* s_cur = s_prev + iw;
    int64_t* q_prev = sq->data() + static_cast<size_t>(y) * iw;
    int64_t* q_cur = q_prev + iw;
    for (int x = 0; x < g.wp; ++x) {
      row_sum += src[x];
      row_sq += static_cast<int64_t>(src[x]) * src[x];
      s_cur[x + 1] = s_prev[x + 1] + row_sum;
      q_cur[x + 1] = q_prev[x + 1] + row_sq;
    }
  }
}

namespace {

// Sums over the window centred on image pixel (u, v) (top-left (u, v) in padded coordinates).
WindowStats windowStats(const std::vector<int64_t>& sum,
                        const std::vector<int64_t>& sq,
                        const Geometry& g,
                        int u,
                        int v) {
  const size_t iw = static_cast<size_t>(g.wp) + 1;
  const size_t a = static_cast<size_t>(v) * iw + u;
  const size_t b = a + g.win;
  const size_t c = a + static_cast<size_t>(g.win) * iw;
  const size_t d = c + g.win;
  return {sum[d] - sum[b] - sum[c] + sum[a], sq[d] - sq[b] - sq[c] + sq[a]};
}

}  // namespace

void pixelStats(const std::vector<int64_t>& sum,
                const std::vector<int64_t>& sq,
                const Geometry& g,
                std::vector<PixelStats>* out) {
  out->resize(static_cast<size_t>(g.width) * g.height);
  for (int v = 0; v < g.height; ++v) {
    for (int u = 0; u < g.width; ++u) {
      const WindowStats w = windowStats(sum, sq, g, u, v);
      const int64_t var = g.n * w.sq - w.sum * w.sum;
      PixelStats& p = (*out)[static_cast<size_t>(v) * g.width + u];
      p.sum = static_cast<int32_t>(w.sum);
      p.inv_std = var > 0 ? static_cast<float>(1.0 / std::sqrt(static_cast<double>(var))) : 0.0f;
    }
  }
}

namespace {

// ---------------------------------------------------------------------------------------------
// Hot loops (compiled twice, see the top of the file).

// Bits j of the result: row[j] > threshold, j < count (count <= 32).
TWOCAM_SV_INLINE uint32_t rowBits(const uint8_t* row, int threshold, int count) {
#if defined(__SSE2__)
  const __m128i bias = _mm_set1_epi8(static_cast<char>(0x80));
  const __m128i t = _mm_set1_epi8(static_cast<char>(threshold ^ 0x80));
  const __m128i a = _mm_xor_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row)), bias);
  uint32_t bits = static_cast<uint32_t>(_mm_movemask_epi8(_mm_cmpgt_epi8(a, t)));
  if (count > 16) {
    const __m128i b =
        _mm_xor_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + 16)), bias);
    bits |= static_cast<uint32_t>(_mm_movemask_epi8(_mm_cmpgt_epi8(b, t))) << 16;
  }
  return count >= 32 ? bits : bits & ((uint32_t{1} << count) - 1);
#else
  uint32_t bits = 0;
  for (int j = 0; j < count; ++j) bits |= static_cast<uint32_t>(row[j] > threshold) << j;
  return bits;
#endif
}

// The binary structure of the window whose top-left padded pixel is (x, y): bit i * win + j is
// 1 when the window's pixel (i, j) exceeds the window mean, i.e. when 'pixel > floor(sum / n)'
// (for integer pixels the same as 'pixel > sum / n').
TWOCAM_SV_INLINE void buildStructure(
    const uint8_t* pad, const Geometry& g, int x, int y, int64_t sum, uint64_t* out) {
  const int threshold = static_cast<int>(sum / g.n);
  for (int k = 0; k < g.words; ++k) out[k] = 0;
  const uint8_t* p = pad + static_cast<size_t>(y) * g.wp + x;
  int offset = 0;
  for (int i = 0; i < g.win; ++i, p += g.wp, offset += g.win) {
    const uint64_t bits = rowBits(p, threshold, g.win);
    const int word = offset >> 6;
    const int shift = offset & 63;
    out[word] |= bits << shift;
    if (shift + g.win > 64) out[word + 1] |= bits >> (64 - shift);
  }
}

TWOCAM_SV_INLINE void buildAllStructures(const uint8_t* pad,
                                         const std::vector<int64_t>& integral,
                                         const Geometry& g,
                                         uint64_t* masks) {
  const size_t iw = static_cast<size_t>(g.wp) + 1;
  for (int v = 0; v < g.height; ++v) {
    const int64_t* top = integral.data() + static_cast<size_t>(v) * iw;
    const int64_t* bottom = top + static_cast<size_t>(g.win) * iw;
    for (int u = 0; u < g.width; ++u) {
      const int64_t s = bottom[u + g.win] - bottom[u] - top[u + g.win] + top[u];
      buildStructure(pad, g, u, v, s, masks + (static_cast<size_t>(v) * g.width + u) * g.words);
    }
  }
}

// Weighted disagreement of two structures: total weight minus the support value.
template <int kWords>
TWOCAM_SV_INLINE int64_t disagreementFixed(const uint64_t* a,
                                           const uint64_t* b,
                                           const WeightPlanes& planes) {
  if (planes.equal) {
    int64_t c = 0;
    for (int k = 0; k < kWords; ++k) c += __builtin_popcountll(a[k] ^ b[k]);
    return c;
  }
  int64_t c = 0;
  for (int p = 0; p < planes.count; ++p) {
    int64_t cp = 0;
    for (int k = 0; k < kWords; ++k) cp += __builtin_popcountll((a[k] ^ b[k]) & planes.mask[p][k]);
    c += cp << p;
  }
  return c;
}

TWOCAM_SV_INLINE int64_t disagreementAny(const uint64_t* a,
                                         const uint64_t* b,
                                         int words,
                                         const WeightPlanes& planes) {
  int64_t c = 0;
  for (int p = 0; p < (planes.equal ? 1 : planes.count); ++p) {
    int64_t cp = 0;
    for (int k = 0; k < words; ++k) {
      const uint64_t x = a[k] ^ b[k];
      cp += __builtin_popcountll(planes.equal ? x : x & planes.mask[p][k]);
    }
    c += cp << p;
  }
  return c;
}

// Support values of one row: sv[u * nd + k] for left pixel u and disparity dmin + k, -1 where
// u - d < 0.
template <int kWords>
TWOCAM_SV_INLINE void supportRowFixed(const uint64_t* left_row,
                                      const uint64_t* right_row,
                                      const Geometry& g,
                                      const WeightPlanes& planes,
                                      int32_t* sv) {
  const int64_t total = planes.total;
  for (int u = 0; u < g.width; ++u) {
    const uint64_t* a = left_row + static_cast<size_t>(u) * kWords;
    int32_t* out = sv + static_cast<size_t>(u) * g.nd;
    // Disparities with u - d >= 0: k <= u - dmin.
    const int reach = std::clamp(u - g.dmin + 1, 0, g.nd);
    for (int k = 0; k < reach; ++k) {
      const uint64_t* b = right_row + static_cast<size_t>(u - g.dmin - k) * kWords;
      out[k] = static_cast<int32_t>(total - disagreementFixed<kWords>(a, b, planes));
    }
    for (int k = reach; k < g.nd; ++k) out[k] = kNoMatch;
  }
}

TWOCAM_SV_INLINE void supportRowBody(const uint64_t* left_row,
                                     const uint64_t* right_row,
                                     const Geometry& g,
                                     const WeightPlanes& planes,
                                     int32_t* sv) {
  switch (g.words) {
    case 1:
      supportRowFixed<1>(left_row, right_row, g, planes, sv);
      return;
    case 2:
      supportRowFixed<2>(left_row, right_row, g, planes, sv);
      return;
    case 3:
      supportRowFixed<3>(left_row, right_row, g, planes, sv);
      return;
    case 4:
      supportRowFixed<4>(left_row, right_row, g, planes, sv);
      return;
    default:
      break;
  }
  for (int u = 0; u < g.width; ++u) {
    const uint64_t* a = left_row + static_cast<size_t>(u) * g.words;
    int32_t* out = sv + static_cast<size_t>(u) * g.nd;
    for (int k = 0; k < g.nd; ++k) {
      const int u_r = u - g.dmin - k;
      out[k] = u_r < 0
                   ? kNoMatch
                   : static_cast<int32_t>(
                         planes.total -
                         disagreementAny(
                             a, right_row + static_cast<size_t>(u_r) * g.words, g.words, planes));
    }
  }
}

// Cross sums sum L * R over the window for every left pixel u of row v and disparity dmin + k:
// cross[k * width + u] (u >= d). col[k * wp + x] holds the column sums of padded column x of the
// window rows, slid down one row per call (v = 0 starts them).
TWOCAM_SV_INLINE void crossRowBody(const uint8_t* __restrict left_pad,
                                   const uint8_t* __restrict right_pad,
                                   const Geometry& g,
                                   int v,
                                   int32_t* __restrict col,
                                   int32_t* __restrict cross) {
  for (int k = 0; k < g.nd; ++k) {
    const int d = g.dmin + k;
    int32_t* c = col + static_cast<size_t>(k) * g.wp;
    if (d >= g.width) continue;
    if (v == 0) {
      for (int x = d; x < g.wp; ++x) c[x] = 0;
      for (int i = 0; i < g.win; ++i) {
        const uint8_t* l = left_pad + static_cast<size_t>(i) * g.wp + d;
        const uint8_t* r = right_pad + static_cast<size_t>(i) * g.wp;
        int32_t* cd = c + d;
        for (int x = 0; x < g.wp - d; ++x) cd[x] += static_cast<int32_t>(l[x]) * r[x];
      }
    } else {
      // Row pointers start at left column d and right column 0 (right = left - d).
      const uint8_t* l_in = left_pad + static_cast<size_t>(v + g.win - 1) * g.wp + d;
      const uint8_t* r_in = right_pad + static_cast<size_t>(v + g.win - 1) * g.wp;
      const uint8_t* l_out = left_pad + static_cast<size_t>(v - 1) * g.wp + d;
      const uint8_t* r_out = right_pad + static_cast<size_t>(v - 1) * g.wp;
      int32_t* cd = c + d;
      for (int x = 0; x < g.wp - d; ++x) {
        cd[x] +=
            static_cast<int32_t>(l_in[x]) * r_in[x] - static_cast<int32_t>(l_out[x]) * r_out[x];
      }
    }
    int32_t* out = cross + static_cast<size_t>(k) * g.width;
    int32_t s = 0;
    for (int x = d; x < d + g.win; ++x) s += c[x];
    out[d] = s;
    for (int u = d + 1; u < g.width; ++u) {
      s += c[u + g.win - 1] - c[u - 1];
      out[u] = s;
    }
  }
}

TWOCAM_SV_KERNEL void structuresBaseline(const uint8_t* pad,
                                         const std::vector<int64_t>& integral,
                                         const Geometry& g,
                                         uint64_t* masks) {
  buildAllStructures(pad, integral, g, masks);
}
TWOCAM_SV_KERNEL void supportBaseline(
    const uint64_t* l, const uint64_t* r, const Geometry& g, const WeightPlanes& p, int32_t* sv) {
  supportRowBody(l, r, g, p, sv);
}
TWOCAM_SV_KERNEL void crossBaseline(
    const uint8_t* l, const uint8_t* r, const Geometry& g, int v, int32_t* col, int32_t* cross) {
  crossRowBody(l, r, g, v, col, cross);
}
TWOCAM_SV_KERNEL int64_t disagreementBaseline(const uint64_t* a,
                                              const uint64_t* b,
                                              int words,
                                              const WeightPlanes& p) {
  return disagreementAny(a, b, words, p);
}
TWOCAM_SV_KERNEL void structureBaseline(
    const uint8_t* pad, const Geometry& g, int x, int y, int64_t sum, uint64_t* out) {
  buildStructure(pad, g, x, y, sum, out);
}

#if TWOCAM_SV_HAVE_AVX2
__attribute__((target("avx2,popcnt"))) TWOCAM_SV_KERNEL void structuresAvx2(
    const uint8_t* pad, const std::vector<int64_t>& integral, const Geometry& g, uint64_t* masks) {
  buildAllStructures(pad, integral, g, masks);
}
__attribute__((target("avx2,popcnt"))) TWOCAM_SV_KERNEL void supportAvx2(
    const uint64_t* l, const uint64_t* r, const Geometry& g, const WeightPlanes& p, int32_t* sv) {
  supportRowBody(l, r, g, p, sv);
}
__attribute__((target("avx2,popcnt"))) TWOCAM_SV_KERNEL void crossAvx2(
    const uint8_t* l, const uint8_t* r, const Geometry& g, int v, int32_t* col, int32_t* cross) {
  crossRowBody(l, r, g, v, col, cross);
}
__attribute__((target("avx2,popcnt"))) TWOCAM_SV_KERNEL int64_t
disagreementAvx2(const uint64_t* a, const uint64_t* b, int words, const WeightPlanes& p) {
  return disagreementAny(a, b, words, p);
}
__attribute__((target("avx2,popcnt"))) TWOCAM_SV_KERNEL void structureAvx2(
    const uint8_t* pad, const Geometry& g, int x, int y, int64_t sum, uint64_t* out) {
  buildStructure(pad, g, x, y, sum, out);
}
#endif

}  // namespace

Kernels kernelsFor(Simd simd) {
#if TWOCAM_SV_HAVE_AVX2
  if (resolveSimd(simd) == Simd::kAvx2) {
    return {structuresAvx2, supportAvx2, crossAvx2, disagreementAvx2, structureAvx2};
  }
#else
  (void)simd;
#endif
  return {
      structuresBaseline, supportBaseline, crossBaseline, disagreementBaseline, structureBaseline};
}

}  // namespace twocam::frontend::internal::support
