#include "frontend/support_value_internal.h"
/// Row constraints and post-processing of the support-value matcher (support_value_internal.h):
/// ordering and uniqueness, continuity, depth-edge erosion, row filling.

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace twocam::frontend::internal::support {

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

}  // namespace twocam::frontend::internal::support
