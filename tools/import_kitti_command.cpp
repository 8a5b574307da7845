#include "import_kitti_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <vector>

#include "common/stats.h"
#include "common/timer.h"
#include "frontend/cv_interop.h"
#include "io/kitti.h"
#include "io/rawlog.h"
#include "io/run_writer.h"
#include "progress.h"
#include "sim/slip_truth.h"
#include "sim/wheel_odometry.h"
#include "sim/world_io.h"

namespace twocam::tools {

namespace fs = std::filesystem;

namespace {

int fail(std::string message) {
  // One line, whatever the library put into the message.
  std::replace(message.begin(), message.end(), '\n', ' ');
  std::cerr << "twocam import-kitti: error: " << message << std::endl;
  return 1;
}

Status loadImage(const std::string& path, const StereoRig& rig, ImageU8* image) {
  if (Status st = frontend::loadGrey(path, image); !st) return st;
  if (image->width != rig.width_px || image->height != rig.height_px) {
    std::ostringstream os;
    os << "image '" << path << "' is " << image->width << "x" << image->height
       << " px but the sequence's first left image is " << rig.width_px << "x" << rig.height_px;
    return Status::error(os.str());
  }
  return Status::ok();
}

/// The effective noise model in one line, so that the log's header says exactly what was drawn
/// (the file may change after the import).
std::string describeNoise(const sim::OdometryNoiseSpec& n) {
  std::ostringstream os;
  os << "sigma_per_m " << n.sigma_per_m << ", sigma_per_rad " << n.sigma_per_rad << ", scale_error "
     << n.scale_error << ", wheel_base_error " << n.wheel_base_error
     << ", slips (time_s dx_m dy_m dyaw_deg) [";
  for (size_t i = 0; i < n.slips.size(); ++i) {
    const sim::SlipEvent& s = n.slips[i];
    os << (i > 0 ? "; " : "") << s.time_s << " " << s.dx_m << " " << s.dy_m << " "
       << s.dyaw_rad * 180.0 / M_PI;
  }
  os << "]";
  return os.str();
}

double pathLength(const std::vector<Eigen::Isometry3d>& T_w_b) {
  double s = 0.0;
  for (size_t k = 1; k < T_w_b.size(); ++k)
    s += (T_w_b[k].translation() - T_w_b[k - 1].translation()).norm();
  return s;
}

}  // namespace

int runImportKitti(const ImportKittiArgs& args) {
  const Timer total;
  if (args.max_frames && *args.max_frames < 1)
    return fail("--max-frames " + std::to_string(*args.max_frames) + ": must be >= 1");
  if (args.seed && !args.synthetic_odometry)
    return fail("--seed " + std::to_string(*args.seed) + " needs --synthetic-odometry NOISE.yaml");
  const uint64_t seed = args.seed.value_or(ImportKittiArgs::kDefaultSeed);
  std::error_code ec;
  if (fs::is_directory(args.output_path, ec))
    return fail("output '" + args.output_path + "' is a folder; give a .rawlog file path");

  io::KittiReadOptions read_options;
  read_options.max_frames = args.max_frames;
  io::KittiSequence seq;
  if (Status st = io::loadKittiSequence(args.input_dir, &seq, read_options); !st)
    return fail(st.message());
  const int n = static_cast<int>(seq.left_paths.size());

  // Synthetic odometry is computed up front: a bad noise file fails before anything is written.
  std::vector<Pose2> odometry;
  std::vector<sim::TrueSlip> true_slips;
  io::RawlogWriterOptions writer_options;
  if (args.synthetic_odometry) {
    sim::OdometryNoiseSpec noise;
    if (Status st = sim::loadOdometryNoise(*args.synthetic_odometry, &noise); !st)
      return fail(st.message());
    if (seq.T_w_b.empty()) {
      return fail("--synthetic-odometry draws from the ground truth, but '" + args.input_dir +
                  "' has no poses.txt");
    }
    odometry = sim::syntheticOdometry(seq.t_ns, seq.T_w_b, noise, seed);
    true_slips = sim::slipsAtTimes(noise.slips, seq.t_ns);
    writer_options.synthetic_odometry = "drawn from the ground truth with the odometry_noise of " +
                                        *args.synthetic_odometry + " (" + describeNoise(noise) +
                                        "), seed " + std::to_string(seed);
  }

  // The writer goes through "<output>.partial" and removes it when destroyed unfinished, so
  // every early return below leaves no log and keeps an older one at the output path.
  std::unique_ptr<io::RawlogWriter> writer;
  if (Status st = io::RawlogWriter::open(args.output_path, seq.rig, writer_options, &writer); !st)
    return fail(st.message());

  std::vector<double> load_ms;
  std::vector<double> write_ms;
  ProgressBar bar("import-kitti", n, !args.quiet);
  StereoFrame frame;
  for (int k = 0; k < n; ++k) {
    Timer stage;
    const size_t i = static_cast<size_t>(k);
    if (Status st = loadImage(seq.left_paths[i], seq.rig, &frame.left); !st)
      return fail("frame " + std::to_string(k) + ": " + st.message());
    if (Status st = loadImage(seq.right_paths[i], seq.rig, &frame.right); !st)
      return fail("frame " + std::to_string(k) + ": " + st.message());
    load_ms.push_back(stage.elapsedMs());
    stage.restart();
    frame.t_ns = seq.t_ns[i];
    OdometrySample odo;
    if (!odometry.empty()) odo = OdometrySample{frame.t_ns, odometry[i]};
    GroundTruthFrame gt;
    if (!seq.T_w_b.empty()) {
      gt.t_ns = frame.t_ns;
      gt.T_w_b = seq.T_w_b[i];
    }
    if (Status st = writer->write(
            frame, odometry.empty() ? nullptr : &odo, seq.T_w_b.empty() ? nullptr : &gt);
        !st)
      return fail(st.message());
    write_ms.push_back(stage.elapsedMs());
    bar.update(k + 1);
  }
  if (Status st = writer->finish(); !st) return fail(st.message());
  // The slips the synthetic odometry holds, beside the log for `twocam run`'s slip metrics; a
  // sidecar of an earlier log at this path no longer describes it.
  const std::string slips_path = sim::slipsSidecarPath(args.output_path);
  if (args.synthetic_odometry) {
    if (Status st = io::writeFileAtomically(slips_path, sim::slipsCsv(true_slips)); !st)
      return fail(st.message());
  } else {
    std::filesystem::remove(slips_path, ec);
  }
  const double total_s = total.elapsedS();

  const StereoRig& rig = seq.rig;
  std::printf("imported %d of %d stereo pairs from %s into %s (images in %s)\n",
              n,
              seq.pairs_available,
              args.input_dir.c_str(),
              args.output_path.c_str(),
              writer->imagesDir().c_str());
  std::printf(
      "rectified rig (%s, %s): %dx%d px, fx = %.3f px, fy = %.3f px, cx = %.3f px, cy = %.3f px, "
      "baseline = %.4f m; left camera at the body origin, looking along body x\n",
      fs::path(seq.left_dir).filename().c_str(),
      fs::path(seq.right_dir).filename().c_str(),
      rig.width_px,
      rig.height_px,
      rig.fx_px,
      rig.fy_px,
      rig.cx_px,
      rig.cy_px,
      rig.baseline_m);
  const double duration_s = static_cast<double>(seq.t_ns.back() - seq.t_ns.front()) * 1e-9;
  std::printf("time stamps: %s, %.2f s\n",
              seq.has_times ? "times.txt" : "10 Hz (no times.txt)",
              duration_s);
  if (seq.T_w_b.empty()) {
    std::printf("ground truth: none (no poses.txt)\n");
  } else {
    const Eigen::Vector3d end = seq.T_w_b.back().translation();
    std::printf(
        "ground truth: %zu body poses from poses.txt, %.2f m travelled, last at (%.2f, %.2f, "
        "%.2f) m\n",
        seq.T_w_b.size(),
        pathLength(seq.T_w_b),
        end.x(),
        end.y(),
        end.z());
  }
  if (odometry.empty()) {
    std::printf("odometry: none (KITTI has no wheel odometry; --synthetic-odometry adds it)\n");
  } else {
    const Pose2 truth = sim::planarPose(seq.T_w_b.back());
    const Pose2& odo = odometry.back();
    const double dyaw = std::remainder(odo.yaw_rad - truth.yaw_rad, 2.0 * M_PI);
    std::printf("odometry: SYNTHETIC, %s; final error %.3f m, %.2f deg\n",
                writer_options.synthetic_odometry.c_str(),
                std::hypot(odo.x_m - truth.x_m, odo.y_m - truth.y_m),
                dyaw * 180.0 / M_PI);
  }
  std::printf("%.2f s in all (%.1f frames/s); per frame median: load %.1f ms, write %.1f ms\n",
              total_s,
              total_s > 0.0 ? n / total_s : 0.0,
              median(load_ms),
              median(write_ms));
  return 0;
}

}  // namespace twocam::tools
