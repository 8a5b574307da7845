#pragma once
/// Exports of the confirmed landmarks to formats other tools read: a PLY point cloud (MeshLab,
/// CloudCompare) and an MRPT points map (mrpt::maps::CSimplePointsMap's own text format, which
/// CPointsMap::load3D_from_text_file reads back). Positions in the map frame [m].
///
/// Every export is written to a temporary file beside the target and renamed into place, so the
/// target is either the complete new file or left as it was.

#include <string>
#include <vector>

#include "common/status.h"
#include "store/landmark_store.h"

namespace twocam::store {

enum class PlyFormat { kBinaryLittleEndian, kAscii };

/// PLY with one vertex per landmark: `double x, y, z` [m] and `float confidence`, in id order.
[[nodiscard]] Status exportPly(const std::vector<StoredLandmark>& landmarks,
                               const std::string& path,
                               PlyFormat format = PlyFormat::kBinaryLittleEndian);
/// Every landmark of the store (loadAll()).
[[nodiscard]] Status exportPly(const LandmarkStore& store,
                               const std::string& path,
                               PlyFormat format = PlyFormat::kBinaryLittleEndian);

/// The positions as an mrpt::maps::CSimplePointsMap saved with save3D_to_text_file ("x y z" per
/// line; MRPT keeps points as float, so about 7 significant digits).
[[nodiscard]] Status exportMrptPointsMap(const std::vector<StoredLandmark>& landmarks,
                                         const std::string& path);
[[nodiscard]] Status exportMrptPointsMap(const LandmarkStore& store, const std::string& path);

}  // namespace twocam::store
