#include "frontend/dense_sad.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <sstream>

// Hot loops are plain loops that GCC auto-vectorises; on x86-64 matchRow is also compiled for
// AVX2 (a target("avx2") copy of the same always-inline body), chosen at run time by
// DenseSadOptions::simd (frontend/simd.h); the baseline copy stays SSE2.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define TWOCAM_DENSE_HAVE_AVX2 1
#define TWOCAM_DENSE_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define TWOCAM_DENSE_HAVE_AVX2 0
#define TWOCAM_DENSE_ALWAYS_INLINE inline
#endif

namespace twocam::frontend {

namespace {

// Disparities inside the post-processing: int16 with 4 fractional bits, negative = no estimate.
constexpr int kFixedShift = 4;
constexpr int kFixedOne = 1 << kFixedShift;
constexpr int16_t kNoFixed = -1;

// A disparity map in fixed point (row-major, tightly packed).
struct FixedMap {
  int width = 0;
  int height = 0;
  int16_t* data = nullptr;
  [[nodiscard]] int16_t* row(int v) const { return data + static_cast<size_t>(v) * width; }
};

int16_t toFixed(float d_px) {
  if (!(d_px >= 0.0f)) return kNoFixed;  // also NaN
  return static_cast<int16_t>(std::lround(d_px * kFixedOne));
}

float fromFixed(int16_t d) {
  return d < 0 ? kNoDisparity : static_cast<float>(d) * (1.0f / kFixedOne);
}

Status floatToFixed(const ImageF32& image, std::vector<int16_t>* fixed) {
  fixed->resize(image.data.size());
  for (size_t i = 0; i < image.data.size(); ++i) {
    const float d = image.data[i];
    if (d > kMaxDisparityValuePx) {
      std::ostringstream msg;
      msg << "disparity " << d << " px at pixel (" << i % image.width << ", " << i / image.width
          << ") exceeds kMaxDisparityValuePx = " << kMaxDisparityValuePx;
      return Status::error(msg.str());
    }
    (*fixed)[i] = toFixed(d);
  }
  return Status::ok();
}

void fixedToFloat(const std::vector<int16_t>& fixed, ImageF32* image) {
  for (size_t i = 0; i < fixed.size(); ++i) image->data[i] = fromFixed(fixed[i]);
}

Status checkMap(const ImageF32* disparity, const char* name) {
  if (disparity == nullptr) return Status::error(std::string(name) + " is null");
  if (disparity->empty() || disparity->width <= 0 || disparity->height <= 0) {
    return Status::error(std::string(name) + " is empty");
  }
  if (disparity->data.size() != static_cast<size_t>(disparity->width) * disparity->height) {
    return Status::error(std::string(name) + " has a pixel count that does not match its size");
  }
  return Status::ok();
}

// ---------------------------------------------------------------------------------------------
// Matching.

struct RowSetup {
  int width = 0;
  int radius = 0;
  int min_d = 0;
  int num_d = 0;
  bool subpixel = false;
  int uniqueness_percent = 0;
};

// |a - b| in a 16-bit lane: GCC vectorises this as widen, subtract, abs (vpabsw on AVX2), which
// is shorter than its code for an 8-bit absolute difference.
inline uint16_t absDiff(uint8_t a, uint8_t b) {
  const auto diff = static_cast<int16_t>(a - b);
  return static_cast<uint16_t>(diff < 0 ? -diff : diff);
}

// Matches one row. `left` holds the row padded by `radius` repeated edge pixels on each side
// (left[i + radius] = L(clamp(i))); `right_rev` holds the right row reversed and padded so
// that right_rev[c - i + d] = R(clamp(i - d)) with c = width - 1 + radius. `sums` (num_d
// entries) is scratch. For the right pixel u_r, `right_cost` and `right_index` (width entries
// each, at index width - 1 - u_r) receive the smallest cost and its disparity index, the
// smaller index on ties (right_cost kMaxCost and right_index kNoIndex when none).
//
// Every loop over j runs over 16-bit lanes without branches so that GCC vectorises it; the
// costs fit in int16 because W * 255 <= 21 * 255 < 2^15.
constexpr uint16_t kNoIndex = 0xFFFF;
// Above every window cost (W * 255 <= 5355): the "none yet" cost and a masked lane.
constexpr int16_t kMaxCost = 0x7FFF;

// 0, 1, ..., 255: disparity indices as uint16 lanes loaded from memory, so that the index
// arithmetic below stays in 16-bit lanes instead of widening a 32-bit loop counter.
struct IndexTable {
  alignas(32) uint16_t values[256];
  alignas(32) uint16_t reversed[256];  // 255 - i
  constexpr IndexTable() : values(), reversed() {
    for (int i = 0; i < 256; ++i) {
      values[i] = static_cast<uint16_t>(i);
      reversed[i] = static_cast<uint16_t>(255 - i);
    }
  }
};
constexpr IndexTable kIndex;

TWOCAM_DENSE_ALWAYS_INLINE void matchRowBody(const uint8_t* __restrict left,
                                             const uint8_t* __restrict right_rev,
                                             const RowSetup& setup,
                                             uint16_t* __restrict sums,
                                             int16_t* __restrict right_cost,
                                             uint16_t* __restrict right_index,
                                             int16_t* __restrict out) {
  const int width = setup.width;
  const int r = setup.radius;
  const int num_d = setup.num_d;
  const int min_d = setup.min_d;
  const int c = width - 1 + r;
  std::fill(right_cost, right_cost + width, kMaxCost);
  std::fill(right_index, right_index + width, kNoIndex);

  // Window sums at u = 0: i runs over -r..r.
  std::fill(sums, sums + num_d, static_cast<uint16_t>(0));
  for (int i = -r; i <= r; ++i) {
    const uint8_t a = left[i + r];
    const uint8_t* q = right_rev + (c - i + min_d);
    for (int j = 0; j < num_d; ++j) sums[j] = static_cast<uint16_t>(sums[j] + absDiff(a, q[j]));
  }

  for (int u = 0; u < width; ++u) {
    const int num_valid = std::min(num_d, u - min_d + 1);
    // Slide the window one pixel right: add column u + r, drop column u - r - 1. The uint16
    // arithmetic wraps in between but the result is the exact window sum.
    const int i_in = u + r;
    const int i_out = u - r - 1;
    const uint8_t a_in = left[i_in + r];
    const uint8_t a_out = left[std::max(i_out, -r) + r];
    const uint8_t* q_in = right_rev + (c - i_in + min_d);
    const uint8_t* q_out = right_rev + (c - std::max(i_out, -r) + min_d);
    // Running winners of the right pixels u_r = u - min_d - j, stored reversed so that the
    // loops run forward over j. Strict < keeps the first, i.e. smallest, disparity on ties,
    // as u (and so d) grows. Minima and compares are signed (costs < 2^15): SSE2 has signed
    // 16-bit min and compare only. Blends are written as masks: GCC does not vectorise a ?:
    // that loads on one side.
    int16_t c_min = kMaxCost;
    if (u > 0 && num_valid == num_d) {
      // The bulk of the row: one pass slides the sums and updates both views' winners.
      int16_t* __restrict rc = right_cost + (width - 1 - u + min_d);
      uint16_t* __restrict ri = right_index + (width - 1 - u + min_d);
      for (int j = 0; j < num_d; ++j) {
        const auto sum =
            static_cast<uint16_t>(sums[j] + absDiff(a_in, q_in[j]) - absDiff(a_out, q_out[j]));
        sums[j] = sum;
        const auto cost = static_cast<int16_t>(sum);
        c_min = std::min(c_min, cost);
        const auto better = static_cast<uint16_t>(-static_cast<uint16_t>(cost < rc[j]));
        rc[j] = std::min(rc[j], cost);
        ri[j] = static_cast<uint16_t>((kIndex.values[j] & better) | (ri[j] & ~better));
      }
    } else {
      // Left border: the first min_d + num_d - 1 columns search fewer disparities.
      if (u > 0) {
        for (int j = 0; j < num_d; ++j) {
          sums[j] =
              static_cast<uint16_t>(sums[j] + absDiff(a_in, q_in[j]) - absDiff(a_out, q_out[j]));
        }
      }
      if (num_valid <= 0) {
        out[u] = kNoFixed;
        continue;
      }
      int16_t* __restrict rc = right_cost + (width - 1 - u + min_d);
      uint16_t* __restrict ri = right_index + (width - 1 - u + min_d);
      for (int j = 0; j < num_valid; ++j) {
        const auto cost = static_cast<int16_t>(sums[j]);
        c_min = std::min(c_min, cost);
        const auto better = static_cast<uint16_t>(-static_cast<uint16_t>(cost < rc[j]));
        rc[j] = std::min(rc[j], cost);
        ri[j] = static_cast<uint16_t>((kIndex.values[j] & better) | (ri[j] & ~better));
      }
    }
    // Smallest index reaching the minimum, as 255 - max(255 - j) over the lanes at the
    // minimum (the others masked to 0): a signed max reduction that SSE2 has.
    int16_t j_best_rev = 0;
    for (int j = 0; j < num_valid; ++j) {
      const auto at_min =
          static_cast<uint16_t>(-static_cast<uint16_t>(static_cast<int16_t>(sums[j]) == c_min));
      j_best_rev = std::max(j_best_rev, static_cast<int16_t>(kIndex.reversed[j] & at_min));
    }
    const int j_best = 255 - j_best_rev;
    const int c_best = c_min;

    if (setup.uniqueness_percent > 0) {
      // Cheapest disparity more than 1 px from the winner: |j - j_best| > 1, i.e.
      // (uint16)(j - (j_best - 1)) > 2, as a mask so that the loop vectorises.
      const auto base = static_cast<uint16_t>(j_best - 1);
      int16_t second = kMaxCost;
      for (int j = 0; j < num_valid; ++j) {
        const auto offset = static_cast<uint16_t>(kIndex.values[j] - base);
        const auto near = static_cast<uint16_t>(-static_cast<uint16_t>(offset <= 2) & kMaxCost);
        second = std::min(second, static_cast<int16_t>(sums[j] | near));
      }
      if (second != kMaxCost &&
          static_cast<int>(second) * 100 <= c_best * (100 + setup.uniqueness_percent)) {
        out[u] = kNoFixed;
        continue;
      }
    }

    int d_fixed = (min_d + j_best) * kFixedOne;
    if (setup.subpixel && j_best > 0 && j_best + 1 < num_valid) {
      // Equiangular fit: two lines of opposite slope through the three costs.
      const int c_minus = sums[j_best - 1];
      const int c_plus = sums[j_best + 1];
      const int slope = std::max(c_minus, c_plus) - c_best;
      if (slope > 0) {
        // offset = (c_minus - c_plus) / (2 slope) in [-1/2, 1/2], rounded to 1/16 px.
        const int num = (c_minus - c_plus) * kFixedOne;
        const int den = 2 * slope;
        d_fixed += (num >= 0 ? num + den / 2 : num - den / 2) / den;
      }
    }
    out[u] = static_cast<int16_t>(d_fixed);
  }
}

void matchRowBaseline(const uint8_t* __restrict left,
                      const uint8_t* __restrict right_rev,
                      const RowSetup& setup,
                      uint16_t* __restrict sums,
                      int16_t* __restrict right_cost,
                      uint16_t* __restrict right_index,
                      int16_t* __restrict out) {
  matchRowBody(left, right_rev, setup, sums, right_cost, right_index, out);
}

#if TWOCAM_DENSE_HAVE_AVX2
__attribute__((target("avx2"))) void matchRowAvx2(const uint8_t* __restrict left,
                                                  const uint8_t* __restrict right_rev,
                                                  const RowSetup& setup,
                                                  uint16_t* __restrict sums,
                                                  int16_t* __restrict right_cost,
                                                  uint16_t* __restrict right_index,
                                                  int16_t* __restrict out) {
  matchRowBody(left, right_rev, setup, sums, right_cost, right_index, out);
}
#endif

/// The row matcher of a SIMD choice: the AVX2 copy for kAvx2 (kAuto on an AVX2 CPU), else the
/// baseline copy. Same results: the same integer code, compiled twice.
using MatchRowFn = void (*)(
    const uint8_t*, const uint8_t*, const RowSetup&, uint16_t*, int16_t*, uint16_t*, int16_t*);
MatchRowFn matchRowFor(Simd simd) {
#if TWOCAM_DENSE_HAVE_AVX2
  if (resolveSimd(simd) == Simd::kAvx2) return matchRowAvx2;
#else
  (void)simd;
#endif
  return matchRowBaseline;
}

// ---------------------------------------------------------------------------------------------
// Post-processing in fixed point.

void leftRightCheckFixed(const FixedMap& right, int tolerance_fixed, const FixedMap& map) {
  for (int v = 0; v < map.height; ++v) {
    int16_t* row = map.row(v);
    const int16_t* right_row = right.row(v);
    for (int u = 0; u < map.width; ++u) {
      const int d = row[u];
      if (d < 0) continue;
      const int u_r = u - ((d + kFixedOne / 2) >> kFixedShift);
      bool ok = false;
      if (u_r >= 0 && u_r < map.width) {
        const int d_r = right_row[u_r];
        ok = d_r >= 0 && std::abs(d_r - d) <= tolerance_fixed;
      }
      if (!ok) row[u] = kNoFixed;
    }
  }
}

// Upper median of values[0..n): element of rank n / 2.
int16_t upperMedian(int16_t* values, int n) {
  std::nth_element(values, values + n / 2, values + n);
  return values[n / 2];
}

void propagateFixed(const FixedMap& in, int window_width, const FixedMap& out) {
  const int half = window_width / 2;
  std::vector<int16_t> window(static_cast<size_t>(window_width));
  for (int v = 0; v < in.height; ++v) {
    const int16_t* src = in.row(v);
    int16_t* dst = out.row(v);
    int16_t latest = kNoFixed;
    int first_output = -1;
    for (int u = 0; u < in.width; ++u) {
      int16_t value = src[u];
      if (value < 0) {
        int n = 0;
        const int u0 = std::max(0, u - half);
        const int u1 = std::min(in.width - 1, u + half);
        for (int k = u0; k <= u1; ++k) {
          if (src[k] >= 0) window[static_cast<size_t>(n++)] = src[k];
        }
        if (2 * n > window_width) {
          value = upperMedian(window.data(), n);
        } else if (n > 0) {
          value = *std::min_element(window.begin(), window.begin() + n);
        } else {
          value = latest;
        }
      }
      dst[u] = value;
      if (value >= 0) {
        latest = value;
        if (first_output < 0) first_output = u;
      }
    }
    if (first_output > 0) std::fill(dst, dst + first_output, dst[first_output]);
  }
}

// Median over valid values with a sliding histogram per row (Huang 1979): the window moves one
// column at a time, so each pixel costs one column update and a short walk of the median bin.
// Column entries equal on the entering and the leaving side cancel and are skipped, which in
// smooth regions is most of them. When every value is a whole pixel (the pipeline's integer
// winners), bins are whole pixels, so the walk is 16 times shorter.
void medianFixed(const FixedMap& in, int window_width, int window_height, const FixedMap& out) {
  int16_t max_value = 0;
  bool whole_pixels = true;
  for (int v = 0; v < in.height; ++v) {
    const int16_t* row = in.row(v);
    for (int u = 0; u < in.width; ++u) {
      max_value = std::max(max_value, row[u]);
      whole_pixels = whole_pixels && (row[u] < 0 || (row[u] & (kFixedOne - 1)) == 0);
    }
  }
  const int shift = whole_pixels ? kFixedShift : 0;
  std::vector<uint16_t> hist(static_cast<size_t>(max_value >> shift) + 1);
  const int hw = window_width / 2;
  const int hh = window_height / 2;
  const int width = in.width;
  for (int v = 0; v < in.height; ++v) {
    const int v0 = std::max(0, v - hh);
    const int v1 = std::min(in.height - 1, v + hh);
    std::fill(hist.begin(), hist.end(), static_cast<uint16_t>(0));
    int count = 0;
    int median = 0;  // current bin
    int below = 0;   // number of values in bins < median
    auto add = [&](int16_t d) {
      if (d < 0) return;
      const int bin = d >> shift;
      ++hist[static_cast<size_t>(bin)];
      ++count;
      below += bin < median ? 1 : 0;
    };
    auto remove = [&](int16_t d) {
      if (d < 0) return;
      const int bin = d >> shift;
      --hist[static_cast<size_t>(bin)];
      --count;
      below -= bin < median ? 1 : 0;
    };
    for (int vv = v0; vv <= v1; ++vv) {
      const int16_t* row = in.row(vv);
      for (int u = 0; u < std::min(hw, width); ++u) add(row[u]);
    }
    const int16_t* src = in.row(v);
    int16_t* dst = out.row(v);
    for (int u = 0; u < width; ++u) {
      const int u_in = u + hw;
      const int u_out = u - hw - 1;
      for (int vv = v0; vv <= v1; ++vv) {
        const int16_t* row = in.row(vv);
        const int16_t d_in = u_in < width ? row[u_in] : kNoFixed;
        const int16_t d_out = u_out >= 0 ? row[u_out] : kNoFixed;
        if (d_in == d_out) continue;
        remove(d_out);
        add(d_in);
      }
      if (src[u] < 0) {
        dst[u] = kNoFixed;
        continue;
      }
      const int rank = count / 2;
      while (below > rank) {
        --median;
        below -= hist[static_cast<size_t>(median)];
      }
      while (below + hist[static_cast<size_t>(median)] <= rank) {
        below += hist[static_cast<size_t>(median)];
        ++median;
      }
      dst[u] = static_cast<int16_t>(median << shift);
    }
  }
}

std::string lower(std::string s) {
  for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return s;
}

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

std::string toString(PostStep step) {
  switch (step) {
    case PostStep::kLeftRightCheck:
      return "lrc";
    case PostStep::kPropagation:
      return "prop";
    case PostStep::kMedian:
      return "median";
  }
  return "unknown";
}

std::string formatPostSteps(const std::vector<PostStep>& steps) {
  std::string text;
  for (size_t i = 0; i < steps.size(); ++i) {
    if (i > 0) text += ",";
    text += toString(steps[i]);
  }
  return text;
}

Status parsePostSteps(const std::string& text, std::vector<PostStep>* steps) {
  if (steps == nullptr) return Status::error("parsePostSteps: steps is null");
  std::vector<PostStep> parsed;
  const std::string all = lower(trim(text));
  if (all.empty() || all == "none") {
    steps->clear();
    return Status::ok();
  }
  std::istringstream in(all);
  std::string token;
  while (std::getline(in, token, ',')) {
    token = trim(token);
    if (token == "lrc" || token == "lr" || token == "leftright") {
      parsed.push_back(PostStep::kLeftRightCheck);
    } else if (token == "prop" || token == "propagation") {
      parsed.push_back(PostStep::kPropagation);
    } else if (token == "median" || token == "med") {
      parsed.push_back(PostStep::kMedian);
    } else {
      return Status::error("unknown post-processing step '" + token + "' in '" + text +
                           "'; expected lrc, prop or median, comma-separated");
    }
  }
  if (!all.empty() && all.back() == ',') {
    return Status::error("empty post-processing step at the end of '" + text + "'");
  }
  *steps = std::move(parsed);
  return Status::ok();
}

Status DenseSadOptions::validate() const {
  std::ostringstream msg;
  if (window_width_px < 3 || window_width_px > 21 || window_width_px % 2 == 0) {
    msg << "window_width_px = " << window_width_px << "; must be odd and in [3, 21]";
  } else if (min_disparity_px < 0) {
    msg << "min_disparity_px = " << min_disparity_px << "; must be >= 0";
  } else if (max_disparity_px < min_disparity_px) {
    msg << "max_disparity_px = " << max_disparity_px
        << "; must be >= min_disparity_px = " << min_disparity_px;
  } else if (max_disparity_px - min_disparity_px > 255) {
    msg << "max_disparity_px - min_disparity_px = " << max_disparity_px - min_disparity_px
        << "; must be <= 255 (at most 256 disparities)";
  } else if (static_cast<float>(max_disparity_px) + 1.0f > kMaxDisparityValuePx) {
    msg << "max_disparity_px = " << max_disparity_px << "; must be < " << kMaxDisparityValuePx;
  } else if (!(lr_tolerance_px >= 0.0f) || lr_tolerance_px > kMaxDisparityValuePx) {
    msg << "lr_tolerance_px = " << lr_tolerance_px << "; must be in [0, " << kMaxDisparityValuePx
        << "]";
  } else if (propagation_width_px < 3 || propagation_width_px % 2 == 0 ||
             propagation_width_px > 255) {
    msg << "propagation_width_px = " << propagation_width_px << "; must be odd and in [3, 255]";
  } else if (median_width_px < 1 || median_width_px % 2 == 0 || median_width_px > 255) {
    msg << "median_width_px = " << median_width_px << "; must be odd and in [1, 255]";
  } else if (median_height_px < 1 || median_height_px % 2 == 0 || median_height_px > 255) {
    msg << "median_height_px = " << median_height_px << "; must be odd and in [1, 255]";
  } else if (uniqueness_percent < 0 || uniqueness_percent > 1000) {
    msg << "uniqueness_percent = " << uniqueness_percent << "; must be in [0, 1000]";
  } else if (Status st = checkSimd("simd", simd); !st) {
    msg << st.message();
  } else {
    return Status::ok();
  }
  return Status::error(msg.str());
}

Status DenseSadMatcher::compute(const ImageU8& left,
                                const ImageU8& right,
                                const DenseSadOptions& options,
                                ImageF32* disparity) {
  if (disparity == nullptr) return Status::error("computeDenseDisparity: disparity is null");
  if (Status s = options.validate(); !s) return Status::error("DenseSadOptions: " + s.message());
  if (left.empty() || right.empty() || left.width <= 0 || left.height <= 0) {
    return Status::error("computeDenseDisparity: empty image");
  }
  if (left.width != right.width || left.height != right.height) {
    std::ostringstream msg;
    msg << "computeDenseDisparity: left image is " << left.width << "x" << left.height
        << " but right image is " << right.width << "x" << right.height;
    return Status::error(msg.str());
  }
  const size_t pixels = static_cast<size_t>(left.width) * left.height;
  if (left.data.size() != pixels || right.data.size() != pixels) {
    return Status::error("computeDenseDisparity: pixel count does not match the image size");
  }
  if (options.max_disparity_px >= left.width) {
    std::ostringstream msg;
    msg << "computeDenseDisparity: max_disparity_px = " << options.max_disparity_px
        << " must be below the image width " << left.width;
    return Status::error(msg.str());
  }

  const int width = left.width;
  const int height = left.height;
  RowSetup setup;
  setup.width = width;
  setup.radius = options.window_width_px / 2;
  setup.min_d = options.min_disparity_px;
  setup.num_d = options.max_disparity_px - options.min_disparity_px + 1;
  setup.subpixel = options.subpixel;
  setup.uniqueness_percent = options.uniqueness_percent;
  const int r = setup.radius;
  const MatchRowFn match_row = matchRowFor(options.simd);

  left_row_.resize(static_cast<size_t>(width + 2 * r));
  right_row_.resize(static_cast<size_t>(width + 2 * r + setup.min_d + setup.num_d));
  sums_.resize(static_cast<size_t>(setup.num_d));
  right_cost_.resize(static_cast<size_t>(width));
  right_index_.resize(static_cast<size_t>(width));
  left_fixed_.resize(pixels);
  right_fixed_.resize(pixels);

  for (int v = 0; v < height; ++v) {
    const uint8_t* l = left.row(v);
    const uint8_t* rr = right.row(v);
    // left_row_[i + r] = L(clamp(i)); right_row_[m] = R(clamp(c - m)).
    std::fill_n(left_row_.begin(), r, l[0]);
    std::copy_n(l, width, left_row_.begin() + r);
    std::fill_n(left_row_.begin() + r + width, r, l[width - 1]);
    std::fill_n(right_row_.begin(), r, rr[width - 1]);
    std::reverse_copy(rr, rr + width, right_row_.begin() + r);
    std::fill(right_row_.begin() + r + width, right_row_.end(), rr[0]);
    int16_t* out = left_fixed_.data() + static_cast<size_t>(v) * width;
    match_row(left_row_.data(),
              right_row_.data(),
              setup,
              sums_.data(),
              right_cost_.data(),
              right_index_.data(),
              out);
    int16_t* right_out = right_fixed_.data() + static_cast<size_t>(v) * width;
    for (int u_r = 0; u_r < width; ++u_r) {
      const uint16_t j = right_index_[static_cast<size_t>(width - 1 - u_r)];
      right_out[u_r] =
          j == kNoIndex ? kNoFixed : static_cast<int16_t>((setup.min_d + j) * kFixedOne);
    }
  }

  FixedMap map{width, height, left_fixed_.data()};
  const FixedMap right_map{width, height, right_fixed_.data()};
  for (const PostStep step : options.steps) {
    switch (step) {
      case PostStep::kLeftRightCheck:
        leftRightCheckFixed(
            right_map, static_cast<int>(std::floor(options.lr_tolerance_px * kFixedOne)), map);
        break;
      case PostStep::kPropagation: {
        work_fixed_.resize(pixels);
        const FixedMap out{width, height, work_fixed_.data()};
        propagateFixed(map, options.propagation_width_px, out);
        left_fixed_.swap(work_fixed_);
        map.data = left_fixed_.data();
        break;
      }
      case PostStep::kMedian: {
        work_fixed_.resize(pixels);
        const FixedMap out{width, height, work_fixed_.data()};
        medianFixed(map, options.median_width_px, options.median_height_px, out);
        left_fixed_.swap(work_fixed_);
        map.data = left_fixed_.data();
        break;
      }
    }
  }

  if (disparity->width != width || disparity->height != height ||
      disparity->data.size() != pixels) {
    *disparity = ImageF32(width, height);
  }
  fixedToFloat(left_fixed_, disparity);
  if (right_disparity_.width != width || right_disparity_.height != height ||
      right_disparity_.data.size() != pixels) {
    right_disparity_ = ImageF32(width, height);
  }
  fixedToFloat(right_fixed_, &right_disparity_);
  return Status::ok();
}

Status computeDenseDisparity(const ImageU8& left,
                             const ImageU8& right,
                             const DenseSadOptions& options,
                             ImageF32* disparity) {
  DenseSadMatcher matcher;
  return matcher.compute(left, right, options, disparity);
}

Status leftRightCheck(const ImageF32& right_disparity, float tolerance_px, ImageF32* disparity) {
  if (Status s = checkMap(disparity, "leftRightCheck: disparity"); !s) return s;
  if (Status s = checkMap(&right_disparity, "leftRightCheck: right_disparity"); !s) return s;
  if (right_disparity.width != disparity->width || right_disparity.height != disparity->height) {
    std::ostringstream msg;
    msg << "leftRightCheck: left map is " << disparity->width << "x" << disparity->height
        << " but right map is " << right_disparity.width << "x" << right_disparity.height;
    return Status::error(msg.str());
  }
  if (!(tolerance_px >= 0.0f) || tolerance_px > kMaxDisparityValuePx) {
    std::ostringstream msg;
    msg << "leftRightCheck: tolerance_px = " << tolerance_px << "; must be >= 0";
    return Status::error(msg.str());
  }
  std::vector<int16_t> left_fixed;
  std::vector<int16_t> right_fixed;
  if (Status s = floatToFixed(*disparity, &left_fixed); !s)
    return Status::error("leftRightCheck: " + s.message());
  if (Status s = floatToFixed(right_disparity, &right_fixed); !s)
    return Status::error("leftRightCheck: " + s.message());
  leftRightCheckFixed(FixedMap{right_disparity.width, right_disparity.height, right_fixed.data()},
                      static_cast<int>(std::floor(tolerance_px * kFixedOne)),
                      FixedMap{disparity->width, disparity->height, left_fixed.data()});
  fixedToFloat(left_fixed, disparity);
  return Status::ok();
}

Status propagateDisparity(int window_width_px, ImageF32* disparity) {
  if (Status s = checkMap(disparity, "propagateDisparity: disparity"); !s) return s;
  if (window_width_px < 3 || window_width_px % 2 == 0 || window_width_px > 255) {
    std::ostringstream msg;
    msg << "propagateDisparity: window_width_px = " << window_width_px
        << "; must be odd and in [3, 255]";
    return Status::error(msg.str());
  }
  std::vector<int16_t> in;
  if (Status s = floatToFixed(*disparity, &in); !s)
    return Status::error("propagateDisparity: " + s.message());
  std::vector<int16_t> out(in.size());
  propagateFixed(FixedMap{disparity->width, disparity->height, in.data()},
                 window_width_px,
                 FixedMap{disparity->width, disparity->height, out.data()});
  fixedToFloat(out, disparity);
  return Status::ok();
}

Status medianFilterDisparity(int width_px, int height_px, ImageF32* disparity) {
  if (Status s = checkMap(disparity, "medianFilterDisparity: disparity"); !s) return s;
  if (width_px < 1 || width_px % 2 == 0 || width_px > 255 || height_px < 1 || height_px % 2 == 0 ||
      height_px > 255) {
    std::ostringstream msg;
    msg << "medianFilterDisparity: window " << width_px << "x" << height_px
        << "; both sizes must be odd and in [1, 255]";
    return Status::error(msg.str());
  }
  std::vector<int16_t> in;
  if (Status s = floatToFixed(*disparity, &in); !s)
    return Status::error("medianFilterDisparity: " + s.message());
  std::vector<int16_t> out(in.size());
  medianFixed(FixedMap{disparity->width, disparity->height, in.data()},
              width_px,
              height_px,
              FixedMap{disparity->width, disparity->height, out.data()});
  fixedToFloat(out, disparity);
  return Status::ok();
}

}  // namespace twocam::frontend
