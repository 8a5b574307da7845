#include "run_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "eval/landmark_metrics.h"
#include "frontend/frontend.h"
#include "io/rawlog.h"
#include "landmarks/landmark_database.h"
#include "landmarks/landmark_model.h"
#include "progress.h"

namespace twocam::tools {
namespace {

namespace fs = std::filesystem;

int fail(const std::string& message) {
  std::cerr << "twocam run: error: " << message << std::endl;
  return 1;
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::floor(q * static_cast<double>(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// Writes a file through "<path>.partial" and a rename, so an earlier result is replaced only by
/// a complete new one.
Status writeFileAtomically(const fs::path& path, const std::string& content) {
  const fs::path tmp = path.string() + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::error(tmp.string() + ": cannot write");
    out << content;
    if (!out.good()) return Status::error(tmp.string() + ": write failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return Status::error(path.string() + ": cannot rename into place (" + ec.message() + ")");
  return Status::ok();
}

/// Number of stereo frames of a log: its external left images (TwoCam's logs), for the
/// progress bar only; 0 when unknown.
int countFrames(const std::string& log_path) {
  std::error_code ec;
  const fs::path dir = io::imagesDirectoryFor(log_path);
  if (!fs::is_directory(dir, ec)) return 0;
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().filename().string().rfind("left_", 0) == 0) ++n;
  }
  return n;
}

}  // namespace

int runRun(const RunArgs& args) {
  landmarks::LandmarkOptions lm_options;
  if (Status s = landmarks::parsePolicy(args.policy, &lm_options.policy); !s) return fail(s.message());
  frontend::FrontendOptions fe_options;
  if (Status s = frontend::parseHypothesisSource(args.source, &fe_options.source); !s) return fail(s.message());

  std::unique_ptr<io::RawlogReader> reader;
  if (Status s = io::RawlogReader::open(args.log_path, &reader); !s) return fail(s.message());
  const StereoRig rig = reader->rig();
  fe_options.sad.max_disparity_px = std::min(fe_options.sad.max_disparity_px, rig.width_px - fe_options.sad.window_width_px);
  lm_options.max_disparity_px = fe_options.sad.max_disparity_px;
  lm_options.min_disparity_px = fe_options.sad.min_disparity_px;
  if (Status s = fe_options.validate(); !s) return fail(s.message());
  if (Status s = lm_options.validate(); !s) return fail(s.message());

  std::error_code ec;
  fs::create_directories(args.output_dir, ec);
  if (!fs::is_directory(args.output_dir)) return fail(args.output_dir + ": cannot create the output folder");
  const fs::path probe = fs::path(args.output_dir) / ".twocam_write_probe";
  {
    std::ofstream p(probe);
    if (!p) return fail(args.output_dir + ": output folder is not writable");
  }
  fs::remove(probe, ec);

  frontend::Frontend frontend(fe_options);
  landmarks::LandmarkDatabase db(rig, lm_options);
  eval::LandmarkEvaluator evaluator(rig);
  bool has_gt = true;
  int frames = 0;
  int skipped = 0;
  std::vector<double> t_frontend, t_landmarks, t_total;
  std::ostringstream timings_csv;
  timings_csv << "frame,frontend_ms,landmarks_ms,total_ms,corners,hypotheses,candidates,confirmed\n";
  StereoHypotheses hyps;
  landmarks::FrameReport report;
  io::LogFrame frame;
  Status read_status;
  const int total = args.max_frames ? *args.max_frames : countFrames(args.log_path);
  ProgressBar progress("run " + args.policy, total, !args.quiet && total > 0);
  while ((!args.max_frames || frames < *args.max_frames) && reader->next(&frame, &read_status)) {
    if (!frame.odometry) {
      return fail("frame " + std::to_string(frame.index) +
                  " has no odometry: the landmark database needs wheel odometry to predict where landmarks reappear");
    }
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = frontend.process(frame.stereo, &hyps); !s) return fail("frame " + std::to_string(frame.index) + ": " + s.message());
    const double fe_ms = msSince(t0);
    const auto t1 = std::chrono::steady_clock::now();
    const Status us = db.update(frame.index, frame.stereo.t_ns, frame.odometry->pose, hyps, &report);
    const double lm_ms = msSince(t1);
    if (!us) {
      // The frame is skipped; the database is unchanged and the run goes on with the next one.
      std::cerr << "twocam run: warning: skipping " << us.message() << std::endl;
      ++skipped;
      ++frames;
      continue;
    }
    if (frame.ground_truth && has_gt) {
      if (Status s = evaluator.addFrame(hyps, report, db, frame.ground_truth->depth_left); !s) return fail(s.message());
    } else {
      has_gt = false;
    }
    t_frontend.push_back(fe_ms);
    t_landmarks.push_back(lm_ms);
    t_total.push_back(fe_ms + lm_ms);
    timings_csv << frame.index << ',' << fe_ms << ',' << lm_ms << ',' << fe_ms + lm_ms << ','
                << frontend.corners().size() << ',' << hyps.hypotheses.size() << ',' << db.numCandidates() << ','
                << db.numConfirmed() << '\n';
    ++frames;
    progress.update(frames);
  }
  if (!read_status) return fail(read_status.message());
  if (frames == 0) return fail(args.log_path + ": no stereo frames");

  // landmarks.csv: the leading columns, then verdict and error when ground truth exists.
  std::ostringstream csv;
  csv << std::setprecision(9);
  csv << "id,x,y,z,confirmed,confidence,n_obs,first_frame,anchor_frame,anchor_u,anchor_v,anchor_d,confirmed_frame,"
         "verdict,error_m,anchor_d_gt,estimate_anchor_d,anchor_d_gt_near,anchor_d_gt_far\n";
  for (const landmarks::Landmark& l : db.landmarks()) {
    if (l.state == landmarks::LandmarkState::kFree) continue;
    const int verdict = has_gt ? evaluator.verdict(l) : -1;
    const double err = has_gt ? evaluator.errorM(l) : std::nan("");
    csv << l.id << ',' << l.p_w.x() << ',' << l.p_w.y() << ',' << l.p_w.z() << ','
        << (l.state == landmarks::LandmarkState::kConfirmed ? 1 : 0) << ',' << l.confidence << ',' << l.n_obs << ','
        << l.first_frame << ',' << l.anchor.frame << ',' << l.anchor.u_px << ',' << l.anchor.v_px << ','
        << l.anchor.d_px << ',' << l.confirmed_frame << ',' << verdict << ',';
    if (std::isfinite(err)) csv << err;
    csv << ',';
    const double d_gt = has_gt ? evaluator.anchorDisparityGt(l) : std::nan("");
    if (std::isfinite(d_gt)) csv << d_gt;
    // The estimate's disparity seen from the anchor camera (equals anchor_d until refined).
    const Eigen::Vector3d p_ca = landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig.T_b_cl).inverse() * l.p_w;
    csv << ',' << rig.fx_px * rig.baseline_m / p_ca.z() << ',';
    const double d_near = has_gt ? evaluator.anchorDisparityNear(l) : std::nan("");
    const double d_far = has_gt ? evaluator.anchorDisparityFar(l) : std::nan("");
    if (std::isfinite(d_near)) csv << d_near;
    csv << ',';
    if (std::isfinite(d_far)) csv << d_far;
    csv << '\n';
  }

  std::ostringstream json;
  json << std::setprecision(10);
  json << "{\n  \"log\": \"" << args.log_path << "\",\n  \"policy\": \"" << args.policy << "\",\n  \"source\": \""
       << args.source << "\",\n  \"frames\": " << frames << ",\n  \"frames_skipped\": " << skipped << ",\n";
  json << "  \"timing_ms\": {\"frontend_median\": " << quantile(t_frontend, 0.5)
       << ", \"frontend_p95\": " << quantile(t_frontend, 0.95) << ", \"landmarks_median\": " << quantile(t_landmarks, 0.5)
       << ", \"landmarks_p95\": " << quantile(t_landmarks, 0.95) << ", \"total_median\": " << quantile(t_total, 0.5)
       << ", \"total_p95\": " << quantile(t_total, 0.95) << "},\n";
  json << "  \"ground_truth\": " << (has_gt ? "true" : "false");
  if (has_gt) {
    const eval::LandmarkMetrics m = evaluator.finish(db);
    const std::string nested = eval::toJson(m, "  ");
    // Merge the evaluator's object into this one (drop its braces).
    const size_t open = nested.find('{');
    const size_t close = nested.rfind('}');
    json << ",\n" << nested.substr(open + 2, close - open - 2);
    std::cout << "landmarks: " << m.confirmed << " confirmed, " << m.correct_confirmed << " correct, precision "
              << std::setprecision(4) << m.precision << " % (" << m.precision_judged << " % of the "
              << m.confirmed - m.unjudged_confirmed << " with ground truth at the anchor), median error "
              << m.median_error_m << " m" << std::endl;
  } else {
    json << ",\n  \"landmarks\": {\"confirmed\": " << db.numConfirmed() << ", \"candidates\": " << db.numCandidates()
         << "}\n";
  }
  json << "}\n";

  const fs::path out(args.output_dir);
  if (Status s = writeFileAtomically(out / "landmarks.csv", csv.str()); !s) return fail(s.message());
  if (Status s = writeFileAtomically(out / "timings.csv", timings_csv.str()); !s) return fail(s.message());
  if (Status s = writeFileAtomically(out / "metrics.json", json.str()); !s) return fail(s.message());
  std::cout << "wrote " << (out / "metrics.json").string() << ", landmarks.csv, timings.csv" << std::endl;
  return 0;
}

}  // namespace twocam::tools
