#pragma once
/// Pictures a person looks at, drawn with OpenCV (plots with axes are made by
/// scripts/*.py with matplotlib from the CSV/JSON outputs).

#include <string>
#include <vector>

#include "common/image.h"
#include "common/status.h"

namespace twocam::io {

struct ContactSheetRow {
  std::string label;
  ImageU8 left;
  ImageU8 right;
  /// Optional ground-truth depth [m] (0 = none), drawn colour-coded.
  ImageF32 depth;
};

/// Writes a PNG with one row per entry: left | right | depth, each scaled by `scale`.
Status writeContactSheet(const std::vector<ContactSheetRow>& rows,
                         const std::string& path,
                         double scale = 0.5);

}  // namespace twocam::io
