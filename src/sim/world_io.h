#pragma once
/// Reading world files (format: worlds/README.md). Unknown keys and out-of-range values are
/// errors whose message names the key path, e.g. "rig.baseline_m = -0.1: must be > 0".

#include <string>

#include "common/status.h"
#include "sim/world.h"

namespace twocam::sim {

/// Loads, parses and validates a world file. Relative texture paths are resolved against the
/// file's folder and must exist. On error *world is unspecified and the Status says why.
Status loadWorld(const std::string& path, World* world);

/// Same from YAML text; base_dir resolves relative paths.
Status parseWorld(const std::string& yaml_text, const std::string& base_dir, World* world);

/// Loads the `odometry_noise:` section of a noise file (e.g. configs/kitti_odometry_noise.yaml):
/// a YAML document whose only top-level key is `odometry_noise`, with exactly the keys, units,
/// defaults and checks of a world file's section (worlds/README.md; slips included). Used for
/// synthetic odometry on recorded data (`twocam import-kitti --synthetic-odometry`). Errors
/// name the file and the key, unknown keys included.
Status loadOdometryNoise(const std::string& path, OdometryNoiseSpec* noise);

/// Same from YAML text; `source` names the text in errors (e.g. the file path in quotes).
Status parseOdometryNoiseFile(const std::string& yaml_text,
                              const std::string& source,
                              OdometryNoiseSpec* noise);

/// The world file's text with every relative texture `file:` made absolute (resolved against
/// base_dir), so that the copy reads the same from any folder (the `<log>.world.yaml` sidecar
/// written beside a log). Comments and layout are kept. Fails if the text does not parse.
Status selfContainedWorldText(const std::string& yaml_text,
                              const std::string& base_dir,
                              std::string* out);

}  // namespace twocam::sim
