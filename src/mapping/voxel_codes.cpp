#include "mapping/voxel_codes.h"

namespace twocam::mapping {
namespace {

constexpr uint64_t kMortonAxisBits = 0x249249249249ULL;  // bits 0, 3, ..., 45
constexpr unsigned kLowLevels = 8;                       // levels below the window bits
constexpr uint64_t kLowMask = (uint64_t{1} << (3U * kLowLevels)) - 1U;

}  // namespace

VoxelCodeLayout fullCodeLayout() {
  VoxelCodeLayout layout;
  for (unsigned i = 0; i < 3; ++i) layout.mask[i] = kMortonAxisBits << i;
  return layout;
}

std::optional<VoxelCodeLayout> windowedCodeLayout(const octomap::OcTreeKey& lo,
                                                  const octomap::OcTreeKey& hi) {
  VoxelCodeLayout layout;
  layout.windowed = true;
  layout.bits = 3U * kLowLevels + 3U;
  // Bit at which each axis's two high parts (key >> 8) first differ, ranked with the axis as
  // tie-break (z > y > x): the Morton position 3 t + i orders them.
  std::array<unsigned, 3> morton_position{};
  for (unsigned i = 0; i < 3; ++i) {
    const unsigned high = lo[i] >> kLowLevels;
    if (hi[i] < lo[i] || (hi[i] >> kLowLevels) > high + 1U) return std::nullopt;
    layout.base[i] = high << kLowLevels;
    unsigned t = 0;
    for (unsigned diff = high ^ (high + 1U); diff > 1U; diff >>= 1U) ++t;
    morton_position[i] = 3U * t + i;
  }
  for (unsigned i = 0; i < 3; ++i) {
    unsigned rank = 0;
    for (unsigned j = 0; j < 3; ++j) rank += morton_position[j] < morton_position[i] ? 1U : 0U;
    layout.window_bit[i] = 3U * kLowLevels + rank;
    layout.mask[i] = ((kMortonAxisBits << i) & kLowMask) | (uint64_t{1} << layout.window_bit[i]);
  }
  for (unsigned g = 0; g < 8; ++g) {
    uint64_t m = 0;
    for (unsigned i = 0; i < 3; ++i) {
      const uint64_t high =
          (layout.base[i] >> kLowLevels) + ((g >> (layout.window_bit[i] - 24U)) & 1U);
      m |= spreadBits(high) << (3U * kLowLevels + i);
    }
    layout.high_morton[g] = m;
  }
  return layout;
}

uint64_t encodeKey(const VoxelCodeLayout& layout, const octomap::OcTreeKey& key) {
  if (!layout.windowed) return mortonCode(key);
  uint64_t code = 0;
  for (unsigned i = 0; i < 3; ++i) {
    const unsigned local = key[i] - layout.base[i];
    assert(key[i] >= layout.base[i] && local < 2U << kLowLevels);
    code |= (spreadBits(local & 0xFFU) << i) |
            (static_cast<uint64_t>(local >> kLowLevels) << layout.window_bit[i]);
  }
  return code;
}

}  // namespace twocam::mapping
