#pragma once
/// Files that go with a simulated log: the world sidecar that `twocam simulate` writes beside it
/// (read back by `twocam run` for the map evaluation) and the world's outline for the plots.

#include <string>

#include "sim/world.h"

namespace twocam::sim {

/// "<dir>/<stem>.world.yaml" for a log "<dir>/<stem>.rawlog": the copy of the world file that
/// `twocam simulate` writes beside its log, read back by `twocam run` for the map evaluation.
std::string worldSidecarPath(const std::string& log_path);

/// Top-down outline of every shape as polylines: CSV "shape,name,kind,x_m,y_m".
std::string worldOutlineCsv(const World& world);

}  // namespace twocam::sim
