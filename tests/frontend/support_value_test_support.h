#pragma once
// Shared fixtures of the support-value tests (support_value_test, support_value_salient_test):
// seeded blurred-noise textures and a layered rectified pair (background and an occluding box).

#include <algorithm>
#include <cmath>
#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <random>
#include <vector>

#include "common/image.h"
#include "frontend/support_value.h"

namespace twocam::frontend {

/// Row-major texture with a few pixels' correlation: uniform noise, box-blurred 3x3.
inline std::vector<uint8_t> texture(std::mt19937& rng, int width, int height) {
  std::uniform_int_distribution<int> grey(0, 255);
  std::vector<int> raw(static_cast<size_t>(width) * height);
  for (int& t : raw) t = grey(rng);
  std::vector<uint8_t> out(raw.size());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      int s = 0, n = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
          s += raw[static_cast<size_t>(yy) * width + xx];
          ++n;
        }
      }
      // Stretch the blurred values back to most of the grey range.
      const double m = static_cast<double>(s) / n;
      out[static_cast<size_t>(y) * width + x] =
          static_cast<uint8_t>(std::clamp(128.0 + 2.5 * (m - 127.5), 0.0, 255.0));
    }
  }
  return out;
}

inline void addNoise(std::mt19937& rng, double sigma, ImageU8* image) {
  std::normal_distribution<double> noise(0.0, sigma);
  for (uint8_t& px : image->data)
    px = static_cast<uint8_t>(std::clamp(std::lround(px + noise(rng)), 0L, 255L));
}

struct SyntheticPair {
  ImageU8 left;
  ImageU8 right;
  ImageF32 truth;
  ImageU8 visible;  // 1 where the right camera sees the left pixel's surface
};

/// A background at bg_d and a box (columns [w/3, 2w/3), rows [h/4, 3h/4)) at box_d, painted as a
/// rectified rig sees them (the box occludes the background in the right view).
inline SyntheticPair makeLayeredPair(uint32_t seed, int width, int height, int bg_d, int box_d) {
  std::mt19937 rng(seed);
  const int u0 = width / 3, u1 = 2 * width / 3, v0 = height / 4, v1 = 3 * height / 4;
  const int bw = width + bg_d;
  const std::vector<uint8_t> bg = texture(rng, bw, height);  // scene column s at index s
  const std::vector<uint8_t> box = texture(rng, width, height);
  SyntheticPair p;
  p.left = ImageU8(width, height);
  p.right = ImageU8(width, height);
  p.truth = ImageF32(width, height);
  p.visible = ImageU8(width, height);
  for (int v = 0; v < height; ++v) {
    const bool box_row = v >= v0 && v < v1;
    for (int u = 0; u < width; ++u) {
      const bool in_box = box_row && u >= u0 && u < u1;
      p.left(u, v) =
          in_box ? box[static_cast<size_t>(v) * width + u] : bg[static_cast<size_t>(v) * bw + u];
      p.truth(u, v) = static_cast<float>(in_box ? box_d : bg_d);
    }
    for (int x = 0; x < width; ++x) {
      const int s_box = x + box_d;
      const bool box_here = box_row && s_box >= u0 && s_box < u1;
      p.right(x, v) = box_here ? box[static_cast<size_t>(v) * width + s_box]
                               : bg[static_cast<size_t>(v) * bw + x + bg_d];
    }
    for (int u = 0; u < width; ++u) {
      const bool in_box = box_row && u >= u0 && u < u1;
      const int x = u - static_cast<int>(p.truth(u, v));
      const bool right_box = box_row && x + box_d >= u0 && x + box_d < u1;
      p.visible(u, v) = x >= 0 && right_box == in_box ? 1 : 0;
    }
  }
  addNoise(rng, 2.0, &p.left);
  addNoise(rng, 2.0, &p.right);
  return p;
}

/// The defaults with a smaller disparity range, for small synthetic pairs.
inline SupportValueOptions smallOptions(int max_d) {
  SupportValueOptions o;
  o.max_disparity_px = max_d;
  return o;
}

}  // namespace twocam::frontend
