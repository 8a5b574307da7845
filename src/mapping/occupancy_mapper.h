#pragma once
/// Occupancy map (OctoMap) built from landmarks. Sensor model: each frame, every landmark
/// observed in it is a ray from the camera origin; the landmark's voxel is a hit and, with
/// MappingOptions::insert_free_space, the voxels the ray crosses before it are misses. Each
/// voxel gets at most one update per frame, a hit winning over a miss. docs/mapping.md.

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"
#include "mapping/options.h"
#include "mapping/voxel.h"

namespace twocam::mapping {

/// Running counters of an OccupancyMapper.
struct MappingStats {
  int64_t frames = 0;
  /// Points whose voxel received a hit (duplicates within one voxel counted each).
  int64_t points_inserted = 0;
  /// Points farther than max_range_m from the camera origin: ignored, no ray.
  int64_t points_beyond_range = 0;
  /// Points with a non-finite coordinate or outside the octree's extent: ignored.
  int64_t points_invalid = 0;
  /// Voxel updates of the last frame: hits and misses after de-duplication.
  int64_t last_frame_hits = 0;
  int64_t last_frame_misses = 0;
};

class OccupancyMapper {
 public:
  /// options must be valid (options.validate().isOk()); aborts (TWOCAM_CHECK) otherwise.
  explicit OccupancyMapper(const MappingOptions& options);

  /// Inserts one frame: camera_origin_w is the left camera centre, points_w the landmarks
  /// observed in this frame, both in the world frame [m]. Points farther than max_range_m
  /// from the origin or non-finite are skipped and counted in stats(). The origin must be
  /// finite and inside the octree (aborts otherwise: it comes from the pose estimate).
  void insertFrame(const Eigen::Vector3d& camera_origin_w,
                   const std::vector<Eigen::Vector3d>& points_w);

  /// Occupied voxels (OctoMap's rule: log-odds >= logit(occupied_threshold)), at the finest
  /// resolution: a leaf that OctoMap pruned into a coarser node is expanded into its
  /// resolution_m voxels, so counts do not depend on pruning. Sorted by centre x, then y, z.
  [[nodiscard]] std::vector<Voxel> occupiedVoxels() const;

  /// Writes the map as an OctoMap binary file (.bt, maximum-likelihood occupied/free bits,
  /// readable by octovis and octomap::OcTree(path)). The data go to "<path>.partial", which
  /// is renamed to path only when complete, so an existing file is never left truncated.
  /// Fails (Status) when the folder is missing or not writable.
  [[nodiscard]] Status writeBinary(const std::string& path) const;

  [[nodiscard]] const MappingStats& stats() const { return stats_; }
  [[nodiscard]] const MappingOptions& options() const { return options_; }
  /// The underlying tree (tests, export). Valid while the mapper lives.
  [[nodiscard]] const octomap::OcTree& tree() const { return tree_; }

 private:
  MappingOptions options_;
  octomap::OcTree tree_;
  MappingStats stats_;
  /// A point of the frame that gets a hit (float, as OctoMap's rays use) and its key.
  struct EndPoint {
    octomap::point3d point;
    octomap::OcTreeKey key;
  };
  /// Slots (log2) of the cache of recent miss codes (insertFrame): 2^14 x 8 bytes = 128 KB stays
  /// in L2 and holds most of an office frame's ~14,000 distinct free voxels; with 2^12 more
  /// repeats reach the sort (office: 1.14 against 1.07 ms per frame in mapping_bench).
  static constexpr unsigned kFreeCacheBits = 14;
  // Scratch buffers reused across frames so insertFrame does not allocate in steady state.
  std::vector<EndPoint> ends_;
  std::vector<const EndPoint*> rays_;  ///< the end points that get a ray (first in their voxel)
  std::vector<uint64_t> end_table_;
  std::vector<uint64_t> free_cache_;
  std::vector<uint64_t> updates_;
  std::vector<uint64_t> sort_scratch_;
  std::vector<uint32_t> sort_histograms_;
};

/// Occupied voxels of any OctoMap tree by the same rule and order as
/// OccupancyMapper::occupiedVoxels() (e.g. a tree read back from a .bt file).
[[nodiscard]] std::vector<Voxel> occupiedVoxels(const octomap::OcTree& tree);

}  // namespace twocam::mapping
