#include "import_euroc_command.h"

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
#include "frontend/rectify.h"
#include "io/euroc.h"
#include "io/rawlog.h"
#include "progress.h"

namespace twocam::tools {

namespace fs = std::filesystem;

namespace {

int fail(std::string message) {
  // One line, whatever the library put into the message.
  std::replace(message.begin(), message.end(), '\n', ' ');
  std::cerr << "twocam import-euroc: error: " << message << std::endl;
  return 1;
}

/// DIR/mav0 when it exists, else DIR itself when it holds cam0/ and cam1/ (DIR is mav0).
Status findMav0(const std::string& dir, std::string* mav0) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return Status::error("input folder '" + dir + "' does not exist");
  if (!fs::is_directory(dir, ec)) return Status::error("input '" + dir + "' is not a folder");
  if (fs::is_directory(fs::path(dir) / "mav0", ec)) {
    *mav0 = (fs::path(dir) / "mav0").string();
    return Status::ok();
  }
  if (fs::is_directory(fs::path(dir) / "cam0", ec) &&
      fs::is_directory(fs::path(dir) / "cam1", ec)) {
    *mav0 = dir;
    return Status::ok();
  }
  return Status::error("'" + dir +
                       "' is not a EuRoC sequence: it has neither mav0/ nor cam0/ and cam1/");
}

Status loadRaw(const std::string& path,
               const CameraCalibration& calibration,
               const char* camera,
               ImageU8* image) {
  if (Status st = frontend::loadGrey(path, image); !st) return st;
  if (image->width != calibration.width || image->height != calibration.height) {
    std::ostringstream os;
    os << "image '" << path << "' is " << image->width << "x" << image->height << " px but "
       << camera << "/sensor.yaml gives resolution " << calibration.width << "x"
       << calibration.height;
    return Status::error(os.str());
  }
  return Status::ok();
}

}  // namespace

int runImportEuroc(const ImportEurocArgs& args) {
  const Timer total;
  if (args.max_frames && *args.max_frames < 1)
    return fail("--max-frames " + std::to_string(*args.max_frames) + ": must be >= 1");
  std::error_code ec;
  if (fs::is_directory(args.output_path, ec))
    return fail("output '" + args.output_path + "' is a folder; give a .rawlog file path");

  std::string mav0;
  if (Status st = findMav0(args.input_dir, &mav0); !st) return fail(st.message());
  CameraCalibration cam0;
  CameraCalibration cam1;
  if (Status st = io::loadEurocStereoCalibration(mav0, &cam0, &cam1); !st)
    return fail(st.message());
  io::EurocStereoIndex index;
  if (Status st = io::loadEurocStereoIndex(mav0, &index); !st) return fail(st.message());
  frontend::StereoRectifier rectifier;
  if (Status st =
          frontend::StereoRectifier::create(cam0, cam1, frontend::RectifyOptions(), &rectifier);
      !st) {
    return fail("cannot rectify " + mav0 + ": " + st.message());
  }
  const StereoRig& rig = rectifier.rig();

  // The writer goes through "<output>.partial" and removes it when destroyed unfinished, so
  // every early return below leaves no log and keeps an older one at the output path.
  std::unique_ptr<io::RawlogWriter> writer;
  if (Status st = io::RawlogWriter::open(args.output_path, rig, io::RawlogWriterOptions(), &writer);
      !st)
    return fail(st.message());

  const int available = static_cast<int>(index.t_ns.size());
  const int n = args.max_frames ? std::min(*args.max_frames, available) : available;
  std::vector<double> load_ms;
  std::vector<double> rectify_ms;
  std::vector<double> write_ms;
  ProgressBar bar("import-euroc", n, !args.quiet);
  ImageU8 raw_left;
  ImageU8 raw_right;
  StereoFrame frame;
  for (int k = 0; k < n; ++k) {
    Timer stage;
    if (Status st = loadRaw(index.left_paths[k], cam0, "cam0", &raw_left); !st)
      return fail("frame " + std::to_string(k) + ": " + st.message());
    if (Status st = loadRaw(index.right_paths[k], cam1, "cam1", &raw_right); !st)
      return fail("frame " + std::to_string(k) + ": " + st.message());
    load_ms.push_back(stage.elapsedMs());
    stage.restart();
    frame.t_ns = index.t_ns[k];
    if (Status st = rectifier.rectify(raw_left, raw_right, &frame.left, &frame.right); !st) {
      return fail("frame " + std::to_string(k) + " (" + index.left_paths[k] + "): " + st.message());
    }
    rectify_ms.push_back(stage.elapsedMs());
    stage.restart();
    // EuRoC has no wheel odometry and its ground truth (Vicon/Leica) is not converted here.
    if (Status st = writer->write(frame, nullptr, nullptr); !st) return fail(st.message());
    write_ms.push_back(stage.elapsedMs());
    bar.update(k + 1);
  }
  if (Status st = writer->finish(); !st) return fail(st.message());
  const double total_s = total.elapsedS();

  std::printf("imported %d of %d stereo pairs from %s into %s (images in %s)\n",
              n,
              available,
              mav0.c_str(),
              args.output_path.c_str(),
              writer->imagesDir().c_str());
  std::printf("dropped %zu cam0 and %zu cam1 time stamps without a partner in the other camera\n",
              index.unmatched_left_t_ns.size(),
              index.unmatched_right_t_ns.size());
  std::printf(
      "rectified rig: %dx%d px, fx = fy = %.3f px, cx = %.3f px, cy = %.3f px, baseline = %.4f m\n",
      rig.width_px,
      rig.height_px,
      rig.fx_px,
      rig.cx_px,
      rig.cy_px,
      rig.baseline_m);
  const Eigen::Vector3d t_b_cl = rig.T_b_cl.translation();
  const double rect_deg =
      Eigen::AngleAxisd(rectifier.R_rect_raw(frontend::StereoSide::kLeft)).angle() * 180.0 / M_PI;
  std::printf(
      "left rectified camera in the body (IMU) frame: t_b_cl = (%.4f, %.4f, %.4f) m, rotated %.2f "
      "deg from raw cam0; "
      "no odometry, no ground truth\n",
      t_b_cl.x(),
      t_b_cl.y(),
      t_b_cl.z(),
      rect_deg);
  std::printf(
      "%.2f s in all (%.1f frames/s); per frame median: load %.1f ms, rectify %.1f ms, write %.1f "
      "ms\n",
      total_s,
      total_s > 0.0 ? n / total_s : 0.0,
      median(load_ms),
      median(rectify_ms),
      median(write_ms));
  return 0;
}

}  // namespace twocam::tools
