#pragma once
/// The true slip events of a log and the frame each lands on: from a world file (simulated logs,
/// frame = ceil(time_s x frame rate)) or from the sidecar `twocam import-kitti
/// --synthetic-odometry` writes beside the log (`<stem>.slips.csv`), whose slips were applied at
/// the first frame stamped time_s or more after the first (sim::syntheticOdometry). The run's
/// `slips.*` metrics and `slip_events.csv` are measured against them.

#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"
#include "sim/world.h"

namespace twocam::sim {

struct TrueSlip {
  /// The frame whose odometry step holds the slip; -1 when the log ends before it.
  int32_t frame = -1;
  SlipEvent event;
};

/// A simulated log's slips: frame = ceil(time_s x frame_rate_hz) (the simulator's frame times).
std::vector<TrueSlip> slipsAtFrameRate(const std::vector<SlipEvent>& events, double frame_rate_hz);

/// Slips applied along time stamps t_ns (sim::syntheticOdometry: the first frame k >= 1 with
/// t_ns[k] - t_ns[0] >= time_s).
std::vector<TrueSlip> slipsAtTimes(const std::vector<SlipEvent>& events,
                                   const std::vector<int64_t>& t_ns);

/// "<folder>/<stem>.slips.csv" beside the log at `log_path`.
std::string slipsSidecarPath(const std::string& log_path);

/// CSV "frame,time_s,dx_m,dy_m,dyaw_deg", one row per slip (the run's slip_events.csv too).
std::string slipsCsv(const std::vector<TrueSlip>& slips);

/// Parses slipsCsv's text; errors name `path` and the line (a wrong header or column count, a
/// number that does not parse or is not finite, a frame below -1, a negative time).
[[nodiscard]] Status parseSlipsCsv(const std::string& text,
                                   const std::string& path,
                                   std::vector<TrueSlip>* slips);

/// Reads and parses the file at `path`.
[[nodiscard]] Status loadSlipsCsv(const std::string& path, std::vector<TrueSlip>* slips);

}  // namespace twocam::sim
