#pragma once
/// Voxel keys as sortable integers for OccupancyMapper's batched update, and a ray traversal that
/// emits them directly (internal to the mapping module; docs/mapping.md, "Implementation").
///
/// The batched update applies a frame's voxel updates in one descent of the octree, which needs
/// them in OctoMap's Morton order (child index: x -> bit 0, y -> bit 1, z -> bit 2), where every
/// subtree's voxels are contiguous. A VoxelCodeLayout maps an OcTreeKey to an integer code whose
/// ascending order is that order, with as few bits as the frame allows, so the radix sort needs
/// few passes.

#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

namespace twocam::mapping {

/// Spreads the 16 bits of v to every third bit (bit i -> bit 3 i).
inline uint64_t spreadBits(uint64_t v) {
  v &= 0xFFFFU;
  v = (v | (v << 16U)) & 0x0000FF0000FFULL;
  v = (v | (v << 8U)) & 0x00F00F00F00FULL;
  v = (v | (v << 4U)) & 0x0C30C30C30C3ULL;
  v = (v | (v << 2U)) & 0x249249249249ULL;
  return v;
}

/// OctoMap's 48-bit Morton code of a key: the child index at tree depth d (0 = root's children)
/// is (code >> 3 (15 - d)) & 7.
inline uint64_t mortonCode(const octomap::OcTreeKey& k) {
  return spreadBits(k[0]) | (spreadBits(k[1]) << 1U) | (spreadBits(k[2]) << 2U);
}

/// How a frame's keys map to codes. Two layouts:
///  - full: the 48-bit Morton code (any key).
///  - windowed: for keys that lie, per axis, in the 512 keys from `base` (a multiple of 256).
///    Bits 0-23: the Morton code of the keys' low 8 bits. Bits 24-26: one window bit per axis,
///    set when key - base >= 256. 27 bits in all, so 3 radix passes instead of 5.
///    Why this is Morton order: two keys whose high parts (key >> 8) are equal compare by their
///    low bits, as in the Morton code. Otherwise, per axis the high parts are h = base / 256 or
///    h + 1, which first differ at some bit t; the Morton code compares the keys at the highest
///    differing bit, i.e. on the differing axis with the highest 3 (8 + t) + axis. So the window
///    bits are ranked by 3 t + axis: the axis with the highest t (ties: z, then y, then x) gets
///    bit 26, and the codes compare at the same axis in the same direction.
///    A frame's rays span at most 2 max_range_m / resolution_m + 1 keys per axis (243 with the
///    defaults); with the walk's margin of 2 on each side, at most 256 always fit.
struct VoxelCodeLayout {
  bool windowed = false;
  /// Bits a code uses.
  unsigned bits = 48;
  /// Per axis: first key of the window (0 in the full layout).
  std::array<unsigned, 3> base{};
  /// Per axis: the code bits holding (key - base), lowest first.
  std::array<uint64_t, 3> mask{};
  /// Windowed: position of each axis's window bit (24, 25 or 26).
  std::array<unsigned, 3> window_bit{};
  /// Windowed: the Morton bits of levels 8-15 for each value of the three window bits.
  std::array<uint64_t, 8> high_morton{};
};

/// The full layout.
VoxelCodeLayout fullCodeLayout();

/// The windowed layout covering keys lo[i] <= key[i] <= hi[i] on every axis, or nullopt when
/// some axis's range does not fit in 512 keys from a multiple of 256.
std::optional<VoxelCodeLayout> windowedCodeLayout(const octomap::OcTreeKey& lo,
                                                  const octomap::OcTreeKey& hi);

/// Code of a key, which must lie in the layout's window (windowed).
uint64_t encodeKey(const VoxelCodeLayout& layout, const octomap::OcTreeKey& key);

/// The Morton code (mortonCode) of the key a code stands for.
inline uint64_t toMortonCode(const VoxelCodeLayout& layout, uint64_t code) {
  if (!layout.windowed) return code;
  return layout.high_morton[code >> 24U] | (code & 0xFFFFFFU);
}

/// The voxels that tree.computeRayKeys(origin, end, ray) lists, as codes, in the same order, one
/// per next(): from the origin's voxel up to, excluding, the end voxel; none when both are in one
/// voxel. origin_key and end_key must be tree.coordToKeyChecked of origin and end, and the layout
/// must cover both with a margin of 2 keys per side: like computeRayKeys, the walk may step one
/// voxel past the end voxel's slab when the end lies within rounding of a voxel face, and stops
/// there (never more than one in 4 million probe rays with ends on voxel faces).
///
/// The arithmetic is computeRayKeys' (OcTreeBaseImpl.hxx, Amanatides & Woo), operation for
/// operation and type for type: float direction and length, double tMax / tDelta, the same tie
/// breaking. It differs in stepping the key's code, not the key: a step of +-1 along an axis is
/// an add on that axis's bits with the gaps between them filled with ones (+1) or zeros (-1), so
/// no KeyRay and no per-voxel encoding; and in choosing the axis without branches (see step()).
/// A walk is a small value: OccupancyMapper runs two at a time so that the processor overlaps
/// their dependency chains. tests/mapping/voxel_codes_test.cpp checks walks against
/// computeRayKeys.
class RayCodeWalk {
 public:
  /// A finished walk.
  RayCodeWalk() = default;
  RayCodeWalk(const octomap::OcTree& tree,
              const VoxelCodeLayout& layout,
              const octomap::point3d& origin,
              const octomap::OcTreeKey& origin_key,
              const octomap::point3d& end,
              const octomap::OcTreeKey& end_key) {
    if (origin_key == end_key) return;
    done_ = false;
    end_code_ = encodeKey(layout, end_key);
    code_ = encodeKey(layout, origin_key);

    octomap::point3d direction = end - origin;
    const auto length = static_cast<float>(direction.norm());
    direction /= length;
    length_ = length;
    const double resolution = tree.getResolution();
    for (unsigned i = 0; i < 3; ++i) {
      int step;
      if (direction(i) > 0.0) {
        step = 1;
      } else if (direction(i) < 0.0) {
        step = -1;
      } else {
        step = 0;
      }
      double t_delta;
      if (step != 0) {
        double voxel_border = tree.keyToCoord(origin_key[i]);
        voxel_border += static_cast<float>(step * resolution * 0.5);
        t_max_[i] = (voxel_border - origin(i)) / direction(i);
        t_delta = resolution / std::fabs(direction(i));
      } else {
        t_max_[i] = std::numeric_limits<double>::max();
        t_delta = std::numeric_limits<double>::max();
      }
      const uint64_t m = layout.mask[i];
      const uint64_t lowest = m & (~m + 1U);
      mask_[i] = m;
      part_[i] = code_ & m;
      fill_[i] = step > 0 ? ~m : 0U;
      delta_[i] = step > 0 ? lowest : ~lowest + 1U;  // -lowest
      add_[i][0] = 0.0;
      add_[i][1] = t_delta;
    }
  }

  [[nodiscard]] bool done() const { return done_; }

  /// Writes the next voxel's code and returns true; false when the ray has no more voxels.
  bool next(uint64_t* code) {
    if (done_) return false;
    *code = code_;
    step();
    return true;
  }

 private:
  /// One step of computeRayKeys' loop, with its branch on the smallest t_max
  ///   dim = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2)
  /// turned into masks and table look-ups (those branches mispredict about every other step on
  /// rays of all directions). An axis that does not step adds 0.0, which keeps its t_max.
  void step() {
    const bool x_before_y = t_max_[0] < t_max_[1];
    // On a tie the two are equal, so the smaller is t_max[dim] for either choice.
    const bool step_z = !(std::min(t_max_[0], t_max_[1]) < t_max_[2]);
    const bool step_x = !step_z && x_before_y;
    const bool step_y = !step_z && !x_before_y;
    stepAxis(0, step_x);
    stepAxis(1, step_y);
    stepAxis(2, step_z);
    code_ = part_[0] | part_[1] | part_[2];
    // At the end voxel; or past the end without meeting it (rounding): computeRayKeys stops.
    done_ = code_ == end_code_ ||
            std::min(std::min(t_max_[0], t_max_[1]), t_max_[2]) > static_cast<double>(length_);
  }

  void stepAxis(unsigned i, bool steps) {
    const uint64_t stepped = ((part_[i] | fill_[i]) + delta_[i]) & mask_[i];
    part_[i] ^= (part_[i] ^ stepped) & (uint64_t{0} - static_cast<uint64_t>(steps));
    t_max_[i] += add_[i][steps ? 1 : 0];
  }

  bool done_ = true;
  uint64_t code_ = 0;
  uint64_t end_code_ = 0;
  float length_ = 0.0F;
  double t_max_[3] = {};
  double add_[3][2] = {};  ///< per axis: what t_max gains without and with a step
  uint64_t part_[3] = {};
  uint64_t fill_[3] = {};
  uint64_t delta_[3] = {};
  uint64_t mask_[3] = {};
};

/// Calls visit(code) for each voxel of RayCodeWalk(tree, layout, origin, origin_key, end,
/// end_key), that is of tree.computeRayKeys(origin, end, ray), in order.
template <class Visit>
void visitRayCodes(const octomap::OcTree& tree,
                   const VoxelCodeLayout& layout,
                   const octomap::point3d& origin,
                   const octomap::OcTreeKey& origin_key,
                   const octomap::point3d& end,
                   const octomap::OcTreeKey& end_key,
                   Visit&& visit) {
  RayCodeWalk walk(tree, layout, origin, origin_key, end, end_key);
  uint64_t code;
  while (walk.next(&code)) visit(code);
}

}  // namespace twocam::mapping
