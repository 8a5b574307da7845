#pragma once
// Shared fixtures of the scaled-window NCC tests (ncc_scaled_test, ncc_salient_test): a smooth
// seeded texture that can be sampled anywhere, slanted-plane pairs, and the sub-pixel
// tolerances they share.

#include <algorithm>
#include <cmath>
#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <random>

#include "common/image.h"

namespace twocam::frontend {

// Sub-pixel search steps of 1/10 px plus 8-bit rounding of the rendered pairs.
constexpr double kSubpixelTolPx = 0.15;
// A scaled window's estimate on a fronto-parallel plane, pulled towards the integer disparity.
constexpr double kScaledSubpixelTolPx = 0.35;

/// A smooth random texture that can be evaluated anywhere: a sum of plane waves with seeded
/// frequencies (0.15..0.7 rad/px along the row, a camera-blurred texture whose 1/sqrt(2)
/// compression stays well below Nyquist)
/// and phases, scaled to about 30..225 grey levels.
class Texture {
 public:
  explicit Texture(uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> wx(0.15, 0.7);
    std::uniform_real_distribution<double> wy(-0.8, 0.8);
    std::uniform_real_distribution<double> phase(0.0, 6.283185307179586);
    for (int k = 0; k < kWaves; ++k) waves_[k] = {wx(rng), wy(rng), phase(rng)};
  }
  [[nodiscard]] double operator()(double x, double y) const {
    double s = 0.0;
    for (const Wave& w : waves_) s += std::sin(w.wx * x + w.wy * y + w.phase);
    return 128.0 + 95.0 * s / std::sqrt(static_cast<double>(kWaves) / 2.0) / 2.0;
  }

 private:
  static constexpr int kWaves = 16;
  struct Wave {
    double wx = 0.0, wy = 0.0, phase = 0.0;
  };
  Wave waves_[kWaves];
};

inline uint8_t toGrey(double value) {
  return static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
}

struct Pair {
  ImageU8 left;
  ImageU8 right;
  ImageF32 truth;  // left-view disparity [px], < 0 = none (occluded)
};

/// A plane d(u) = d0 + slope * u seen by both cameras: L(u, y) = T(u, y) and
/// R(x, y) = T(u(x), y) with x = u - d(u), so a left window maps onto right samples spaced
/// (1 - slope) apart: slope 1 - 1/sqrt(2) is the matcher's scale 1/sqrt(2), 1 - sqrt(2) its
/// sqrt(2). slope 0 is a fronto-parallel plane at d0 (any real value).
inline Pair slantedPair(int width, int height, double d0, double slope, uint32_t seed) {
  const Texture tex(seed);
  Pair p{ImageU8(width, height), ImageU8(width, height), ImageF32(width, height)};
  for (int y = 0; y < height; ++y) {
    for (int u = 0; u < width; ++u) {
      p.left(u, y) = toGrey(tex(u, y));
      // No truth where the match falls outside the right image (or within 3 px of its edge).
      const double x = u - (d0 + slope * u);
      p.truth(u, y) = x >= 3.0 && x <= width - 4.0 ? static_cast<float>(d0 + slope * u) : -1.0f;
      p.right(u, y) = toGrey(tex((u + d0) / (1.0 - slope), y));
    }
  }
  return p;
}

}  // namespace twocam::frontend
