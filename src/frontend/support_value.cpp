#include "frontend/support_value.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/options_check.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

// The hot loops (binary structures, support values, correlation sums) are always-inline bodies
// compiled twice on x86-64: the baseline copy and a target("avx2,popcnt") copy, chosen at run
// time by SupportValueOptions::simd (frontend/simd.h). The population count is what pays:
// without POPCNT the baseline's __builtin_popcountll is a bit-twiddling sequence.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define TWOCAM_SV_HAVE_AVX2 1
#define TWOCAM_SV_INLINE inline __attribute__((always_inline))
#else
#define TWOCAM_SV_HAVE_AVX2 0
#define TWOCAM_SV_INLINE inline
#endif

namespace twocam::frontend {

namespace {

constexpr int kMaxWindowPx = 31;
constexpr int kMaxWords = (kMaxWindowPx * kMaxWindowPx + 63) / 64;
constexpr int kMaxPlanes = 8;  // weights in [0, 255]
constexpr int kMaxCandidates = 16;
constexpr int kNoMatch = -1;
/// Correlation of a window without variance: below every valid NCC, so it never matches.
constexpr float kNoCorrelation = -2.0f;
/// Bytes after a padded image so that the 16-byte loads of the last window rows stay inside.
constexpr int kPadSlack = 32;

// ---------------------------------------------------------------------------------------------
// Geometry and weights.

struct Geometry {
  int width = 0;  // image
  int height = 0;
  int win = 0;    // window side
  int half = 0;   // win / 2
  int n = 0;      // win * win
  int words = 0;  // 64-bit words per binary structure
  int wp = 0;     // padded width  (width + 2 half)
  int hp = 0;     // padded height
  int dmin = 0;
  int nd = 0;  // number of disparities
};

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

// The weighting matrix as bit planes over the packed binary structure: bit k of a weight sets the
// structure's bit in plane k. equal: every weight 1 (one plane covering every bit, skipped).
struct WeightPlanes {
  bool equal = true;
  int count = 0;
  int64_t total = 0;  // sum of the weights (support value of identical structures)
  uint64_t mask[kMaxPlanes][kMaxWords] = {};
};

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

// Copies `image` into `pad` (wp x hp plus slack) repeating the edge pixels half px outwards.
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

struct WindowStats {
  int64_t sum = 0;
  int64_t sq = 0;
};

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

// Zero-mean normalised cross-correlation from the window sums; kNoCorrelation when a window has
// no variance.
float correlation(int64_t cross, const WindowStats& l, const WindowStats& r, int n) {
  const int64_t num = n * cross - l.sum * r.sum;
  const int64_t var_l = n * l.sq - l.sum * l.sum;
  const int64_t var_r = n * r.sq - r.sum * r.sum;
  if (var_l <= 0 || var_r <= 0) return kNoCorrelation;
  return static_cast<float>(static_cast<double>(num) /
                            std::sqrt(static_cast<double>(var_l) * static_cast<double>(var_r)));
}

// Per-pixel window sum and 1 / sqrt(n * sum of squares - sum^2) (0 when the window has no
// variance), so that a dense correlation costs two multiplications instead of a square root.
using PixelStats = internal::SupportWindowStats;

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

// correlation() from PixelStats (float; the same value up to rounding).
float fastCorrelation(int32_t cross, const PixelStats& l, const PixelStats& r, int n) {
  if (l.inv_std == 0.0f || r.inv_std == 0.0f) return kNoCorrelation;
  const int64_t num = static_cast<int64_t>(n) * cross - static_cast<int64_t>(l.sum) * r.sum;
  return static_cast<float>(num) * l.inv_std * r.inv_std;
}

// Window sums of the padded image for image pixel (u, v), computed directly (salient).
WindowStats directStats(const std::vector<uint8_t>& pad, const Geometry& g, int u, int v) {
  WindowStats w;
  for (int i = 0; i < g.win; ++i) {
    const uint8_t* row = pad.data() + static_cast<size_t>(v + i) * g.wp + u;
    int32_t s = 0;
    int32_t q = 0;
    for (int j = 0; j < g.win; ++j) {
      s += row[j];
      q += static_cast<int32_t>(row[j]) * row[j];
    }
    w.sum += s;
    w.sq += q;
  }
  return w;
}

// Sum of L(window at left u) * R(window at right u_r) on row v, computed directly (salient).
int64_t crossSum(
    const uint8_t* left_pad, const uint8_t* right_pad, const Geometry& g, int u, int u_r, int v) {
  int64_t s = 0;
  for (int i = 0; i < g.win; ++i) {
    const uint8_t* l = left_pad + static_cast<size_t>(v + i) * g.wp + u;
    const uint8_t* r = right_pad + static_cast<size_t>(v + i) * g.wp + u_r;
    int32_t row = 0;
    for (int j = 0; j < g.win; ++j) row += static_cast<int32_t>(l[j]) * r[j];
    s += row;
  }
  return s;
}

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

struct Kernels {
  void (*structures)(const uint8_t*, const std::vector<int64_t>&, const Geometry&, uint64_t*);
  void (*support)(const uint64_t*, const uint64_t*, const Geometry&, const WeightPlanes&, int32_t*);
  void (*cross)(const uint8_t*, const uint8_t*, const Geometry&, int, int32_t*, int32_t*);
  int64_t (*disagreement)(const uint64_t*, const uint64_t*, int, const WeightPlanes&);
  void (*structure)(const uint8_t*, const Geometry&, int, int, int64_t, uint64_t*);
};

void structuresBaseline(const uint8_t* pad,
                        const std::vector<int64_t>& integral,
                        const Geometry& g,
                        uint64_t* masks) {
  buildAllStructures(pad, integral, g, masks);
}
void supportBaseline(
    const uint64_t* l, const uint64_t* r, const Geometry& g, const WeightPlanes& p, int32_t* sv) {
  supportRowBody(l, r, g, p, sv);
}
void crossBaseline(
    const uint8_t* l, const uint8_t* r, const Geometry& g, int v, int32_t* col, int32_t* cross) {
  crossRowBody(l, r, g, v, col, cross);
}
int64_t disagreementBaseline(const uint64_t* a,
                             const uint64_t* b,
                             int words,
                             const WeightPlanes& p) {
  return disagreementAny(a, b, words, p);
}
void structureBaseline(
    const uint8_t* pad, const Geometry& g, int x, int y, int64_t sum, uint64_t* out) {
  buildStructure(pad, g, x, y, sum, out);
}

#if TWOCAM_SV_HAVE_AVX2
__attribute__((target("avx2,popcnt"))) void structuresAvx2(const uint8_t* pad,
                                                           const std::vector<int64_t>& integral,
                                                           const Geometry& g,
                                                           uint64_t* masks) {
  buildAllStructures(pad, integral, g, masks);
}
__attribute__((target("avx2,popcnt"))) void supportAvx2(
    const uint64_t* l, const uint64_t* r, const Geometry& g, const WeightPlanes& p, int32_t* sv) {
  supportRowBody(l, r, g, p, sv);
}
__attribute__((target("avx2,popcnt"))) void crossAvx2(
    const uint8_t* l, const uint8_t* r, const Geometry& g, int v, int32_t* col, int32_t* cross) {
  crossRowBody(l, r, g, v, col, cross);
}
__attribute__((target("avx2,popcnt"))) int64_t disagreementAvx2(const uint64_t* a,
                                                                const uint64_t* b,
                                                                int words,
                                                                const WeightPlanes& p) {
  return disagreementAny(a, b, words, p);
}
__attribute__((target("avx2,popcnt"))) void structureAvx2(
    const uint8_t* pad, const Geometry& g, int x, int y, int64_t sum, uint64_t* out) {
  buildStructure(pad, g, x, y, sum, out);
}
#endif

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

// ---------------------------------------------------------------------------------------------
// Candidates and decision.

// The candidates of one pixel's support-value curve sv[k * stride], k in [0, count): local
// maxima (a plateau counts once, at its last element) within margin of the best, at most
// max_count, best support values first (ties: smaller k). Returns their number; *dropped is set
// when a local maximum within the margin did not fit.
int selectCandidates(const int32_t* sv,
                     int stride,
                     int count,
                     double margin,
                     int max_count,
                     int* out_k,
                     bool* dropped) {
  *dropped = false;
  if (count <= 0) return 0;
  int32_t best = kNoMatch;
  for (int k = 0; k < count; ++k) best = std::max(best, sv[static_cast<size_t>(k) * stride]);
  if (best <= 0) return 0;
  // Smallest integer support value within the margin: s >= (1 - margin) * best.
  const auto limit = static_cast<int32_t>(std::ceil((1.0 - margin) * best));
  int n = 0;
  int32_t values[kMaxCandidates + 1];
  for (int k = 0; k < count; ++k) {
    const int32_t s = sv[static_cast<size_t>(k) * stride];
    if (s < limit) continue;
    const bool left_ok = k == 0 || s >= sv[static_cast<size_t>(k - 1) * stride];
    const bool right_ok = k == count - 1 || s > sv[static_cast<size_t>(k + 1) * stride];
    if (!left_ok || !right_ok) continue;
    // Insert by support value (descending), ties keep the smaller k first.
    int pos = n;
    while (pos > 0 && values[pos - 1] < s) --pos;
    if (pos >= max_count) {
      *dropped = true;
      continue;
    }
    if (n == max_count) *dropped = true;
    const int last = std::min(n, max_count - 1);
    for (int q = last; q > pos; --q) {
      values[q] = values[q - 1];
      out_k[q] = out_k[q - 1];
    }
    values[pos] = s;
    out_k[pos] = k;
    n = std::min(n + 1, max_count);
  }
  return n;
}

// ---------------------------------------------------------------------------------------------
// Row constraints and post-processing.

// Uniqueness and ordering along one row: the kept matches' partner positions pos(x) = x + sign
// * d[x] strictly increase with x (sign -1 for the left view, +1 for the right view). A conflict
// voids the match with the lower score (ties: the earlier one stays).
void orderRow(int width, int sign, int16_t* d, const float* score, std::vector<int>* stack) {
  stack->clear();
  for (int x = 0; x < width; ++x) {
    if (d[x] < 0) continue;
    const int pos = x + sign * d[x];
    bool keep = true;
    while (!stack->empty()) {
      const int top = stack->back();
      if (top + sign * d[top] < pos) break;
      if (score[top] < score[x]) {
        d[top] = kNoMatch;
        stack->pop_back();
      } else {
        keep = false;
        break;
      }
    }
    if (keep) {
      stack->push_back(x);
    } else {
      d[x] = kNoMatch;
    }
  }
}

// Continuity: an estimate stays when at least min_neighbours other estimates of the window lie
// within 1 px of it.
void continuityFilter(const std::vector<int16_t>& in,
                      int width,
                      int height,
                      int window,
                      int min_neighbours,
                      std::vector<int16_t>* out) {
  *out = in;
  if (min_neighbours <= 0) return;
  const int h = window / 2;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int d = in[static_cast<size_t>(v) * width + u];
      if (d < 0) continue;
      int count = -1;  // the pixel itself
      for (int y = std::max(0, v - h); y <= std::min(height - 1, v + h); ++y) {
        const int16_t* row = in.data() + static_cast<size_t>(y) * width;
        for (int x = std::max(0, u - h); x <= std::min(width - 1, u + h); ++x) {
          count += row[x] >= 0 && std::abs(row[x] - d) <= 1 ? 1 : 0;
        }
      }
      if (count < min_neighbours) (*out)[static_cast<size_t>(v) * width + u] = kNoMatch;
    }
  }
}

// Depth-edge erosion: wherever two estimates at most 3 px apart along a row or a column differ by
// more than 1 px, the `width` pixels on the nearer side (larger disparity) that start at the
// nearer estimate and run away from the jump are voided. A centred window that straddles a
// depth edge is dominated by the nearer surface's texture, so the nearer surface's estimates
// spread over the farther one by up to half a window (foreground fattening); the pixels voided
// here are filled from the farther side afterwards. Jumps are found in `in`, voids written to out.
void erodeDepthEdges(
    const std::vector<int16_t>& in, int width, int height, int erosion, std::vector<int16_t>* out) {
  if (erosion <= 0) return;
  constexpr int kMaxGapPx = 3;
  // One line (row or column) of n samples at in[first + i * step].
  auto line = [&](size_t first, size_t step, int n) {
    int prev = -1;
    for (int i = 0; i < n; ++i) {
      const int d = in[first + static_cast<size_t>(i) * step];
      if (d < 0) continue;
      if (prev >= 0 && i - prev <= kMaxGapPx) {
        const int d_prev = in[first + static_cast<size_t>(prev) * step];
        if (d_prev - d > 1) {  // nearer surface before the jump
          for (int j = std::max(0, prev - erosion + 1); j <= prev; ++j)
            (*out)[first + static_cast<size_t>(j) * step] = kNoMatch;
        } else if (d - d_prev > 1) {  // nearer surface after it
          for (int j = i; j < std::min(n, i + erosion); ++j)
            (*out)[first + static_cast<size_t>(j) * step] = kNoMatch;
        }
      }
      prev = i;
    }
  };
  for (int v = 0; v < height; ++v) line(static_cast<size_t>(v) * width, 1, width);
  for (int u = 0; u < width; ++u) line(static_cast<size_t>(u), static_cast<size_t>(width), height);
}

// Fills each row's holes from the nearest estimates either side (linear or farther); at a row's
// ends the nearest estimate; rows without any estimate stay empty.
void fillRows(SupportFill fill, int max_width, int width, int height, ImageF32* map) {
  if (fill == SupportFill::kNone) return;
  if (max_width <= 0) max_width = width;
  for (int v = 0; v < height; ++v) {
    float* row = map->row(v);
    int prev = -1;
    for (int u = 0; u <= width; ++u) {
      if (u < width && row[u] < 0.0f) continue;
      // Hole (prev, u).
      if (u - prev > 1 && u - prev - 1 <= max_width) {
        if (prev < 0 && u == width) break;  // no estimate on this row
        for (int x = prev + 1; x < u; ++x) {
          if (prev < 0) {
            row[x] = row[u];
          } else if (u == width) {
            row[x] = row[prev];
          } else if (fill == SupportFill::kFarther) {
            row[x] = std::min(row[prev], row[u]);
          } else {
            const float t = static_cast<float>(x - prev) / static_cast<float>(u - prev);
            row[x] = row[prev] + t * (row[u] - row[prev]);
          }
        }
      }
      prev = u;
    }
  }
}

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

}  // namespace

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

// ---------------------------------------------------------------------------------------------
// Salient points.

Status matchSupportValueSalient(const ImageU8& left,
                                const ImageU8& right,
                                const std::vector<Corner>& corners,
                                const SupportValueOptions& options,
                                StereoHypotheses* out) {
  if (out == nullptr) return Status::error("support value: out is null");
  if (Status s = checkInputs(left, right, options); !s) return s;

  const Geometry g = makeGeometry(left.width, left.height, options);
  const WeightPlanes planes = makePlanes(options);
  const Kernels kernels = kernelsFor(options.simd);
  std::vector<uint8_t> left_pad, right_pad;
  padImage(left, g, &left_pad);
  padImage(right, g, &right_pad);

  const size_t words = static_cast<size_t>(g.words);
  std::vector<uint64_t> anchor(words);
  std::vector<uint64_t> others(static_cast<size_t>(g.nd) * words);
  std::vector<int32_t> sv(static_cast<size_t>(g.nd));
  std::vector<int32_t> back(static_cast<size_t>(g.nd));
  const float min_corr = static_cast<float>(options.min_correlation);

  // Structures of the windows of `pad` on row v at columns x0 + sign * k, k in [0, count); their
  // sums slide along the row over column sums of the window rows (no integral image: a call
  // touches only the corners' rows).
  std::vector<int32_t> column_sums;
  auto structures_along = [&](const std::vector<uint8_t>& pad, int x0, int sign, int count, int v) {
    if (count <= 0) return;
    const int first = sign > 0 ? x0 : x0 - count + 1;  // leftmost window
    const int span = count + g.win - 1;
    column_sums.assign(static_cast<size_t>(span), 0);
    for (int i = 0; i < g.win; ++i) {
      const uint8_t* row = pad.data() + static_cast<size_t>(v + i) * g.wp + first;
      for (int x = 0; x < span; ++x) column_sums[static_cast<size_t>(x)] += row[x];
    }
    int64_t sum = 0;
    for (int x = 0; x < g.win; ++x) sum += column_sums[static_cast<size_t>(x)];
    for (int j = 0; j < count; ++j) {  // window first + j
      if (j > 0) {
        sum += column_sums[static_cast<size_t>(j + g.win - 1)] -
               column_sums[static_cast<size_t>(j - 1)];
      }
      const int k = sign > 0 ? j : count - 1 - j;
      kernels.structure(
          pad.data(), g, first + j, v, sum, others.data() + static_cast<size_t>(k) * words);
    }
  };

  struct Scored {
    int d;
    float r;
  };
  out->clear();
  for (const Corner& c : corners) {
    const int u = c.u_px;
    const int v = c.v_px;
    if (u < 0 || u >= g.width || v < 0 || v >= g.height) continue;
    SalientPoint point;
    point.corner = c;
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    const uint32_t point_index = static_cast<uint32_t>(out->points.size());
    const int count = u < g.dmin ? 0 : std::min(g.nd, u - g.dmin + 1);
    const bool cut_short = count < g.nd;
    const WindowStats ls = directStats(left_pad, g, u, v);
    kernels.structure(left_pad.data(), g, u, v, ls.sum, anchor.data());
    // Right windows at u - dmin - k.
    structures_along(right_pad, u - g.dmin, -1, count, v);
    for (int k = 0; k < count; ++k) {
      sv[static_cast<size_t>(k)] = static_cast<int32_t>(
          planes.total -
          kernels.disagreement(anchor.data(), others.data() + k * words, g.words, planes));
    }
    int cand[kMaxCandidates];
    bool dropped = false;
    const int max_list = std::min(kMaxCandidates, options.max_hypotheses);
    const int n =
        selectCandidates(sv.data(), 1, count, options.hypothesis_margin, max_list, cand, &dropped);
    Scored scored[kMaxCandidates];
    int kept = 0;
    for (int q = 0; q < n; ++q) {
      const int d = g.dmin + cand[q];
      const float r = correlation(crossSum(left_pad.data(), right_pad.data(), g, u, u - d, v),
                                  ls,
                                  directStats(right_pad, g, u - d, v),
                                  g.n);
      if (r >= min_corr) scored[kept++] = {d, r};
    }
    std::stable_sort(
        scored, scored + kept, [](const Scored& a, const Scored& b) { return a.r > b.r; });
    for (int q = 0; q < kept; ++q) {
      DisparityHypothesis h;
      h.d_px = static_cast<float>(scored[q].d);
      h.cost = 1.0f - scored[q].r;
      h.point_index = point_index;
      h.rank = static_cast<uint8_t>(q);
      if (options.lr_tolerance_px >= 0) {
        // Right window at u_r matched back along the left row: left windows at u_r + dmin + k.
        const int u_r = u - scored[q].d;
        const WindowStats rs = directStats(right_pad, g, u_r, v);
        uint64_t right_anchor[kMaxWords];
        kernels.structure(right_pad.data(), g, u_r, v, rs.sum, right_anchor);
        const int back_count = std::min(g.nd, g.width - u_r - g.dmin);
        structures_along(left_pad, u_r + g.dmin, +1, back_count, v);
        for (int k = 0; k < back_count; ++k) {
          back[static_cast<size_t>(k)] = static_cast<int32_t>(
              planes.total -
              kernels.disagreement(right_anchor, others.data() + k * words, g.words, planes));
        }
        int back_cand[kMaxCandidates];
        bool back_dropped = false;
        const int nb = selectCandidates(back.data(),
                                        1,
                                        back_count,
                                        options.candidate_margin,
                                        options.max_candidates,
                                        back_cand,
                                        &back_dropped);
        float best = kNoCorrelation;
        int best_d = kNoMatch;
        for (int b = 0; b < nb; ++b) {
          const int d = g.dmin + back_cand[b];
          const float r =
              correlation(crossSum(left_pad.data(), right_pad.data(), g, u_r + d, u_r, v),
                          directStats(left_pad, g, u_r + d, v),
                          rs,
                          g.n);
          if (r > best) {
            best = r;
            best_d = d;
          }
        }
        h.lr_consistent = best_d >= 0 && best >= min_corr &&
                          std::abs(best_d - scored[q].d) <= options.lr_tolerance_px;
      }
      out->hypotheses.push_back(h);
    }
    point.num_hypotheses = static_cast<uint32_t>(kept);
    point.complete = !dropped && !cut_short;
    out->points.push_back(point);
  }
  return Status::ok();
}

}  // namespace twocam::frontend
