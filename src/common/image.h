#pragma once
/// Plain image buffers exchanged between modules. Row-major, tightly packed,
/// pixel (0, 0) is the top-left pixel; its centre is at (u, v) = (0, 0).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace twocam {

template <typename T>
struct Image {
  int width = 0;
  int height = 0;
  std::vector<T> data;

  Image() = default;
  Image(int w, int h, T fill = T{}) : width(w), height(h), data(static_cast<size_t>(w) * h, fill) {}
  [[nodiscard]] bool empty() const { return data.empty(); }
  T& operator()(int u, int v) { return data[static_cast<size_t>(v) * width + u]; }
  const T& operator()(int u, int v) const { return data[static_cast<size_t>(v) * width + u]; }
  T* row(int v) { return data.data() + static_cast<size_t>(v) * width; }
  const T* row(int v) const { return data.data() + static_cast<size_t>(v) * width; }
};

/// 8-bit grey image (what the rig's cameras deliver).
using ImageU8 = Image<uint8_t>;
/// Float image, e.g. depth along the optical axis [m]; 0 means no surface.
using ImageF32 = Image<float>;

}  // namespace twocam
