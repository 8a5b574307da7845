#include "simulate_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <vector>

#include "common/stats.h"
#include "common/timer.h"
#include "io/pictures.h"
#include "io/rawlog.h"
#include "progress.h"
#include "sim/simulator.h"
#include "sim/world_files.h"
#include "sim/world_io.h"

namespace twocam::tools {

namespace fs = std::filesystem;

namespace {

int fail(const std::string& message) {
  std::cerr << "twocam simulate: error: " << message << std::endl;
  return 1;
}

/// Absolute, normalised form of a path for comparisons (symlinks resolved where they exist).
fs::path canonicalish(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? fs::absolute(p).lexically_normal() : c;
}

/// Whether `inner` is `outer` or lies under it.
bool within(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

/// Removes staged files on every early return.
struct StagedCleanup {
  std::vector<std::string> paths;
  bool committed = false;
  ~StagedCleanup() {
    if (committed) return;
    std::error_code ec;
    for (const auto& p : paths) fs::remove_all(p, ec);
  }
};

}  // namespace

int runSimulate(const SimulateArgs& args) {
  sim::World world;
  if (Status st = sim::loadWorld(args.world_path, &world); !st) return fail(st.message());
  if (args.seed) world.seed = *args.seed;
  if (args.noise_seed) {
    if (args.seed) return fail("--noise-seed and --seed: give one of them");
    world.texture_seed = world.seed;
    world.seed = *args.noise_seed;
  }
  if (args.odometry_noise_scale) {
    const double f = *args.odometry_noise_scale;
    if (!std::isfinite(f) || f < 0.0) {
      return fail("--odometry-noise-scale " + std::to_string(f) + ": must be a finite number >= 0");
    }
    world.odometry_noise = sim::scaledOdometryNoise(world.odometry_noise, f);
  }
  if (args.start_waypoint) {
    if (Status st = sim::startWaypointStatus(world.robot, *args.start_waypoint); !st)
      return fail("--start-waypoint " + st.message());
    world.robot.start_waypoint = *args.start_waypoint;
  }
  if (args.frames) {
    if (*args.frames < 1)
      return fail("--frames " + std::to_string(*args.frames) + ": must be >= 1");
    world.frames = *args.frames;
  }
  const fs::path out(args.output_path);
  const std::string preview_dir =
      !args.preview_dir.empty() ? args.preview_dir
                                : ((out.has_parent_path() ? out.parent_path() : fs::path(".")) /
                                   (out.stem().string() + "_preview"))
                                      .string();
  const std::string sidecar = sim::worldSidecarPath(args.output_path);
  const std::string images_dir = ((out.has_parent_path() ? out.parent_path() : fs::path(".")) /
                                  (out.stem().string() + "_Images"))
                                     .string();
  const std::vector<std::string> preview_files = {
      "contact_sheet.png", "trajectory.csv", "world_outline.csv", "simulate.json"};

  // Every output path is checked before anything is written: nothing an output would replace
  // may be an input, and no output may be in the way of another kind of file.
  {
    std::vector<fs::path> inputs = {canonicalish(args.world_path)};
    for (const sim::Shape& shape : world.shapes)
      if (!shape.texture.resolved_path.empty())
        inputs.push_back(canonicalish(shape.texture.resolved_path));
    const std::vector<std::pair<std::string, std::string>> outputs = [&] {
      std::vector<std::pair<std::string, std::string>> o = {{args.output_path, "the log (-o)"},
                                                            {images_dir, "the log's image folder"},
                                                            {sidecar, "the log's world copy"}};
      for (const auto& f : preview_files)
        o.push_back({(fs::path(preview_dir) / f).string(), "the preview (--preview-dir)"});
      return o;
    }();
    for (const auto& [path, what] : outputs) {
      const fs::path c = canonicalish(path);
      for (const fs::path& in : inputs) {
        if (within(in, c)) {
          return fail("output '" + path + "' (" + what + ") would overwrite the input '" +
                      in.string() + "'; choose another output path");
        }
      }
    }
    std::error_code ec;
    if (fs::is_directory(args.output_path, ec))
      return fail("output '" + args.output_path + "' is a folder; -o names the log file");
    if (fs::is_directory(sidecar, ec))
      return fail("cannot write '" + sidecar + "': it is a folder");
    if (fs::exists(images_dir, ec) && !fs::is_directory(images_dir, ec))
      return fail("cannot write image folder '" + images_dir + "': a file of that name exists");
    if (fs::exists(preview_dir, ec) && !fs::is_directory(preview_dir, ec))
      return fail("--preview-dir '" + preview_dir + "' is a file, not a folder");
    for (const auto& f : preview_files) {
      if (fs::is_directory(fs::path(preview_dir) / f, ec))
        return fail("cannot write '" + (fs::path(preview_dir) / f).string() + "': it is a folder");
    }
  }

  const Timer setup;
  std::unique_ptr<sim::Simulator> simulator;
  if (Status st = sim::Simulator::create(world, sim::RendererOptions{}, &simulator); !st)
    return fail(st.message());
  io::RawlogWriterOptions wopt;
  const Eigen::AlignedBox3d bounds = sim::worldBounds(world);
  wopt.max_depth_m = std::max(1.0, bounds.diagonal().norm());
  std::unique_ptr<io::RawlogWriter> writer;
  if (Status st = io::RawlogWriter::open(args.output_path, world.rig, wopt, &writer); !st)
    return fail(st.message());
  const double setup_s = setup.elapsedS();

  const int n = world.frames;
  const int sheet_rows = std::min(4, n);
  std::vector<int> sheet_frames;
  for (int k = 0; k < sheet_rows; ++k)
    sheet_frames.push_back(sheet_rows == 1 ? 0 : k * (n - 1) / (sheet_rows - 1));
  std::vector<io::ContactSheetRow> sheet;
  std::ostringstream traj;
  traj << "frame,t_s,true_x_m,true_y_m,true_yaw_rad,odom_x_m,odom_y_m,odom_yaw_rad\n";
  std::vector<double> render_ms, depth_ms, sim_ms, write_ms;
  long unresolved = 0;

  ProgressBar bar("simulate " + world.name, n, !args.quiet);
  const Timer loop;
  sim::SimFrame frame;
  for (int k = 0; k < n; ++k) {
    Timer stage;
    simulator->next(&frame);
    sim_ms.push_back(stage.elapsedMs());
    stage.restart();
    if (Status st = writer->write(frame.stereo, &frame.odometry, &frame.ground_truth); !st)
      return fail(st.message());
    write_ms.push_back(stage.elapsedMs());
    render_ms.push_back(frame.render_stats.ms_render);
    depth_ms.push_back(frame.render_stats.ms_depth);
    unresolved += frame.render_stats.pixels_unresolved;
    const Eigen::Isometry3d& T = frame.ground_truth.T_w_b;
    const double true_yaw = std::atan2(T.linear()(1, 0), T.linear()(0, 0));
    char line[256];
    std::snprintf(line,
                  sizeof(line),
                  "%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n",
                  k,
                  (frame.stereo.t_ns - sim::kStartTimeNs) * 1e-9,
                  T.translation().x(),
                  T.translation().y(),
                  true_yaw,
                  frame.odometry.pose.x_m,
                  frame.odometry.pose.y_m,
                  frame.odometry.pose.yaw_rad);
    traj << line;
    if (std::find(sheet_frames.begin(), sheet_frames.end(), k) != sheet_frames.end()) {
      sheet.push_back({"frame " + std::to_string(k),
                       frame.stereo.left,
                       frame.stereo.right,
                       frame.ground_truth.depth_left});
    }
    bar.update(k + 1);
  }
  // Timed up to here: moving the finished log into place (and deleting an older log's image
  // folder it replaces) is not per-frame work.
  const double loop_s = loop.elapsedS();
  if (Status st = writer->close(); !st) return fail(st.message());
  const double fps = n / loop_s;

  // Everything is staged under ".partial" names first and swapped in together at the end, so
  // that a failure leaves the previous log, its images, world copy and preview as they were.
  StagedCleanup staged;
  std::vector<io::StagedMove> moves = writer->stagedMoves();
  // The world file travels with the log ("<stem>.world.yaml") so that `twocam run` can measure
  // its map against the world's geometry (phantom voxels) without being told where it came from.
  // Texture paths are made absolute so that the copy reads the same from the log's folder.
  {
    std::ifstream in(args.world_path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in) return fail("cannot read '" + args.world_path + "'");
    std::string self_contained;
    if (Status st = sim::selfContainedWorldText(text.str(), world.base_dir, &self_contained); !st)
      return fail("cannot copy the world file beside the log: " + st.message());
    const std::string tmp = sidecar + ".partial";
    staged.paths.push_back(tmp);
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << "# Copy of " << args.world_path << " written by twocam simulate beside "
      << out.filename().string() << " (seed " << world.seed << "); texture paths made absolute.\n"
      << self_contained;
    f.close();
    if (!f) return fail("cannot write '" + tmp + "'");
    moves.push_back({tmp, sidecar});
  }

  std::error_code ec;
  fs::create_directories(preview_dir, ec);
  if (ec) return fail("cannot create preview folder '" + preview_dir + "': " + ec.message());
  const auto stage_preview = [&](const std::string& name) {
    const std::string final_path = (fs::path(preview_dir) / name).string();
    // The extension stays last: OpenCV picks the image format from it.
    const std::string tmp = (fs::path(preview_dir) / (".partial_" + name)).string();
    staged.paths.push_back(tmp);
    moves.push_back({tmp, final_path});
    return tmp;
  };
  if (Status st = io::writeContactSheet(sheet, stage_preview("contact_sheet.png")); !st)
    return fail(st.message());
  {
    const std::string path = stage_preview("trajectory.csv");
    std::ofstream f(path);
    f << traj.str();
    if (!f) return fail("cannot write '" + path + "'");
  }
  {
    const std::string path = stage_preview("world_outline.csv");
    std::ofstream f(path);
    f << sim::worldOutlineCsv(world);
    if (!f) return fail("cannot write '" + path + "'");
  }
  {
    const std::string path = stage_preview("simulate.json");
    std::ofstream f(path);
    f << "{\n  \"world\": \"" << world.name << "\",\n  \"world_file\": \"" << args.world_path
      << "\",\n  \"seed\": " << world.seed
      << ",\n  \"odometry_noise_scale\": " << args.odometry_noise_scale.value_or(1.0)
      << ",\n  \"start_waypoint\": " << world.robot.start_waypoint << ",\n  \"frames\": " << n
      << ",\n  \"width_px\": " << world.rig.width_px
      << ",\n  \"height_px\": " << world.rig.height_px << ",\n  \"setup_s\": " << setup_s
      << ",\n  \"loop_s\": " << loop_s << ",\n  \"frames_per_s\": " << fps
      << ",\n  \"render_ms_median\": " << median(render_ms)
      << ",\n  \"gt_depth_ms_median\": " << median(depth_ms)
      << ",\n  \"simulate_ms_median\": " << median(sim_ms)
      << ",\n  \"write_ms_median\": " << median(write_ms)
      << ",\n  \"gt_depth_unresolved_pixels\": " << unresolved << "\n}\n";
    if (!f) return fail("cannot write '" + path + "'");
  }
  if (Status st = io::commitStaged(moves); !st) return fail(st.message());
  staged.committed = true;
  writer->release();
  std::printf("wrote %d stereo frames with odometry and ground truth to %s (images in %s)\n",
              n,
              args.output_path.c_str(),
              writer->imagesDir().c_str());
  std::printf(
      "%.1f frames/s including writing (%.2f s for %d frames; setup %.2f s; render %.1f ms, GT "
      "depth %.1f ms median)\n",
      fps,
      loop_s,
      n,
      setup_s,
      median(render_ms),
      median(depth_ms));
  std::printf("world geometry for evaluation: %s\n",
              sim::worldSidecarPath(args.output_path).c_str());
  std::printf("preview: %s/contact_sheet.png, %s/trajectory.csv\n",
              preview_dir.c_str(),
              preview_dir.c_str());
  return 0;
}

}  // namespace twocam::tools
