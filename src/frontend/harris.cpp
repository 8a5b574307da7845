#include "frontend/harris.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>

#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(__i386__))
#define TWOCAM_HARRIS_HAVE_AVX2 1
#define TWOCAM_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define TWOCAM_HARRIS_HAVE_AVX2 0
#define TWOCAM_ALWAYS_INLINE inline
#endif

namespace twocam::frontend {
namespace {

/// Reach of Sobel (1) plus binomial (2): the response exists from this many pixels off an edge.
constexpr int kResponseMargin = 3;
/// Response margin plus the 3x3 suppression.
constexpr int kMinBorderPx = kResponseMargin + 1;
/// Largest accepted bucketing grid side [cells].
constexpr int kMaxGridSide = 4096;
/// Largest accepted border [px]: keeps 2 border_px + 1 (the smallest image side) and the row
/// arithmetic far inside int; an image more than 65536 px on a side is beyond any camera here.
constexpr int kMaxBorderPx = 1 << 15;
/// Largest corner budget (target_count, max_corners, max_per_cell): 2^24 is more than one
/// corner per pixel of a 4096 x 4096 image, and keeps counts exact in float and int arithmetic.
constexpr int kMaxCornerBudget = 1 << 24;
/// The integer tensor entries carry the unnormalised binomial weights (16 x 16 = 256); det and
/// trace^2 carry 256^2, divided out here (a power of two, so exact).
constexpr float kResponseScale = 1.0f / 65536.0f;

template <typename T>
std::string str(const T& value) {
  std::ostringstream os;
  os << value;
  return os.str();
}

Status checkImage(const ImageU8& image, int min_side) {
  if (image.width <= 0 || image.height <= 0 || image.data.empty()) {
    return Status::error("image is empty (" + str(image.width) + "x" + str(image.height) + ")");
  }
  if (image.data.size() != static_cast<size_t>(image.width) * static_cast<size_t>(image.height)) {
    return Status::error("image data holds " + str(image.data.size()) + " pixels; " +
                         str(image.width) + "x" + str(image.height) + " needs " +
                         str(static_cast<size_t>(image.width) * image.height));
  }
  if (image.width < min_side || image.height < min_side) {
    return Status::error("image is " + str(image.width) + "x" + str(image.height) +
                         "; each side must be at least " + str(min_side) +
                         " px (kernels plus border)");
  }
  if (static_cast<uint64_t>(image.width) * static_cast<uint64_t>(image.height) >
      std::numeric_limits<uint32_t>::max()) {
    return Status::error("image has more than 2^32 pixels");
  }
  return Status::ok();
}

// Candidate keys: ascending key order = descending response, then ascending raster index
// (v, then u). The float is mapped to an unsigned integer with the same order.
TWOCAM_ALWAYS_INLINE uint64_t makeKey(float response, uint32_t raster_index) {
  uint32_t bits;
  std::memcpy(&bits, &response, sizeof bits);
  const uint32_t ordered = (bits & 0x80000000u) != 0 ? ~bits : (bits | 0x80000000u);
  return (static_cast<uint64_t>(~ordered) << 32) | raster_index;
}

inline float keyResponse(uint64_t key) {
  const uint32_t ordered = ~static_cast<uint32_t>(key >> 32);
  const uint32_t bits = (ordered & 0x80000000u) != 0 ? (ordered & 0x7fffffffu) : ~ordered;
  float response;
  std::memcpy(&response, &bits, sizeof response);
  return response;
}

// The shared 3x3 suppression rule (see harris.h): strict against the 4 raster-order
// predecessors, non-strict against the 4 successors.
TWOCAM_ALWAYS_INLINE bool isLocalMax(const float* up, const float* mid, const float* down, int x) {
  const float r = mid[x];
  return r > up[x - 1] && r > up[x] && r > up[x + 1] && r > mid[x - 1] && r >= mid[x + 1] &&
         r >= down[x - 1] && r >= down[x] && r >= down[x + 1];
}

// Appends the corners of row y (columns [x0, x1]) to `keys`. The rule is evaluated for every
// pixel without branches (so it vectorises into `flags`), then the rare hits are read out eight
// flags at a time: a textured image has most pixels above a low threshold, and a branchy test
// per pixel would mispredict on each of them.
TWOCAM_ALWAYS_INLINE void suppressRow(const float* __restrict up,
                                      const float* __restrict mid,
                                      const float* __restrict down,
                                      int x0,
                                      int x1,
                                      float threshold,
                                      uint32_t row_base,
                                      uint8_t* __restrict flags,
                                      std::vector<uint64_t>* keys) {
  for (int x = x0; x <= x1; ++x) {
    const float r = mid[x];
    flags[x] = static_cast<uint8_t>((r > threshold) & (r > up[x - 1]) & (r > up[x]) &
                                    (r > up[x + 1]) & (r > mid[x - 1]) & (r >= mid[x + 1]) &
                                    (r >= down[x - 1]) & (r >= down[x]) & (r >= down[x + 1]));
  }
  int x = x0;
  for (; x + 8 <= x1 + 1; x += 8) {
    uint64_t word;
    std::memcpy(&word, flags + x, sizeof word);
    if (word == 0) continue;
    for (int j = 0; j < 8; ++j) {
      if (flags[x + j] != 0) {
        keys->push_back(makeKey(mid[x + j], row_base + static_cast<uint32_t>(x + j)));
      }
    }
  }
  for (; x <= x1; ++x) {
    if (flags[x] != 0) keys->push_back(makeKey(mid[x], row_base + static_cast<uint32_t>(x)));
  }
}

// Sobel gradients of image row v (rows r0, r1, r2 = v-1, v, v+1) and their products, for
// columns [x0, x1]. Integer-exact: |g| <= 1020, products <= 1040400.
TWOCAM_ALWAYS_INLINE void sobelProducts(const uint8_t* __restrict r0,
                                        const uint8_t* __restrict r1,
                                        const uint8_t* __restrict r2,
                                        int x0,
                                        int x1,
                                        int32_t* __restrict guu,
                                        int32_t* __restrict gvv,
                                        int32_t* __restrict guv) {
  for (int x = x0; x <= x1; ++x) {
    const int16_t gu = static_cast<int16_t>((r0[x + 1] - r0[x - 1]) + 2 * (r1[x + 1] - r1[x - 1]) +
                                            (r2[x + 1] - r2[x - 1]));
    const int16_t gv = static_cast<int16_t>((r2[x - 1] + 2 * r2[x] + r2[x + 1]) -
                                            (r0[x - 1] + 2 * r0[x] + r0[x + 1]));
    guu[x] = static_cast<int32_t>(gu) * gu;
    gvv[x] = static_cast<int32_t>(gv) * gv;
    guv[x] = static_cast<int32_t>(gu) * gv;
  }
}

// Vertical binomial 1 4 6 4 1 over five product rows. Sums <= 16 * 1040400.
TWOCAM_ALWAYS_INLINE void verticalBinomial(const int32_t* __restrict p0,
                                           const int32_t* __restrict p1,
                                           const int32_t* __restrict p2,
                                           const int32_t* __restrict p3,
                                           const int32_t* __restrict p4,
                                           int x0,
                                           int x1,
                                           int32_t* __restrict out) {
  for (int x = x0; x <= x1; ++x) {
    out[x] = (p0[x] + p4[x]) + 4 * (p1[x] + p3[x]) + 6 * p2[x];
  }
}

// Horizontal binomial of the three tensor channels and the Harris response. Tensor entries
// <= 256 * 1040400 < 2^31.
TWOCAM_ALWAYS_INLINE void horizontalResponse(const int32_t* __restrict vuu,
                                             const int32_t* __restrict vvv,
                                             const int32_t* __restrict vuv,
                                             int x0,
                                             int x1,
                                             float k,
                                             float* __restrict out) {
  for (int x = x0; x <= x1; ++x) {
    const int32_t a = (vuu[x - 2] + vuu[x + 2]) + 4 * (vuu[x - 1] + vuu[x + 1]) + 6 * vuu[x];
    const int32_t b = (vvv[x - 2] + vvv[x + 2]) + 4 * (vvv[x - 1] + vvv[x + 1]) + 6 * vvv[x];
    const int32_t c = (vuv[x - 2] + vuv[x + 2]) + 4 * (vuv[x - 1] + vuv[x + 1]) + 6 * vuv[x];
    const float fa = static_cast<float>(a);
    const float fb = static_cast<float>(b);
    const float fc = static_cast<float>(c);
    const float det = fa * fb - fc * fc;
    const float trace = fa + fb;
    out[x] = (det - k * (trace * trace)) * kResponseScale;
  }
}

/// One run of the fused pipeline over response rows [ry0, ry1] and columns [cx0, cx1]
/// (both at least kResponseMargin from the edges).
struct PipelineJob {
  const ImageU8* image = nullptr;
  int ry0 = 0, ry1 = 0, cx0 = 0, cx1 = 0;
  float k = 0.04f;
  /// Response mode: write every response row here (rows ry0..ry1) and skip suppression.
  ImageF32* response = nullptr;
  /// Detection mode: suppression on rows ry0+1..ry1-1, columns cx0+1..cx1-1.
  float threshold = 0.0f;
  internal::HarrisWorkspace* workspace = nullptr;
};

TWOCAM_ALWAYS_INLINE void runPipeline(const PipelineJob& job) {
  const ImageU8& image = *job.image;
  const int width = image.width;
  const size_t stride = static_cast<size_t>(width);
  internal::HarrisWorkspace& ws = *job.workspace;
  int32_t* const products = ws.products.data();  // slot s, channel c at (3 s + c) * stride
  int32_t* const vuu = ws.vertical.data();
  int32_t* const vvv = vuu + stride;
  int32_t* const vuv = vvv + stride;
  auto product_row = [&](int p, int channel) {
    return products + (static_cast<size_t>(p % 5) * 3 + channel) * stride;
  };
  auto response_row = [&](int r) -> float* {
    if (job.response != nullptr) return job.response->row(r);
    return ws.responses.data() + static_cast<size_t>(r % 3) * stride;
  };
  const int px0 = job.cx0 - 2;
  const int px1 = job.cx1 + 2;
  for (int p = job.ry0 - 2; p <= job.ry1 + 2; ++p) {
    sobelProducts(image.row(p - 1),
                  image.row(p),
                  image.row(p + 1),
                  px0,
                  px1,
                  product_row(p, 0),
                  product_row(p, 1),
                  product_row(p, 2));
    const int r = p - 2;
    if (r < job.ry0) continue;
    for (int c = 0; c < 3; ++c) {
      verticalBinomial(product_row(r - 2, c),
                       product_row(r - 1, c),
                       product_row(r, c),
                       product_row(r + 1, c),
                       product_row(r + 2, c),
                       px0,
                       px1,
                       vuu + c * stride);
    }
    horizontalResponse(vuu, vvv, vuv, job.cx0, job.cx1, job.k, response_row(r));
    if (job.response != nullptr || r < job.ry0 + 2) continue;
    const int y = r - 1;
    suppressRow(response_row(y - 1),
                response_row(y),
                response_row(y + 1),
                job.cx0 + 1,
                job.cx1 - 1,
                job.threshold,
                static_cast<uint32_t>(y) * static_cast<uint32_t>(width),
                ws.flags.data(),
                &ws.keys);
  }
}

void runPipelinePortable(const PipelineJob& job) { runPipeline(job); }

#if TWOCAM_HARRIS_HAVE_AVX2
__attribute__((target("avx2"))) void runPipelineAvx2(const PipelineJob& job) { runPipeline(job); }
#endif

void dispatchPipeline(const PipelineJob& job, Simd simd) {
#if TWOCAM_HARRIS_HAVE_AVX2
  if (resolveSimd(simd) == Simd::kAvx2 && internal::harrisAvx2Available()) {
    runPipelineAvx2(job);
    return;
  }
#else
  (void)simd;
#endif
  runPipelinePortable(job);
}

void prepareWorkspace(int width, internal::HarrisWorkspace* ws) {
  const size_t stride = static_cast<size_t>(width);
  if (ws->products.size() < 15 * stride) ws->products.resize(15 * stride);
  if (ws->vertical.size() < 3 * stride) ws->vertical.resize(3 * stride);
  if (ws->responses.size() < 3 * stride) ws->responses.resize(3 * stride);
  if (ws->flags.size() < stride) ws->flags.resize(stride);
  ws->keys.clear();
}

// Sorts and caps the candidate keys (see selectCornersFromResponse) and writes the corners.
// Returns the response of the options.target_count-th strongest candidate, or NaN when there are
// fewer candidates (the adaptive threshold's estimate of where the target count lies).
float selectFromKeys(int width,
                     int height,
                     const HarrisOptions& options,
                     internal::HarrisWorkspace* ws,
                     std::vector<Corner>* corners) {
  std::vector<uint64_t>& keys = ws->keys;
  const size_t max_corners = static_cast<size_t>(options.max_corners);
  const size_t rank = static_cast<size_t>(options.target_count);
  float rank_response = std::numeric_limits<float>::quiet_NaN();
  corners->clear();
  auto emit = [&](uint64_t key) {
    const uint32_t index = static_cast<uint32_t>(key);
    Corner c;
    c.u_px = static_cast<int>(index % static_cast<uint32_t>(width));
    c.v_px = static_cast<int>(index / static_cast<uint32_t>(width));
    c.response = keyResponse(key);
    corners->push_back(c);
  };
  if (!options.bucketing) {
    const size_t num_candidates = keys.size();
    if (num_candidates >= rank && rank > max_corners) {
      std::nth_element(keys.begin(), keys.begin() + static_cast<ptrdiff_t>(rank - 1), keys.end());
      rank_response = keyResponse(keys[rank - 1]);
    }
    if (num_candidates > max_corners) {
      // Afterwards keys[0, max_corners) hold the strongest candidates, in some order.
      std::nth_element(
          keys.begin(), keys.begin() + static_cast<ptrdiff_t>(max_corners), keys.end());
      keys.resize(max_corners);
    }
    std::sort(keys.begin(), keys.end());
    if (num_candidates >= rank && rank <= max_corners) rank_response = keyResponse(keys[rank - 1]);
    for (const uint64_t key : keys) emit(key);
    return rank_response;
  }
  std::sort(keys.begin(), keys.end());
  if (keys.size() >= rank) rank_response = keyResponse(keys[rank - 1]);
  const size_t cells = static_cast<size_t>(options.grid_cols) * options.grid_rows;
  ws->cell_counts.assign(cells, 0);
  for (const uint64_t key : keys) {
    if (corners->size() >= max_corners) break;
    const uint32_t index = static_cast<uint32_t>(key);
    const int64_t u = index % static_cast<uint32_t>(width);
    const int64_t v = index / static_cast<uint32_t>(width);
    const size_t cell = static_cast<size_t>((v * options.grid_rows / height) * options.grid_cols +
                                            u * options.grid_cols / width);
    if (ws->cell_counts[cell] >= options.max_per_cell) continue;
    ++ws->cell_counts[cell];
    emit(key);
  }
  return rank_response;
}

Status checkThreshold(float threshold) {
  if (!std::isfinite(threshold) || threshold < 0.0f) {
    return Status::error("threshold = " + str(threshold) + "; must be finite and >= 0");
  }
  return Status::ok();
}

}  // namespace

Status HarrisOptions::validate() const {
  if (!(k > 0.0f && k < 0.25f)) return Status::error("k = " + str(k) + "; must be in (0, 0.25)");
  if (border_px < kMinBorderPx || border_px > kMaxBorderPx) {
    return Status::error("border_px = " + str(border_px) + "; must be in [" + str(kMinBorderPx) +
                         ", " + str(kMaxBorderPx) +
                         "] (at least the reach of the Sobel, binomial and suppression kernels)");
  }
  if (target_count < 1 || target_count > kMaxCornerBudget) {
    return Status::error("target_count = " + str(target_count) + "; must be in [1, " +
                         str(kMaxCornerBudget) + "]");
  }
  if (!(std::isfinite(threshold_min) && threshold_min > 0.0f)) {
    return Status::error("threshold_min = " + str(threshold_min) + "; must be finite and > 0");
  }
  if (!(std::isfinite(threshold_max) && threshold_max >= threshold_min)) {
    return Status::error("threshold_max = " + str(threshold_max) +
                         "; must be finite and >= threshold_min = " + str(threshold_min));
  }
  if (!(initial_threshold >= threshold_min && initial_threshold <= threshold_max)) {
    return Status::error("initial_threshold = " + str(initial_threshold) + "; must be in [" +
                         str(threshold_min) + ", " + str(threshold_max) + "]");
  }
  if (!(threshold_adapt_rate >= 0.0f && threshold_adapt_rate <= 1.0f)) {
    return Status::error("threshold_adapt_rate = " + str(threshold_adapt_rate) +
                         "; must be in [0, 1]");
  }
  if (max_corners < 1 || max_corners > kMaxCornerBudget) {
    return Status::error("max_corners = " + str(max_corners) + "; must be in [1, " +
                         str(kMaxCornerBudget) + "]");
  }
  // The upper bound keeps the per-cell counters small; finer grids than that are finer than pixels.
  if (grid_cols < 1 || grid_cols > kMaxGridSide) {
    return Status::error("grid_cols = " + str(grid_cols) + "; must be in [1, " + str(kMaxGridSide) +
                         "]");
  }
  if (grid_rows < 1 || grid_rows > kMaxGridSide) {
    return Status::error("grid_rows = " + str(grid_rows) + "; must be in [1, " + str(kMaxGridSide) +
                         "]");
  }
  if (max_per_cell < 1 || max_per_cell > kMaxCornerBudget) {
    return Status::error("max_per_cell = " + str(max_per_cell) + "; must be in [1, " +
                         str(kMaxCornerBudget) + "]");
  }
  if (Status s = checkSimd("simd", simd); !s) return s;
  return Status::ok();
}

int minHarrisImageSide(const HarrisOptions& options) { return 2 * options.border_px + 1; }

Status harrisResponse(const ImageU8& image, const HarrisOptions& options, ImageF32* response) {
  if (response == nullptr) return Status::error("harrisResponse: response is null");
  if (Status s = options.validate(); !s) return s;
  if (Status s = checkImage(image, 2 * kResponseMargin + 1); !s) return s;
  if (response->width != image.width || response->height != image.height ||
      response->data.size() != image.data.size()) {
    *response = ImageF32(image.width, image.height);
  } else {
    std::fill(response->data.begin(), response->data.end(), 0.0f);
  }
  internal::HarrisWorkspace ws;
  prepareWorkspace(image.width, &ws);
  PipelineJob job;
  job.image = &image;
  job.ry0 = kResponseMargin;
  job.ry1 = image.height - 1 - kResponseMargin;
  job.cx0 = kResponseMargin;
  job.cx1 = image.width - 1 - kResponseMargin;
  job.k = options.k;
  job.response = response;
  job.workspace = &ws;
  dispatchPipeline(job, options.simd);
  return Status::ok();
}

Status selectCornersFromResponse(const ImageF32& response,
                                 const HarrisOptions& options,
                                 float threshold,
                                 std::vector<Corner>* corners,
                                 int* num_candidates) {
  if (corners == nullptr) return Status::error("selectCornersFromResponse: corners is null");
  corners->clear();
  if (Status s = options.validate(); !s) return s;
  if (!std::isfinite(threshold)) {
    return Status::error("threshold = " + str(threshold) + "; must be finite");
  }
  const int min_side = minHarrisImageSide(options);
  if (response.width < min_side || response.height < min_side ||
      response.data.size() != static_cast<size_t>(response.width) * response.height) {
    return Status::error("response image is " + str(response.width) + "x" + str(response.height) +
                         " with " + str(response.data.size()) +
                         " values; needs consistent sides of at least " + str(min_side) + " px");
  }
  internal::HarrisWorkspace ws;
  const int b = options.border_px;
  for (int y = b; y <= response.height - 1 - b; ++y) {
    const float* up = response.row(y - 1);
    const float* mid = response.row(y);
    const float* down = response.row(y + 1);
    const uint32_t row_base = static_cast<uint32_t>(y) * static_cast<uint32_t>(response.width);
    for (int x = b; x <= response.width - 1 - b; ++x) {
      if (mid[x] > threshold && isLocalMax(up, mid, down, x)) {
        ws.keys.push_back(makeKey(mid[x], row_base + static_cast<uint32_t>(x)));
      }
    }
  }
  if (num_candidates != nullptr) *num_candidates = static_cast<int>(ws.keys.size());
  selectFromKeys(response.width, response.height, options, &ws, corners);
  return Status::ok();
}

namespace internal {

bool harrisAvx2Available() {
#if TWOCAM_HARRIS_HAVE_AVX2
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

Status detectHarrisCorners(const ImageU8& image,
                           const HarrisOptions& options,
                           float threshold,
                           HarrisWorkspace* workspace,
                           std::vector<Corner>* corners,
                           HarrisFrameStats* stats) {
  if (corners == nullptr) return Status::error("detectHarrisCorners: corners is null");
  corners->clear();
  if (workspace == nullptr) return Status::error("detectHarrisCorners: workspace is null");
  if (Status s = options.validate(); !s) return s;
  if (Status s = checkThreshold(threshold); !s) return s;
  if (Status s = checkImage(image, minHarrisImageSide(options)); !s) return s;
  prepareWorkspace(image.width, workspace);
  const int b = options.border_px;
  PipelineJob job;
  job.image = &image;
  // Suppression on [b, side - 1 - b] needs responses one pixel further out.
  job.ry0 = b - 1;
  job.ry1 = image.height - b;
  job.cx0 = b - 1;
  job.cx1 = image.width - b;
  job.k = options.k;
  job.threshold = threshold;
  job.workspace = workspace;
  dispatchPipeline(job, options.simd);
  const int num_candidates = static_cast<int>(workspace->keys.size());
  const float rank_response =
      selectFromKeys(image.width, image.height, options, workspace, corners);
  if (stats != nullptr) {
    stats->num_candidates = num_candidates;
    stats->target_rank_response = rank_response;
  }
  return Status::ok();
}

}  // namespace internal

Status detectHarrisCorners(const ImageU8& image,
                           const HarrisOptions& options,
                           float threshold,
                           std::vector<Corner>* corners) {
  internal::HarrisWorkspace workspace;
  return internal::detectHarrisCorners(image, options, threshold, &workspace, corners, nullptr);
}

HarrisDetector::HarrisDetector(HarrisOptions options)
    : options_(options), threshold_(options.initial_threshold) {}

void HarrisDetector::reset() {
  threshold_ = options_.initial_threshold;
  last_candidates_ = 0;
}

Status HarrisDetector::detect(const ImageU8& image, std::vector<Corner>* corners) {
  internal::HarrisFrameStats stats;
  if (Status s =
          internal::detectHarrisCorners(image, options_, threshold_, &workspace_, corners, &stats);
      !s) {
    return s;
  }
  last_candidates_ = stats.num_candidates;
  const double t = static_cast<double>(threshold_);
  double estimate;
  if (stats.num_candidates >= options_.target_count) {
    // Exact for this frame: just below the target_count-th strongest response, so that
    // "R > threshold" keeps exactly target_count of this frame's candidates.
    estimate = static_cast<double>(std::nextafter(stats.target_rank_response, 0.0f));
  } else {
    // Too few candidates to read the answer off this frame: step down as if count ~ t^-0.5
    // (the flattest dependence measured on real images is about t^-0.3, the steepest t^-2), which
    // usually overshoots to enough candidates for the exact estimate on the next frame.
    const double ratio = static_cast<double>(std::max(stats.num_candidates, 1)) /
                         static_cast<double>(options_.target_count);
    estimate = t * ratio * ratio;
  }
  const double rate = static_cast<double>(options_.threshold_adapt_rate);
  const double next = std::exp((1.0 - rate) * std::log(t) + rate * std::log(estimate));
  threshold_ = static_cast<float>(std::clamp(next,
                                             static_cast<double>(options_.threshold_min),
                                             static_cast<double>(options_.threshold_max)));
  return Status::ok();
}

}  // namespace twocam::frontend
