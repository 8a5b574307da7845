#pragma once
/// The support-value matcher's internals (support_value.h), shared by its files:
/// support_value_kernels.cpp (geometry, weights, padded images, window sums and the hot loops
/// with their run-time SIMD choice), support_value_constraints.cpp (row constraints and
/// post-processing), support_value.cpp (options and the dense matcher) and
/// support_value_salient.cpp (salient points); candidate selection is inline here. Exposed for
/// those files and their tests only.

#include <algorithm>
#include <cmath>
#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "frontend/simd.h"
#include "frontend/support_value.h"

namespace twocam::frontend::internal::support {

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
// Geometry and weights (support_value_kernels.cpp).

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

Geometry makeGeometry(int width, int height, const SupportValueOptions& o);

// The weighting matrix as bit planes over the packed binary structure: bit k of a weight sets the
// structure's bit in plane k. equal: every weight 1 (one plane covering every bit, skipped).
struct WeightPlanes {
  bool equal = true;
  int count = 0;
  int64_t total = 0;  // sum of the weights (support value of identical structures)
  uint64_t mask[kMaxPlanes][kMaxWords] = {};
};

WeightPlanes makePlanes(const SupportValueOptions& o);

// ---------------------------------------------------------------------------------------------
// Padded images and window sums (support_value_kernels.cpp; the small ones inline).

// Copies `image` into `pad` (wp x hp plus slack) repeating the edge pixels half px outwards.
void padImage(const ImageU8& image, const Geometry& g, std::vector<uint8_t>* pad);

// Integral images of the padded image and of its squares, (wp + 1) x (hp + 1).
void integrate(const std::vector<uint8_t>& pad,
               const Geometry& g,
               std::vector<int64_t>* sum,
               std::vector<int64_t>* sq);

struct WindowStats {
  int64_t sum = 0;
  int64_t sq = 0;
};

// Zero-mean normalised cross-correlation from the window sums; kNoCorrelation when a window has
// no variance.
inline float correlation(int64_t cross, const WindowStats& l, const WindowStats& r, int n) {
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
                std::vector<PixelStats>* out);

// correlation() from PixelStats (float; the same value up to rounding).
inline float fastCorrelation(int32_t cross, const PixelStats& l, const PixelStats& r, int n) {
  if (l.inv_std == 0.0f || r.inv_std == 0.0f) return kNoCorrelation;
  const int64_t num = static_cast<int64_t>(n) * cross - static_cast<int64_t>(l.sum) * r.sum;
  return static_cast<float>(num) * l.inv_std * r.inv_std;
}

// Window sums of the padded image for image pixel (u, v), computed directly (salient).
inline WindowStats directStats(const std::vector<uint8_t>& pad, const Geometry& g, int u, int v) {
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
inline int64_t crossSum(
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
// Hot loops (support_value_kernels.cpp): the baseline or the AVX2 + POPCNT copy, chosen at run
// time by kernelsFor.

struct Kernels {
  void (*structures)(const uint8_t*, const std::vector<int64_t>&, const Geometry&, uint64_t*);
  void (*support)(const uint64_t*, const uint64_t*, const Geometry&, const WeightPlanes&, int32_t*);
  void (*cross)(const uint8_t*, const uint8_t*, const Geometry&, int, int32_t*, int32_t*);
  int64_t (*disagreement)(const uint64_t*, const uint64_t*, int, const WeightPlanes&);
  void (*structure)(const uint8_t*, const Geometry&, int, int, int64_t, uint64_t*);
};

Kernels kernelsFor(Simd simd);

// ---------------------------------------------------------------------------------------------
// Candidates (here: the dense matcher's inner loop), row constraints and post-processing
// (support_value_constraints.cpp).

// The candidates of one pixel's support-value curve sv[k * stride], k in [0, count): local
// maxima (a plateau counts once, at its last element) within margin of the best, at most
// max_count, best support values first (ties: smaller k). Returns their number; *dropped is set
// when a local maximum within the margin did not fit.
// Inline: it runs twice per pixel in the dense matcher's decision loop.
inline int selectCandidates(const int32_t* sv,
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

// Uniqueness and ordering along one row: the kept matches' partner positions pos(x) = x + sign
// * d[x] strictly increase with x (sign -1 for the left view, +1 for the right view). A conflict
// voids the match with the lower score (ties: the earlier one stays).
void orderRow(int width, int sign, int16_t* d, const float* score, std::vector<int>* stack);

// Continuity: an estimate stays when at least min_neighbours other estimates of the window lie
// within 1 px of it.
void continuityFilter(const std::vector<int16_t>& in,
                      int width,
                      int height,
                      int window,
                      int min_neighbours,
                      std::vector<int16_t>* out);

// Depth-edge erosion: wherever two estimates at most 3 px apart along a row or a column differ by
// more than 1 px, the `width` pixels on the nearer side (larger disparity) that start at the
// nearer estimate and run away from the jump are voided. A centred window that straddles a
// depth edge is dominated by the nearer surface's texture, so the nearer surface's estimates
// spread over the farther one by up to half a window (foreground fattening); the pixels voided
// here are filled from the farther side afterwards. Jumps are found in `in`, voids written to out.
void erodeDepthEdges(
    const std::vector<int16_t>& in, int width, int height, int erosion, std::vector<int16_t>* out);

// Fills each row's holes from the nearest estimates either side (linear or farther); at a row's
// ends the nearest estimate; rows without any estimate stay empty.
void fillRows(SupportFill fill, int max_width, int width, int height, ImageF32* map);

/// The input checks of both matchers (support_value.cpp): images of one size that match their
/// buffers, valid options, max_disparity_px below the image width.
Status checkInputs(const ImageU8& left, const ImageU8& right, const SupportValueOptions& o);

}  // namespace twocam::frontend::internal::support
