#include "mapping/voxel_codes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace twocam::mapping {
namespace {

/// Property trials per test (house style: 1000 seeded trials).
constexpr int kTrials = 1000;

octomap::OcTreeKey key(unsigned x, unsigned y, unsigned z) {
  return {static_cast<octomap::key_type>(x),
          static_cast<octomap::key_type>(y),
          static_cast<octomap::key_type>(z)};
}

/// The codes computeRayKeys' voxels have in `layout`, in its order; nullopt when it fails.
std::optional<std::vector<uint64_t>> octomapRay(const octomap::OcTree& tree,
                                                const VoxelCodeLayout& layout,
                                                const octomap::point3d& origin,
                                                const octomap::point3d& end) {
  octomap::KeyRay ray;
  if (!tree.computeRayKeys(origin, end, ray)) return std::nullopt;
  std::vector<uint64_t> codes;
  for (const octomap::OcTreeKey& k : ray) codes.push_back(encodeKey(layout, k));
  return codes;
}

/// The codes RayCodeWalk visits.
std::vector<uint64_t> walkedRay(const octomap::OcTree& tree,
                                const VoxelCodeLayout& layout,
                                const octomap::point3d& origin,
                                const octomap::point3d& end) {
  const octomap::OcTreeKey origin_key = tree.coordToKey(origin);
  const octomap::OcTreeKey end_key = tree.coordToKey(end);
  std::vector<uint64_t> codes;
  visitRayCodes(
      tree, layout, origin, origin_key, end, end_key, [&](uint64_t c) { codes.push_back(c); });
  return codes;
}

/// The windowed layout around a ray's end voxels with the margin OccupancyMapper uses.
VoxelCodeLayout windowAround(const octomap::OcTree& tree,
                             const octomap::point3d& origin,
                             const octomap::point3d& end) {
  const octomap::OcTreeKey a = tree.coordToKey(origin);
  const octomap::OcTreeKey b = tree.coordToKey(end);
  octomap::OcTreeKey lo;
  octomap::OcTreeKey hi;
  for (unsigned i = 0; i < 3; ++i) {
    lo[i] = static_cast<octomap::key_type>(std::min(a[i], b[i]) - 2);
    hi[i] = static_cast<octomap::key_type>(std::max(a[i], b[i]) + 2);
  }
  const std::optional<VoxelCodeLayout> layout = windowedCodeLayout(lo, hi);
  EXPECT_TRUE(layout.has_value());
  return layout.value_or(fullCodeLayout());
}

/// Expects RayCodeWalk to list computeRayKeys' voxels, in both layouts.
void expectSameRay(const octomap::OcTree& tree,
                   const octomap::point3d& origin,
                   const octomap::point3d& end,
                   const std::string& what) {
  for (const VoxelCodeLayout& layout : {fullCodeLayout(), windowAround(tree, origin, end)}) {
    const std::optional<std::vector<uint64_t>> expected = octomapRay(tree, layout, origin, end);
    ASSERT_TRUE(expected.has_value()) << what;
    ASSERT_EQ(walkedRay(tree, layout, origin, end), *expected)
        << what << " (windowed: " << layout.windowed << "), origin " << origin << ", end " << end;
  }
}

/// A coordinate in [-range, range] on a voxel face of `tree` (a multiple of the resolution, as
/// float); faces at 0.05 m are not exact binary fractions, at 0.25 m they are.
float onFace(std::mt19937& rng, const octomap::OcTree& tree, double range) {
  const int n = static_cast<int>(range / tree.getResolution());
  std::uniform_int_distribution<int> k(-n, n);
  return static_cast<float>(k(rng) * tree.getResolution());
}

TEST(RayCodeWalk, ListsComputeRayKeysVoxelsForRandomRays) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-3.0, 3.0);
  std::normal_distribution<double> dir(0.0, 1.0);
  std::uniform_real_distribution<double> length(0.0, 6.0);
  for (const double resolution : {0.05, 0.25}) {
    const octomap::OcTree tree(resolution);
    for (int trial = 0; trial < kTrials; ++trial) {
      // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to
      // left, kept)
      const auto oz = static_cast<float>(coord(rng));
      const auto oy = static_cast<float>(coord(rng));
      const auto ox = static_cast<float>(coord(rng));
      const octomap::point3d origin(ox, oy, oz);
      const auto dz = static_cast<float>(dir(rng));
      const auto dy = static_cast<float>(dir(rng));
      const auto dx = static_cast<float>(dir(rng));
      const octomap::point3d d(dx, dy, dz);
      const octomap::point3d end = origin + d.normalized() * static_cast<float>(length(rng));
      expectSameRay(tree, origin, end, "random ray " + std::to_string(trial));
    }
  }
}

TEST(RayCodeWalk, ListsComputeRayKeysVoxelsAlongAxesAndOnVoxelFaces) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> coord(-3.0, 3.0);
  std::uniform_real_distribution<double> length(-6.0, 6.0);
  std::uniform_int_distribution<int> axis(0, 2);
  std::bernoulli_distribution on_face(0.5);
  for (const double resolution : {0.05, 0.25}) {
    const octomap::OcTree tree(resolution);
    for (int trial = 0; trial < kTrials; ++trial) {
      // Origin and end anywhere or on voxel faces, ray along one axis or along a plane's
      // diagonal or free.
      octomap::point3d origin;
      octomap::point3d end;
      for (unsigned i = 0; i < 3; ++i) {
        origin(i) = on_face(rng) ? onFace(rng, tree, 3.0) : static_cast<float>(coord(rng));
        end(i) = on_face(rng) ? onFace(rng, tree, 3.0) : static_cast<float>(coord(rng));
      }
      switch (trial % 4) {
        case 0: {  // along an axis
          const int a = axis(rng);
          end = origin;
          end(a) += static_cast<float>(length(rng));
          break;
        }
        case 1: {  // in an axis plane, at 45 degrees
          const int a = axis(rng);
          end = origin;
          const auto l = static_cast<float>(length(rng));
          end((a + 1) % 3) += l;
          end((a + 2) % 3) += trial % 2 == 0 ? l : -l;
          break;
        }
        case 2: {  // face to face, whole voxels along two or three axes: ends on edges or corners
          std::uniform_int_distribution<int> voxels(-40, 40);
          const int k = voxels(rng);
          const int a = axis(rng);
          for (unsigned i = 0; i < 3; ++i) {
            origin(i) = onFace(rng, tree, 3.0);
            const int sign = (trial / 4 + static_cast<int>(i)) % 2 == 0 ? 1 : -1;
            const int steps = static_cast<int>(i) == a && trial % 8 == 2 ? 0 : sign * k;
            end(i) = origin(i) + static_cast<float>(steps * tree.getResolution());
          }
          break;
        }
        default:  // both ends as drawn
          break;
      }
      expectSameRay(tree, origin, end, "axis/face ray " + std::to_string(trial));
    }
  }
}

TEST(RayCodeWalk, ListsComputeRayKeysVoxelsForDiagonalsThroughVoxelCorners) {
  // From a voxel corner along (+-1, +-1, 0) or (+-1, +-1, +-1) for whole voxels: every step is a
  // tie between axes and the end is a corner, where computeRayKeys' "past the end" test can meet
  // t_max == length exactly.
  for (const double resolution : {0.05, 0.25}) {
    const octomap::OcTree tree(resolution);
    for (int corner = -3; corner <= 3; ++corner) {
      const auto c = static_cast<float>(corner * resolution);
      const octomap::point3d origin(c, -c, 0.5F * c);
      for (int k = -24; k <= 24; ++k) {
        for (int signs = 0; signs < 8; ++signs) {
          octomap::point3d end = origin;
          for (unsigned i = 0; i < 3; ++i) {
            const int sign = (signs >> i) & 1 ? -1 : 1;
            if (i < 2 || corner % 2 == 0) end(i) += static_cast<float>(sign * k * resolution);
          }
          expectSameRay(tree, origin, end, "diagonal " + std::to_string(k));
        }
      }
    }
  }
}

TEST(RayCodeWalk, ZeroLengthAndSameVoxelRaysHaveNoVoxels) {
  const octomap::OcTree tree(0.05);
  const octomap::point3d origin(0.012F, -0.013F, 1.024F);
  expectSameRay(tree, origin, origin, "zero length");
  EXPECT_TRUE(walkedRay(tree, fullCodeLayout(), origin, origin).empty());
  const octomap::point3d near(0.013F, -0.012F, 1.026F);  // same voxel
  expectSameRay(tree, origin, near, "same voxel");
  EXPECT_TRUE(walkedRay(tree, fullCodeLayout(), origin, near).empty());
  // One voxel apart: only the origin's voxel.
  const octomap::point3d next(0.062F, -0.013F, 1.024F);
  expectSameRay(tree, origin, next, "neighbour");
  EXPECT_EQ(walkedRay(tree, fullCodeLayout(), origin, next).size(), 1U);
}

/// Random keys of a window starting at `base` on every axis: codes sort like Morton codes and
/// map back to them.
void expectWindowedOrderIsMortonOrder(unsigned base, std::mt19937& rng) {
  const std::optional<VoxelCodeLayout> layout =
      windowedCodeLayout(key(base, base, base), key(base + 511, base + 511, base + 511));
  ASSERT_TRUE(layout.has_value()) << base;
  std::uniform_int_distribution<unsigned> offset(0, 511);
  std::vector<octomap::OcTreeKey> keys;
  for (int i = 0; i < kTrials; ++i) {
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const auto kz = base + offset(rng);
    const auto ky = base + offset(rng);
    const auto kx = base + offset(rng);
    keys.push_back(key(kx, ky, kz));
  }
  for (const octomap::OcTreeKey& k : keys) {
    const uint64_t code = encodeKey(*layout, k);
    ASSERT_LT(code, uint64_t{1} << layout->bits);
    ASSERT_EQ(toMortonCode(*layout, code), mortonCode(k)) << base;
  }
  for (size_t i = 0; i + 1 < keys.size(); ++i) {
    const bool by_code = encodeKey(*layout, keys[i]) < encodeKey(*layout, keys[i + 1]);
    const bool by_morton = mortonCode(keys[i]) < mortonCode(keys[i + 1]);
    ASSERT_EQ(by_code, by_morton) << "base " << base << ", pair " << i;
  }
}

TEST(VoxelCodeLayout, WindowedCodesSortInMortonOrderAcrossKeyBoundaries) {
  std::mt19937 rng(13);
  // Windows whose two halves differ at bit 15 (the origin of the world), at bits 8-14, or only
  // at bit 8; and per axis different bits, which ranks the window bits.
  for (const unsigned base : {0x7F00U, 0x8000U, 0x7E00U, 0x8100U, 0x3F00U, 0x0100U, 0xFE00U}) {
    expectWindowedOrderIsMortonOrder(base, rng);
  }
  const std::optional<VoxelCodeLayout> mixed =
      windowedCodeLayout(key(0x7F10, 0x8010, 0x7B20), key(0x80F0, 0x81F0, 0x7CF0));
  ASSERT_TRUE(mixed.has_value());
  std::uniform_int_distribution<unsigned> offset(0, 0x1DF);
  uint64_t previous_morton = 0;
  std::vector<octomap::OcTreeKey> keys;
  for (int i = 0; i < kTrials; ++i) {
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const auto kz = 0x7B20 + offset(rng);
    const auto ky = 0x8010 + offset(rng);
    const auto kx = 0x7F10 + offset(rng);
    keys.push_back(key(kx, ky, kz));
  }
  std::sort(keys.begin(), keys.end(), [&](const auto& a, const auto& b) {
    return encodeKey(*mixed, a) < encodeKey(*mixed, b);
  });
  for (const octomap::OcTreeKey& k : keys) {
    ASSERT_LE(previous_morton, mortonCode(k));
    ASSERT_EQ(toMortonCode(*mixed, encodeKey(*mixed, k)), mortonCode(k));
    previous_morton = mortonCode(k);
  }
}

TEST(VoxelCodeLayout, WindowedRejectsRangesBeyondTwoBlocks) {
  EXPECT_TRUE(windowedCodeLayout(key(0x7F00, 0, 0), key(0x80FF, 0, 0)).has_value());
  EXPECT_FALSE(windowedCodeLayout(key(0x7F00, 0, 0), key(0x8100, 0, 0)).has_value());
  EXPECT_FALSE(windowedCodeLayout(key(0, 0x7F01, 0), key(0, 0x8100, 0)).has_value());
  EXPECT_FALSE(windowedCodeLayout(key(0, 0, 5), key(0, 0, 4)).has_value());
}

}  // namespace
}  // namespace twocam::mapping
