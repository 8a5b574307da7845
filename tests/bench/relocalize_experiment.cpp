// Relocalisation experiment (issue 25; docs/experiments/2026-12-03-relocalization.md).
//
// For each world (office, garden): a map from log 1 (the world's default seed and start):
// every 5th frame, the frontend's best left-right-consistent hypothesis per corner,
// triangulated with the TRUE camera pose, with its ORB and patch descriptors (one landmark per
// 5 cm voxel, the first seen). Then 20 second logs, simulated in-process: start waypoint
// t % 4 and seed 1000 + t, each skipping (t / 4) * 15 frames first so the 20 trials start at 20
// different places; each of the next 10 frames is relocalised in the map with each descriptor.
// A trial succeeds when a frame is accepted within those 10 and the accepted pose is within
// 5 cm / 1 degree of the truth; an accepted pose outside that is a wrong relocalisation.
// Wrong place: 20 frames of one world (every 15th of its log 1) against the other's map.
//
// Usage: relocalize_experiment WORLDS_DIR [trials]   (prints one table per world)

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "common/rig.h"
#include "common/stats.h"
#include "frontend/descriptors.h"
#include "frontend/frontend.h"
#include "localization/relocalize.h"
#include "sim/simulator.h"
#include "sim/world_io.h"

namespace {

using twocam::StereoRig;
using twocam::frontend::DescribedCorners;
using twocam::frontend::DescriptorKind;
using twocam::localization::MapLandmark;
using twocam::localization::RelocalizationPoint;

constexpr int kMapEvery = 5;
constexpr double kVoxelM = 0.05;
constexpr int kAttemptFrames = 10;
constexpr int kOffsetStepFrames = 15;
constexpr double kMaxErrorM = 0.05;
constexpr double kMaxErrorDeg = 1.0;
constexpr int kWrongPlaceFrames = 20;
constexpr int kWrongPlaceStep = 15;

const DescriptorKind kKinds[] = {DescriptorKind::kOrb, DescriptorKind::kPatch};

/// The frame's stereo points (best hypothesis, left-right consistent) with both descriptors.
struct FramePoints {
  std::vector<Eigen::Vector3d> uvd;
  std::array<std::vector<RelocalizationPoint>, 2> points;  // per kind; uvd index in `index`
  std::array<std::vector<size_t>, 2> index;
  std::array<double, 2> describe_ms{};
};

FramePoints framePoints(twocam::frontend::Frontend* frontend, const twocam::StereoFrame& frame) {
  twocam::StereoHypotheses hyp;
  if (twocam::Status s = frontend->process(frame, &hyp); !s) {
    std::fprintf(stderr, "frontend: %s\n", s.message().c_str());
    std::exit(1);
  }
  FramePoints out;
  std::vector<twocam::Corner> corners;
  for (const twocam::SalientPoint& p : hyp.points) {
    for (uint32_t k = 0; k < p.num_hypotheses; ++k) {
      const twocam::DisparityHypothesis& h = hyp.hypotheses[p.first_hypothesis + k];
      if (h.rank != 0 || !h.lr_consistent || h.d_px <= 0.0f) continue;
      corners.push_back(p.corner);
      out.uvd.emplace_back(p.corner.u_px, p.corner.v_px, h.d_px);
    }
  }
  for (int kind = 0; kind < 2; ++kind) {
    twocam::frontend::DescriptorOptions o;
    o.kind = kKinds[kind];
    DescribedCorners d;
    const auto t0 = std::chrono::steady_clock::now();
    if (twocam::Status s = twocam::frontend::describeCorners(frame.left, corners, o, &d); !s) {
      std::fprintf(stderr, "descriptors: %s\n", s.message().c_str());
      std::exit(1);
    }
    out.describe_ms[kind] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    for (size_t k = 0; k < d.kept.size(); ++k) {
      const Eigen::Vector3d& p = out.uvd[d.kept[k]];
      out.points[kind].push_back({p.x(), p.y(), p.z(), d.descriptors[k]});
      out.index[kind].push_back(d.kept[k]);
    }
  }
  return out;
}

twocam::sim::World loadWorld(const std::string& path) {
  twocam::sim::World world;
  if (twocam::Status s = twocam::sim::loadWorld(path, &world); !s) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    std::exit(1);
  }
  return world;
}

std::unique_ptr<twocam::sim::Simulator> simulator(const twocam::sim::World& world) {
  std::unique_ptr<twocam::sim::Simulator> sim;
  if (twocam::Status s =
          twocam::sim::Simulator::create(world, twocam::sim::RendererOptions{}, &sim);
      !s) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    std::exit(1);
  }
  return sim;
}

struct WorldMap {
  StereoRig rig;
  std::array<std::vector<MapLandmark>, 2> landmarks;  // per kind
  /// Frames kept for the wrong-place check (every kWrongPlaceStep-th frame of log 1).
  std::vector<FramePoints> probe_frames;
};

WorldMap buildMap(const twocam::sim::World& world) {
  WorldMap m;
  m.rig = world.rig;
  auto sim = simulator(world);
  twocam::frontend::Frontend frontend{twocam::frontend::FrontendOptions{}};
  std::map<std::tuple<int64_t, int64_t, int64_t>, bool> voxels[2];
  twocam::sim::SimFrame frame;
  for (int k = 0; k < world.frames; ++k) {
    sim->next(&frame);
    const bool map_frame = k % kMapEvery == 0;
    const bool probe =
        k % kWrongPlaceStep == 0 && static_cast<int>(m.probe_frames.size()) < kWrongPlaceFrames;
    if (!map_frame && !probe) continue;
    FramePoints fp = framePoints(&frontend, frame.stereo);
    if (map_frame) {
      const Eigen::Isometry3d T_w_cl = frame.ground_truth.T_w_b * world.rig.T_b_cl;
      for (int kind = 0; kind < 2; ++kind) {
        for (const RelocalizationPoint& p : fp.points[kind]) {
          const auto p_cl =
              twocam::triangulateRectified(world.rig, Eigen::Vector2d(p.u_px, p.v_px), p.d_px);
          if (!p_cl) continue;
          const Eigen::Vector3d p_w = T_w_cl * *p_cl;
          const auto key = std::make_tuple(static_cast<int64_t>(std::floor(p_w.x() / kVoxelM)),
                                           static_cast<int64_t>(std::floor(p_w.y() / kVoxelM)),
                                           static_cast<int64_t>(std::floor(p_w.z() / kVoxelM)));
          if (!voxels[kind].emplace(key, true).second) continue;
          m.landmarks[kind].push_back(
              {static_cast<uint64_t>(m.landmarks[kind].size()), p_w, p.descriptor});
        }
      }
    }
    if (probe) m.probe_frames.push_back(std::move(fp));
  }
  return m;
}

/// The default options, or overrides for exploring them: RELOC_RATIO, RELOC_SAME_PLACE_M,
/// RELOC_MIN_INLIERS, RELOC_MIN_VERIFIED_FRACTION.
twocam::localization::RelocalizationOptions experimentOptions() {
  twocam::localization::RelocalizationOptions o;
  if (const char* v = std::getenv("RELOC_RATIO")) o.ratio = std::atof(v);
  if (const char* v = std::getenv("RELOC_SAME_PLACE_M")) o.same_place_m = std::atof(v);
  if (const char* v = std::getenv("RELOC_MIN_INLIERS")) o.min_inliers = std::atoi(v);
  if (const char* v = std::getenv("RELOC_MIN_VERIFIED_FRACTION"))
    o.min_verified_fraction = std::atof(v);
  if (twocam::Status s = o.validate(); !s) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    std::exit(2);
  }
  return o;
}

double angleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

struct KindStats {
  int trials = 0, success = 0, wrong = 0, never = 0;
  std::vector<double> first_frame, err_m, err_deg, attempt_ms, describe_ms, inliers, verified;
};

void printStats(const char* kind, const KindStats& s) {
  auto mx = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  };
  std::printf(
      "  %-5s relocalised within %d frames: %d/%d (%.0f %%); wrong poses accepted: %d; never: "
      "%d\n",
      kind,
      kAttemptFrames,
      s.success,
      s.trials,
      s.trials ? 100.0 * s.success / s.trials : 0.0,
      s.wrong,
      s.never);
  std::printf(
      "        first accepted frame median %.1f max %.0f; error median %.2f cm max %.2f cm, "
      "median %.3f deg max %.3f deg\n",
      twocam::median(s.first_frame),
      mx(s.first_frame),
      100.0 * twocam::median(s.err_m),
      100.0 * mx(s.err_m),
      twocam::median(s.err_deg),
      mx(s.err_deg));
  std::printf(
      "        per attempt: relocalize %.1f ms median (max %.1f), descriptors %.2f ms median; "
      "inliers median %.0f, verified median %.0f\n",
      twocam::median(s.attempt_ms),
      mx(s.attempt_ms),
      twocam::median(s.describe_ms),
      twocam::median(s.inliers),
      twocam::median(s.verified));
}

void runWorld(const std::string& name,
              const twocam::sim::World& world,
              const WorldMap& map,
              int trials) {
  std::printf("%s: map of %zu (orb) / %zu (patch) landmarks from %d frames\n",
              name.c_str(),
              map.landmarks[0].size(),
              map.landmarks[1].size(),
              (world.frames + kMapEvery - 1) / kMapEvery);
  KindStats stats[2];
  const int n_waypoints = static_cast<int>(world.robot.waypoints.size());
  const twocam::localization::RelocalizationOptions options = experimentOptions();
  const char* only_trial = std::getenv("RELOC_TRIAL");  // exploring one trial
  for (int t = 0; t < trials; ++t) {
    if (only_trial != nullptr && std::atoi(only_trial) != t) continue;
    twocam::sim::World w2 = world;
    w2.robot.start_waypoint = t % n_waypoints;
    w2.texture_seed = world.seed;  // the same world, other noise
    w2.seed = 1000 + static_cast<uint64_t>(t);
    const int offset = (t / n_waypoints) * kOffsetStepFrames;
    auto sim = simulator(w2);
    twocam::frontend::Frontend frontend{twocam::frontend::FrontendOptions{}};
    twocam::sim::SimFrame frame;
    int first[2] = {-1, -1};
    bool wrong[2] = {false, false};
    for (int k = 0; k < offset + kAttemptFrames; ++k) {
      sim->next(&frame);
      if (k < offset) continue;
      if (first[0] >= 0 && first[1] >= 0) break;
      const FramePoints fp = framePoints(&frontend, frame.stereo);
      const Eigen::Isometry3d T_w_cl = frame.ground_truth.T_w_b * world.rig.T_b_cl;
      for (int kind = 0; kind < 2; ++kind) {
        if (first[kind] >= 0) continue;
        twocam::localization::RelocalizationResult r;
        const auto t0 = std::chrono::steady_clock::now();
        if (twocam::Status s = twocam::localization::relocalize(
                map.rig, fp.points[kind], map.landmarks[kind], options, &r);
            !s) {
          std::fprintf(stderr, "relocalize: %s\n", s.message().c_str());
          std::exit(1);
        }
        stats[kind].attempt_ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
        stats[kind].describe_ms.push_back(fp.describe_ms[kind]);
        if (std::getenv("RELOC_VERBOSE") != nullptr) {
          // Matches that the true pose confirms (landmark projects within 3 px of the point).
          int true_matches = 0;
          for (const auto& m : r.matches) {
            const Eigen::Vector3d p_cl = T_w_cl.inverse() * map.landmarks[kind][m.landmark].p_m;
            const RelocalizationPoint& f = fp.points[kind][m.point];
            if (p_cl.z() > 0 &&
                std::hypot(map.rig.fx_px * p_cl.x() / p_cl.z() + map.rig.cx_px - f.u_px,
                           map.rig.fy_px * p_cl.y() / p_cl.z() + map.rig.cy_px - f.v_px) < 3.0)
              ++true_matches;
          }
          std::printf("    true matches %d; T_w_b %.3f %.3f\n",
                      true_matches,
                      frame.ground_truth.T_w_b.translation().x(),
                      frame.ground_truth.T_w_b.translation().y());
          std::printf(
              "    frame %d %s: sigma %.3f m, %zu points, %zu matches, %d inliers, %d/%d verified, "
              "%d agree: %s\n",
              k - offset,
              kind == 0 ? "orb" : "patch",
              r.position_sigma_m,
              fp.points[kind].size(),
              r.matches.size(),
              r.inliers,
              r.verified,
              r.checked,
              r.points_agreeing,
              r.found ? "found" : r.reason.c_str());
        }
        if (!r.found) continue;
        first[kind] = k - offset;
        const double e_m = (r.T_m_cl.translation() - T_w_cl.translation()).norm();
        const double e_deg = angleDeg(r.T_m_cl, T_w_cl);
        stats[kind].first_frame.push_back(first[kind]);
        stats[kind].err_m.push_back(e_m);
        stats[kind].err_deg.push_back(e_deg);
        stats[kind].inliers.push_back(r.inliers);
        stats[kind].verified.push_back(r.verified);
        wrong[kind] = e_m > kMaxErrorM || e_deg > kMaxErrorDeg;
        if (wrong[kind]) {
          std::printf(
              "    %s accepted a wrong pose at frame %d: %.3f m, %.2f deg off; %d inliers, "
              "%d agree, %d/%d verified (fraction %.2f), position sigma %.3f m\n",
              kind == 0 ? "orb" : "patch",
              first[kind],
              e_m,
              e_deg,
              r.inliers,
              r.points_agreeing,
              r.verified,
              r.checked,
              r.verified_fraction,
              r.position_sigma_m);
        }
      }
    }
    for (int kind = 0; kind < 2; ++kind) {
      ++stats[kind].trials;
      if (first[kind] < 0) {
        ++stats[kind].never;
      } else if (wrong[kind]) {
        ++stats[kind].wrong;
      } else {
        ++stats[kind].success;
      }
    }
    std::printf("  trial %2d: start waypoint %d, seed %d, offset %2d frames: orb %s, patch %s\n",
                t,
                w2.robot.start_waypoint,
                static_cast<int>(w2.seed),
                offset,
                first[0] < 0 ? "never" : (wrong[0] ? "WRONG" : std::to_string(first[0]).c_str()),
                first[1] < 0 ? "never" : (wrong[1] ? "WRONG" : std::to_string(first[1]).c_str()));
    std::fflush(stdout);
  }
  printStats("orb", stats[0]);
  printStats("patch", stats[1]);
}

void wrongPlace(const std::string& frames_of,
                const WorldMap& frames_world,
                const std::string& map_of,
                const WorldMap& map) {
  const twocam::localization::RelocalizationOptions options = experimentOptions();
  for (int kind = 0; kind < 2; ++kind) {
    int accepted = 0, max_inliers = 0, max_verified = 0;
    size_t max_matches = 0;
    for (const FramePoints& fp : frames_world.probe_frames) {
      twocam::localization::RelocalizationResult r;
      if (twocam::Status s = twocam::localization::relocalize(
              frames_world.rig, fp.points[kind], map.landmarks[kind], options, &r);
          !s) {
        std::fprintf(stderr, "relocalize: %s\n", s.message().c_str());
        std::exit(1);
      }
      accepted += r.found ? 1 : 0;
      max_inliers = std::max(max_inliers, r.inliers);
      max_matches = std::max(max_matches, r.matches.size());
      max_verified = std::max(max_verified, r.verified);
    }
    std::printf(
        "wrong place: %zu frames of %s against the %s map, %s: %d accepted (most matches %zu, "
        "most inliers %d, most verified %d)\n",
        frames_world.probe_frames.size(),
        frames_of.c_str(),
        map_of.c_str(),
        kind == 0 ? "orb" : "patch",
        accepted,
        max_matches,
        max_inliers,
        max_verified);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s WORLDS_DIR [trials] [worlds...]\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  const int trials = argc > 2 ? std::atoi(argv[2]) : 20;
  std::vector<std::string> names = {"office", "garden"};
  if (const char* only = std::getenv("RELOC_ONLY")) names = {only};  // exploring one world
  std::vector<std::string> others;
  for (int i = 3; i < argc; ++i) others.push_back(argv[i]);
  std::map<std::string, WorldMap> maps;
  std::map<std::string, twocam::sim::World> worlds;
  for (const std::string& n : names) {
    worlds[n] = loadWorld(dir + "/" + n + ".yaml");
    maps[n] = buildMap(worlds[n]);
  }
  for (const std::string& n : names) runWorld(n, worlds[n], maps[n], trials);
  if (names.size() == 2) {
    wrongPlace("garden", maps["garden"], "office", maps["office"]);
    wrongPlace("office", maps["office"], "garden", maps["garden"]);
  }
  for (const std::string& n : others) {
    const WorldMap m = buildMap(loadWorld(dir + "/" + n + ".yaml"));
    wrongPlace(n, m, "office", maps["office"]);
  }
  return 0;
}
