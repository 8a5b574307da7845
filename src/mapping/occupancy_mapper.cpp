#include "mapping/occupancy_mapper.h"

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <utility>

#include "mapping/voxel_codes.h"

namespace twocam::mapping {
namespace {

// An OcTreeKey packed into one integer (16 bits per axis, x most significant), so key sets
// are sorted vectors: no per-frame allocation, and the update order is deterministic.
uint64_t pack(const octomap::OcTreeKey& k) {
  return (static_cast<uint64_t>(k[0]) << 32U) | (static_cast<uint64_t>(k[1]) << 16U) | k[2];
}

octomap::OcTreeKey unpack(uint64_t p) {
  return octomap::OcTreeKey(static_cast<octomap::key_type>((p >> 32U) & 0xFFFFU),
                            static_cast<octomap::key_type>((p >> 16U) & 0xFFFFU),
                            static_cast<octomap::key_type>(p & 0xFFFFU));
}

octomap::point3d toOctomap(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

// An update is (morton code << 1) | hit: sorting puts a voxel's miss right before its hit.
constexpr uint64_t kHitFlag = 1U;

/// Sorts `v` ascending: LSD radix sort on the low `bits` bits of the updates (the others are
/// zero), in 11-bit passes, the buffers reused from frame to frame. The same order as std::sort
/// (equal updates are equal values), so the same map (tested byte for byte against OctoMap's own
/// updates); faster for the thousands of updates of a frame (docs/mapping.md).
void radixSortUpdates(unsigned bits,
                      std::vector<uint64_t>* v,
                      std::vector<uint64_t>* scratch,
                      std::vector<uint32_t>* histograms) {
  constexpr unsigned kBits = 11;
  constexpr size_t kBuckets = size_t{1} << kBits;
  const unsigned passes = (bits + kBits - 1U) / kBits;
  const size_t n = v->size();
  if (n < 2) return;
  scratch->resize(n);
  std::vector<uint32_t>& counts = *histograms;
  counts.assign(kBuckets * passes, 0);
  for (const uint64_t x : *v) {
    for (unsigned p = 0; p < passes; ++p)
      ++counts[p * kBuckets + ((x >> (p * kBits)) & (kBuckets - 1))];
  }
  uint64_t* src = v->data();
  uint64_t* dst = scratch->data();
  for (unsigned p = 0; p < passes; ++p) {
    uint32_t* c = counts.data() + p * kBuckets;
    if (c[(src[0] >> (p * kBits)) & (kBuckets - 1)] == n)
      continue;  // one digit value: nothing to do
    uint32_t sum = 0;
    for (size_t b = 0; b < kBuckets; ++b) {
      const uint32_t count = c[b];
      c[b] = sum;
      sum += count;
    }
    for (size_t i = 0; i < n; ++i) dst[c[(src[i] >> (p * kBits)) & (kBuckets - 1)]++] = src[i];
    std::swap(src, dst);
  }
  if (src != v->data()) std::copy(src, src + n, v->data());
}

/// Multiplicative hash of a code to `bits` bits (Fibonacci hashing: the golden-ratio multiplier
/// spreads neighbouring codes over the table).
size_t hashCode(uint64_t code, unsigned bits) {
  return static_cast<size_t>((code * 0x9E3779B97F4A7C15ULL) >> (64U - bits));
}

/// Marks a table slot as empty: no code has all bits set (codes use at most 48).
constexpr uint64_t kNoCode = ~uint64_t{0};

/// Applies sorted, de-duplicated updates [begin, end) under `node` at `depth` in one descent:
/// each touched node is visited once, inner occupancies are refreshed and nodes pruned on the
/// way back up. Same tree as OctoMap's updateNode(key, occupied, lazy_eval = false) per key
/// (OccupancyOcTreeBase::updateNodeRecurs), without the 16 levels of inner updates per key.
void updateSubtree(octomap::OcTree* tree,
                   octomap::OcTreeNode* node,
                   bool node_just_created,
                   unsigned depth,
                   const uint64_t* begin,
                   const uint64_t* end,
                   float hit_log_odds,
                   float miss_log_odds) {
  const unsigned tree_depth = tree->getTreeDepth();
  if (!node_just_created && !tree->nodeHasChildren(node)) {
    // A known leaf (finest voxel or pruned cube) at a clamping bound that receives only
    // updates pushing against that bound stays as it is: skip it, as OctoMap's updateNode
    // does per key. This spares expanding and re-pruning large free cubes every frame.
    const float log_odds = node->getLogOdds();
    const bool at_min = log_odds <= tree->getClampingThresMinLog();
    const bool at_max = log_odds >= tree->getClampingThresMaxLog();
    if (at_min || at_max) {
      const uint64_t pushing = at_max ? kHitFlag : 0U;
      if (std::all_of(begin, end, [pushing](uint64_t u) { return (u & kHitFlag) == pushing; }))
        return;
    }
  }
  if (depth == tree_depth) {
    assert(end - begin == 1);
    tree->updateNodeLogOdds(node, (*begin & kHitFlag) != 0U ? hit_log_odds : miss_log_odds);
    return;
  }
  // A leaf above the finest level that existed before is a pruned node: expand it first.
  if (!tree->nodeHasChildren(node) && !node_just_created) tree->expandNode(node);
  const unsigned shift = 3U * (tree_depth - 1U - depth) + 1U;
  for (const uint64_t* it = begin; it != end;) {
    const auto child = static_cast<unsigned>((*it >> shift) & 7U);
    const uint64_t* run_end = it + 1;
    while (run_end != end && ((*run_end >> shift) & 7U) == child) ++run_end;
    bool created = false;
    if (!tree->nodeChildExists(node, child)) {
      tree->createNodeChild(node, child);
      created = true;
    }
    updateSubtree(tree,
                  tree->getNodeChild(node, child),
                  created,
                  depth + 1,
                  it,
                  run_end,
                  hit_log_odds,
                  miss_log_odds);
    it = run_end;
  }
  if (!tree->pruneNode(node)) node->updateOccupancyChildren();
}

}  // namespace

OccupancyMapper::OccupancyMapper(const MappingOptions& options)
    : options_(options), tree_(options.resolution_m) {
  const Status st = options.validate();
  TWOCAM_CHECK(st.isOk()) << "invalid MappingOptions: " << st.message();
  tree_.setProbHit(options.prob_hit);
  tree_.setProbMiss(options.prob_miss);
  tree_.setClampingThresMin(options.clamp_min);
  tree_.setClampingThresMax(options.clamp_max);
  tree_.setOccupancyThres(options.occupied_threshold);
}

void OccupancyMapper::insertFrame(const Eigen::Vector3d& camera_origin_w,
                                  const std::vector<Eigen::Vector3d>& points_w) {
  TWOCAM_CHECK(camera_origin_w.allFinite()) << "camera origin " << camera_origin_w.transpose();
  const octomap::point3d origin = toOctomap(camera_origin_w);
  octomap::OcTreeKey origin_key;
  TWOCAM_CHECK(tree_.coordToKeyChecked(origin, origin_key))
      << "camera origin " << camera_origin_w.transpose() << " is outside the octree";

  ++stats_.frames;
  // The frame's end points and the key range of its rays, which picks the code layout.
  ends_.clear();
  octomap::OcTreeKey lo = origin_key;
  octomap::OcTreeKey hi = origin_key;
  const double max_range_sq = options_.max_range_m * options_.max_range_m;
  for (const Eigen::Vector3d& p_w : points_w) {
    if (!p_w.allFinite()) {
      ++stats_.points_invalid;
      continue;
    }
    if ((p_w - camera_origin_w).squaredNorm() > max_range_sq) {
      ++stats_.points_beyond_range;
      continue;
    }
    const octomap::point3d end = toOctomap(p_w);
    octomap::OcTreeKey end_key;
    if (!tree_.coordToKeyChecked(end, end_key)) {
      ++stats_.points_invalid;
      continue;
    }
    ++stats_.points_inserted;
    ends_.push_back({end, end_key});
    for (unsigned i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], end_key[i]);
      hi[i] = std::max(hi[i], end_key[i]);
    }
  }
  // RayCodeWalk needs 2 keys of margin around the rays' end voxels; at the edge of the key space
  // (1.6 km away at 5 cm) the full layout does without.
  constexpr unsigned kRayMargin = 2;
  bool inside = true;
  for (unsigned i = 0; i < 3; ++i) {
    inside = inside && lo[i] >= kRayMargin && hi[i] + kRayMargin <= 0xFFFFU;
    lo[i] = static_cast<octomap::key_type>(std::max<unsigned>(lo[i], kRayMargin) - kRayMargin);
    hi[i] = static_cast<octomap::key_type>(std::min<unsigned>(hi[i] + kRayMargin, 0xFFFFU));
  }
  const std::optional<VoxelCodeLayout> windowed =
      inside ? windowedCodeLayout(lo, hi) : std::nullopt;
  const VoxelCodeLayout layout = windowed ? *windowed : fullCodeLayout();

  // Discretised update (as OctoMap's insertPointCloud(..., discretize = true)): one ray per
  // distinct end voxel, the first point's. The end voxels seen so far are an open-addressing
  // hash set (linear probing, at most half full).
  unsigned end_bits = 6;
  while ((size_t{1} << end_bits) < 2 * ends_.size()) ++end_bits;
  end_table_.assign(size_t{1} << end_bits, kNoCode);
  const size_t end_slot_mask = end_table_.size() - 1;
  // Rays from one origin share their first voxels: a direct-mapped cache of recent miss codes
  // drops most repeats before the sort (a code found there was pushed already; one evicted is
  // pushed again and removed after the sort, so the result does not depend on the cache).
  free_cache_.assign(size_t{1} << kFreeCacheBits, kNoCode);
  updates_.clear();
  rays_.clear();
  for (const EndPoint& e : ends_) {
    const uint64_t code = encodeKey(layout, e.key);
    size_t slot = hashCode(code, end_bits);
    while (end_table_[slot] != kNoCode && end_table_[slot] != code)
      slot = (slot + 1) & end_slot_mask;
    if (end_table_[slot] == code) continue;
    end_table_[slot] = code;
    updates_.push_back((code << 1U) | kHitFlag);
    rays_.push_back(&e);
  }
  if (options_.insert_free_space) {
    const auto push_miss = [this](uint64_t c) {
      uint64_t& cached = free_cache_[hashCode(c, kFreeCacheBits)];
      if (cached == c) return;
      cached = c;
      updates_.push_back(c << 1U);
    };
    // Two walks at a time, each restarted on the next ray when it ends: one walk is a chain of
    // dependent steps, two independent chains keep the processor busy.
    size_t next_ray = 0;
    const auto start_walk = [&]() {
      if (next_ray == rays_.size()) return RayCodeWalk();
      const EndPoint& e = *rays_[next_ray++];
      return RayCodeWalk(tree_, layout, origin, origin_key, e.point, e.key);
    };
    RayCodeWalk a = start_walk();
    RayCodeWalk b = start_walk();
    uint64_t code;
    while (!a.done() || !b.done() || next_ray < rays_.size()) {
      if (a.next(&code)) {
        push_miss(code);
      } else {
        a = start_walk();
      }
      if (b.next(&code)) {
        push_miss(code);
      } else {
        b = start_walk();
      }
    }
  }
  // One update per voxel: keep the last of each run of equal codes, which is the hit when
  // the voxel holds a landmark of this frame (a hit wins over a miss); back to Morton codes
  // for the descent.
  radixSortUpdates(layout.bits + 1U, &updates_, &sort_scratch_, &sort_histograms_);
  size_t kept = 0;
  int64_t hits = 0;
  for (size_t i = 0; i < updates_.size(); ++i) {
    if (i + 1 < updates_.size() && (updates_[i + 1] >> 1U) == (updates_[i] >> 1U)) continue;
    const uint64_t hit = updates_[i] & kHitFlag;
    hits += static_cast<int64_t>(hit);
    updates_[kept++] = (toMortonCode(layout, updates_[i] >> 1U) << 1U) | hit;
  }
  updates_.resize(kept);
  stats_.last_frame_hits = hits;
  stats_.last_frame_misses = static_cast<int64_t>(kept) - hits;
  if (updates_.empty()) return;
  if (tree_.getRoot() == nullptr) {
    // OctoMap creates the root only through its own update path: a zero update of a voxel
    // that gets its hit below does that (a new node starts at log-odds 0 anyway).
    tree_.updateNode(rays_.front()->key, 0.0F, true);
  }
  updateSubtree(&tree_,
                tree_.getRoot(),
                false,
                0,
                updates_.data(),
                updates_.data() + updates_.size(),
                tree_.getProbHitLog(),
                tree_.getProbMissLog());
}

std::vector<Voxel> OccupancyMapper::occupiedVoxels() const {
  return mapping::occupiedVoxels(tree_);
}

std::vector<Voxel> occupiedVoxels(const octomap::OcTree& tree) {
  const unsigned max_depth = tree.getTreeDepth();
  std::vector<std::pair<uint64_t, float>> cells;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const float probability = static_cast<float>(it->getOccupancy());
    if (it.getDepth() == max_depth) {
      cells.emplace_back(pack(it.getKey()), probability);
      continue;
    }
    // A pruned leaf: expand into its finest-resolution voxels (smallest child key first).
    const octomap::OcTreeKey base = it.getIndexKey();
    const unsigned n = 1U << (max_depth - it.getDepth());
    for (unsigned i = 0; i < n; ++i) {
      for (unsigned j = 0; j < n; ++j) {
        for (unsigned k = 0; k < n; ++k) {
          const octomap::OcTreeKey key(static_cast<octomap::key_type>(base[0] + i),
                                       static_cast<octomap::key_type>(base[1] + j),
                                       static_cast<octomap::key_type>(base[2] + k));
          cells.emplace_back(pack(key), probability);
        }
      }
    }
  }
  // Key order is centre order: keyToCoord is increasing in the key.
  std::sort(cells.begin(), cells.end());
  std::vector<Voxel> voxels;
  voxels.reserve(cells.size());
  const double resolution_m = tree.getResolution();
  for (const auto& [packed, probability] : cells) {
    const octomap::OcTreeKey key = unpack(packed);
    Voxel v;
    v.centre_m =
        Eigen::Vector3d(tree.keyToCoord(key[0]), tree.keyToCoord(key[1]), tree.keyToCoord(key[2]));
    v.size_m = resolution_m;
    v.probability = probability;
    voxels.push_back(v);
  }
  return voxels;
}

Status OccupancyMapper::writeBinary(const std::string& path) const {
  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!out) {
      return Status::error("cannot write octomap '" + partial + "': " + std::strerror(errno));
    }
    const bool written = tree_.writeBinaryConst(out);
    out.close();
    if (!written || out.fail()) {
      std::remove(partial.c_str());
      return Status::error("writing octomap '" + partial + "' failed");
    }
  }
  if (std::rename(partial.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(partial.c_str());
    return Status::error("cannot rename '" + partial + "' to '" + path + "': " + reason);
  }
  return Status::ok();
}

}  // namespace twocam::mapping
