#include "run_command.h"

#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "eval/disparity_io.h"
#include "eval/landmark_metrics.h"
#include "eval/map_metrics.h"
#include "eval/trajectory_metrics.h"
#include "frontend/cv_interop.h"
#include "io/rawlog.h"
#include "io/trajectory.h"
#include "landmarks/landmark_database.h"
#include "landmarks/landmark_model.h"
#include "pipeline/config.h"
#include "pipeline/pipeline.h"
#include "progress.h"
#include "sim/world_io.h"
#include "simulate_command.h"

extern char** environ;

namespace twocam::tools {
namespace {

namespace fs = std::filesystem;

int fail(const std::string& message) {
  std::cerr << "twocam run: error: " << message << std::endl;
  return 1;
}

void warn(const std::string& message) {
  std::cerr << "twocam run: warning: " << message << std::endl;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(
      v.size() - 1, static_cast<size_t>(std::floor(q * static_cast<double>(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(10) << v;
  return s.str();
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

/// Writes a file through "<path>.partial" and a rename, so an earlier result is replaced only by
/// a complete new one.
Status writeFileAtomically(const fs::path& path, const std::string& content) {
  const fs::path tmp = path.string() + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::error(tmp.string() + ": cannot write");
    out << content;
    out.flush();
    if (!out.good()) return Status::error(tmp.string() + ": write failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return Status::error(path.string() + ": cannot rename into place (" + ec.message() + ")");
  return Status::ok();
}

Status writePngAtomically(const fs::path& path, const ImageU8& image) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", frontend::asMat(image), png))
    return Status::error(path.string() + ": cannot encode PNG");
  return writeFileAtomically(path, std::string(png.begin(), png.end()));
}

/// Number of stereo frames of a log: its external left images (TwoCam's logs), for the
/// progress bar and the default sample frame only; 0 when unknown.
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

/// The frame drawn in sample_frame/: its images and every hypothesis with its fate.
struct SampleFrame {
  bool taken = false;
  int frame = 0;
  ImageU8 left, right;
  std::string hypotheses_csv;
};

void takeSample(int frame,
                const StereoFrame& stereo,
                const pipeline::Pipeline& pipe,
                bool with_landmarks,
                const GroundTruthFrame* gt,
                const StereoRig& rig,
                SampleFrame* sample) {
  sample->taken = true;
  sample->frame = frame;
  sample->left = stereo.left;
  sample->right = stereo.right;
  eval::DisparityGroundTruth d_gt;
  const bool has_gt = gt != nullptr && eval::disparityFromDepth(gt->depth_left, rig, &d_gt).isOk();
  std::ostringstream csv;
  csv << std::setprecision(7)
      << "frame,corner,u,v,rank,d,cost,lr_consistent,landmark_state,truth\n";
  const StereoHypotheses& hyps = pipe.hypotheses();
  const auto& slots = pipe.database().landmarks();
  for (size_t j = 0; j < hyps.hypotheses.size(); ++j) {
    const DisparityHypothesis& h = hyps.hypotheses[j];
    const Corner& c = hyps.points[h.point_index].corner;
    int state = -1;
    if (with_landmarks && j < pipe.report().hypothesis_landmark.size()) {
      const int32_t slot = pipe.report().hypothesis_landmark[j];
      if (slot >= 0) {
        const auto s = slots[static_cast<size_t>(slot)].state;
        state = s == landmarks::LandmarkState::kConfirmed   ? 1
                : s == landmarks::LandmarkState::kCandidate ? 0
                                                            : -1;
      }
    }
    int truth = -1;
    if (has_gt && d_gt.valid(c.u_px, c.v_px))
      truth = std::abs(h.d_px - d_gt.d_px(c.u_px, c.v_px)) <= 1.0f ? 1 : 0;
    csv << frame << ',' << h.point_index << ',' << c.u_px << ',' << c.v_px << ','
        << static_cast<int>(h.rank) << ',' << h.d_px << ',' << h.cost << ','
        << (h.lr_consistent ? 1 : 0) << ',' << state << ',' << truth << '\n';
  }
  sample->hypotheses_csv = csv.str();
}

std::string voxelsCsv(const std::vector<mapping::Voxel>& voxels) {
  std::ostringstream csv;
  csv << std::setprecision(9) << "x,y,z,size,probability\n";
  for (const mapping::Voxel& v : voxels) {
    csv << v.centre_m.x() << ',' << v.centre_m.y() << ',' << v.centre_m.z() << ',' << v.size_m
        << ',' << v.probability << '\n';
  }
  return csv.str();
}

std::string mapMetricsJson(const eval::MapMetrics& m) {
  return "{\"occupied\": " + std::to_string(m.occupied) +
         ", \"phantom\": " + std::to_string(m.phantom) +
         ", \"phantom_fraction\": " + num(m.phantom_fraction) + "}";
}

/// Runs scripts/plot_run.py on the output folder. Pictures are a convenience: failing to draw
/// them is a warning, the run's data are already written.
void drawPictures(const std::string& output_dir) {
  std::string script = std::string(TWOCAM_SOURCE_DIR) + "/scripts/plot_run.py";
  if (const char* s = std::getenv("TWOCAM_PLOT_RUN")) script = s;
  std::error_code ec;
  if (!fs::exists(script, ec)) {
    warn("no pictures: " + script + " not found");
    return;
  }
  // Debian's interpreter, which has python3-matplotlib (a python3 earlier on PATH may not).
  std::error_code ec2;
  const std::string python = fs::exists("/usr/bin/python3", ec2) ? "/usr/bin/python3" : "python3";
  std::vector<std::string> argv_s = {python, script, output_dir};
  std::vector<char*> argv;
  for (std::string& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, python.c_str(), nullptr, nullptr, argv.data(), environ) != 0) {
    warn("no pictures: cannot start python3");
    return;
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    warn("scripts/plot_run.py failed; the data files are complete");
}

}  // namespace

int runRun(const RunArgs& args) {
  // ---- configuration: defaults, then the file, then the command line ----------------------------
  pipeline::PipelineConfig config;
  if (args.config_path) {
    if (Status s = pipeline::loadConfigFile(*args.config_path, &config); !s)
      return fail(s.message());
  }
  if (args.policy) {
    if (Status s = landmarks::parsePolicy(*args.policy, &config.landmarks.policy); !s)
      return fail(s.message());
  }
  if (args.source) {
    if (Status s = frontend::parseHypothesisSource(*args.source, &config.frontend.source); !s)
      return fail(s.message());
  }

  std::unique_ptr<io::RawlogReader> reader;
  if (Status s = io::RawlogReader::open(args.log_path, &reader); !s) return fail(s.message());
  const StereoRig rig = reader->rig();
  if (Status s = pipeline::clampToRig(rig, &config); !s) return fail(s.message());

  // ---- the world, for the map evaluation of simulated runs --------------------------------------
  std::unique_ptr<sim::World> world;
  {
    const std::string sidecar = worldSidecarPath(args.log_path);
    std::error_code ec;
    const std::string path =
        args.world_path ? *args.world_path : (fs::exists(sidecar, ec) ? sidecar : "");
    if (!path.empty()) {
      world = std::make_unique<sim::World>();
      if (Status s = sim::loadWorld(path, world.get()); !s) {
        if (args.world_path) return fail(s.message());
        warn("no map evaluation: " + s.message());
        world.reset();
      }
    }
  }

  // ---- output folder: must exist (or be creatable) and be writable before any work -------------
  const fs::path out(args.output_dir);
  {
    std::error_code ec;
    fs::create_directories(out, ec);
    if (!fs::is_directory(out, ec))
      return fail(args.output_dir + ": cannot create the output folder");
    const fs::path probe = out / ".twocam_write_probe";
    {
      std::ofstream p(probe);
      if (!p) return fail(args.output_dir + ": output folder is not writable");
    }
    fs::remove(probe, ec);
  }

  pipeline::Pipeline pipe(rig, config);
  eval::LandmarkEvaluator evaluator(rig);
  // The evaluation map: the same rays placed with the frame's true pose instead of its odometry
  // pose, so that phantom voxels measure wrong landmarks, not odometry drift.
  std::unique_ptr<mapping::OccupancyMapper> eval_mapper;
  if (world) eval_mapper = std::make_unique<mapping::OccupancyMapper>(config.mapping);

  const int total_in_log = countFrames(args.log_path);
  const int total = args.max_frames ? (total_in_log > 0 ? std::min(*args.max_frames, total_in_log)
                                                        : *args.max_frames)
                                    : total_in_log;
  const int sample_at = args.sample_frame ? *args.sample_frame : std::max(0, total / 2);

  bool odometry_mode = true;
  bool has_gt = true;
  int frames = 0, processed = 0, skipped = 0;
  std::vector<double> t_frontend, t_landmarks, t_mapping, t_total;
  std::vector<io::TimedPose> odom_track, gt_track;
  std::vector<Eigen::Isometry3d> T_true_odom_by_frame;  // per frame index, evaluation map only
  int64_t sum_corners = 0, sum_points = 0, sum_hypotheses = 0;
  int frames_outside_map = 0;
  std::ostringstream timings_csv;
  timings_csv << std::setprecision(6)
              << "frame,frontend_ms,landmarks_ms,mapping_ms,total_ms,corners,hypotheses,candidates,"
                 "confirmed\n";
  SampleFrame sample;
  pipeline::FrameOutput fo;
  io::LogFrame frame;
  Status read_status;
  ProgressBar progress("run", total, !args.quiet && total > 0);
  while ((!args.max_frames || frames < *args.max_frames) && reader->next(&frame, &read_status)) {
    if (frames == 0 && !frame.odometry) {
      odometry_mode = false;
      pipe.skipRowSupport();
      warn(args.log_path +
           " has no odometry: running the frontend only (corners and hypotheses); the landmark "
           "database "
           "needs wheel odometry to predict where landmarks reappear, so there are no landmarks "
           "and no map");
    }
    ++frames;
    if (odometry_mode && !frame.odometry) {
      warn("skipping frame " + std::to_string(frame.index) + ": it has no odometry");
      ++skipped;
      continue;
    }
    const Status s = odometry_mode
                         ? pipe.process(frame.index, frame.stereo, frame.odometry->pose, &fo)
                         : pipe.processFrontendOnly(frame.stereo, &fo);
    if (!s) {
      if (fo.failure != pipeline::FrameOutput::Failure::kLandmarks) {
        return fail("frame " + std::to_string(frame.index) + ": " + s.message());
      }
      // The database refused the frame (NaN pose, time going backwards): it is unchanged.
      warn("skipping " + s.message());
      ++skipped;
      continue;
    }
    ++processed;
    if (fo.outside_map && frames_outside_map++ == 0) {
      warn("frame " + std::to_string(frame.index) + ": the camera is outside the map's extent (" +
           std::to_string(fo.camera_origin_w.norm()) +
           " m from the origin); such frames are not mapped");
    }
    sum_corners += static_cast<int64_t>(pipe.frontend().corners().size());
    sum_points += static_cast<int64_t>(pipe.hypotheses().points.size());
    sum_hypotheses += static_cast<int64_t>(pipe.hypotheses().hypotheses.size());
    // Ground truth counts only with a depth image of the frame's size (a log may carry poses
    // alone; a truncated log may end inside a frame's ground truth).
    const GroundTruthFrame* gt =
        frame.ground_truth && frame.ground_truth->depth_left.width == frame.stereo.left.width &&
                frame.ground_truth->depth_left.height == frame.stereo.left.height
            ? &*frame.ground_truth
            : nullptr;
    if (odometry_mode) {
      odom_track.push_back({frame.stereo.t_ns, toIsometry(frame.odometry->pose)});
      if (gt && has_gt) {
        gt_track.push_back({frame.stereo.t_ns, gt->T_w_b});
        if (Status es = evaluator.addFrame(pipe.hypotheses(),
                                           frame.stereo.left,
                                           pipe.report(),
                                           pipe.database(),
                                           gt->depth_left,
                                           gt->T_w_b);
            !es) {
          return fail(es.message());
        }
        if (eval_mapper) {
          // Each landmark is placed with the correction (true pose x odometry pose^-1) of its
          // anchor frame, where its position was measured; the ray starts at the true camera.
          const Eigen::Isometry3d T_true_odom =
              gt->T_w_b * toIsometry(frame.odometry->pose).inverse();
          if (static_cast<size_t>(frame.index) >= T_true_odom_by_frame.size()) {
            T_true_odom_by_frame.resize(static_cast<size_t>(frame.index) + 1,
                                        Eigen::Isometry3d::Identity());
          }
          T_true_odom_by_frame[static_cast<size_t>(frame.index)] = T_true_odom;
          std::vector<Eigen::Vector3d> pts;
          pts.reserve(fo.mapped_points_w.size());
          for (size_t i = 0; i < fo.mapped_points_w.size(); ++i) {
            const int32_t anchor = pipe.database().landmarks()[fo.mapped_slots[i]].anchor.frame;
            const bool known =
                anchor >= 0 && static_cast<size_t>(anchor) < T_true_odom_by_frame.size();
            pts.push_back(
                (known ? T_true_odom_by_frame[static_cast<size_t>(anchor)] : T_true_odom) *
                fo.mapped_points_w[i]);
          }
          const Eigen::Vector3d o = T_true_odom * fo.camera_origin_w;
          octomap::OcTreeKey key;
          if (eval_mapper->tree().coordToKeyChecked(octomap::point3d(static_cast<float>(o.x()),
                                                                     static_cast<float>(o.y()),
                                                                     static_cast<float>(o.z())),
                                                    key)) {
            eval_mapper->insertFrame(o, pts);
          }
        }
      } else {
        has_gt = false;
      }
    }
    if (!sample.taken && frame.index >= sample_at)
      takeSample(frame.index, frame.stereo, pipe, odometry_mode, gt, rig, &sample);
    t_frontend.push_back(fo.times.frontend_ms);
    t_landmarks.push_back(fo.times.landmarks_ms);
    t_mapping.push_back(fo.times.mapping_ms);
    t_total.push_back(fo.times.total_ms());
    timings_csv << frame.index << ',' << fo.times.frontend_ms << ',' << fo.times.landmarks_ms << ','
                << fo.times.mapping_ms << ',' << fo.times.total_ms() << ','
                << pipe.frontend().corners().size() << ',' << pipe.hypotheses().hypotheses.size()
                << ',' << pipe.database().numCandidates() << ',' << pipe.database().numConfirmed()
                << '\n';
    progress.update(frames);
  }
  if (!read_status) return fail(read_status.message());
  if (frames == 0) return fail(args.log_path + ": no stereo frames");
  if (processed == 0) return fail(args.log_path + ": no frame could be processed");
  has_gt = has_gt && odometry_mode && !gt_track.empty();
  const landmarks::LandmarkDatabase& db = pipe.database();

  // ---- landmarks.csv: the leading columns, then verdict and errors with ground truth ---
  std::ostringstream csv;
  csv << std::setprecision(9);
  csv << "id,x,y,z,confirmed,confidence,n_obs,first_frame,anchor_frame,anchor_u,anchor_v,anchor_d,"
         "confirmed_frame,"
         "verdict,error_m,anchor_d_gt,estimate_anchor_d,anchor_d_gt_near,anchor_d_gt_far,anchor_"
         "texture_grey\n";
  const auto optional_num = [&](double v) {
    if (std::isfinite(v)) csv << v;
  };
  for (const landmarks::Landmark& l : db.landmarks()) {
    if (l.state == landmarks::LandmarkState::kFree) continue;
    csv << l.id << ',' << l.p_w.x() << ',' << l.p_w.y() << ',' << l.p_w.z() << ','
        << (l.state == landmarks::LandmarkState::kConfirmed ? 1 : 0) << ',' << l.confidence << ','
        << l.n_obs << ',' << l.first_frame << ',' << l.anchor.frame << ',' << l.anchor.u_px << ','
        << l.anchor.v_px << ',' << l.anchor.d_px << ',' << l.confirmed_frame << ','
        << (has_gt ? evaluator.verdict(l) : -1) << ',';
    optional_num(has_gt ? evaluator.errorM(l) : std::nan(""));
    csv << ',';
    optional_num(has_gt ? evaluator.anchorDisparityGt(l) : std::nan(""));
    // The estimate's disparity seen from the anchor camera (equals anchor_d until refined).
    const Eigen::Vector3d p_ca =
        landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig.T_b_cl).inverse() * l.p_w;
    csv << ',' << rig.fx_px * rig.baseline_m / p_ca.z() << ',';
    optional_num(has_gt ? evaluator.anchorDisparityNear(l) : std::nan(""));
    csv << ',';
    optional_num(has_gt ? evaluator.anchorDisparityFar(l) : std::nan(""));
    csv << ',';
    optional_num(has_gt ? evaluator.anchorTextureGrey(l) : std::nan(""));
    csv << '\n';
  }

  // ---- map
  // ---------------------------------------------------------------------------------------
  const std::vector<mapping::Voxel> voxels = pipe.mapper().occupiedVoxels();
  std::optional<eval::MapMetrics> map_eval, map_eval_odom;
  std::ostringstream eval_voxels_csv;
  if (world && has_gt) {
    const std::vector<mapping::Voxel> ev = eval_mapper->occupiedVoxels();
    std::vector<double> dist;
    map_eval = eval::evaluateMap(ev, *world, config.mapping.resolution_m, &dist);
    map_eval_odom = eval::evaluateMap(voxels, *world, config.mapping.resolution_m);
    eval_voxels_csv << std::setprecision(9) << "x,y,z,size,distance_m,phantom\n";
    for (size_t i = 0; i < ev.size(); ++i) {
      eval_voxels_csv << ev[i].centre_m.x() << ',' << ev[i].centre_m.y() << ','
                      << ev[i].centre_m.z() << ',' << ev[i].size_m << ',' << dist[i] << ','
                      << (dist[i] > 2.0 * config.mapping.resolution_m ? 1 : 0) << '\n';
    }
  }

  // ---- metrics.json: deterministic (wall-clock times go to timing.json) -------------------------
  std::ostringstream json;
  json << std::setprecision(10);
  json << "{\n  \"log\": " << jsonString(args.log_path) << ",\n  \"policy\": \""
       << landmarks::policyName(config.landmarks.policy) << "\",\n  \"source\": \""
       << frontend::hypothesisSourceName(config.frontend.source)
       << "\",\n  \"seed\": " << config.seed << ",\n  \"frames\": " << frames
       << ",\n  \"frames_processed\": " << processed << ",\n  \"frames_skipped\": " << skipped
       << ",\n  \"odometry\": " << (odometry_mode ? "true" : "false")
       << ",\n  \"ground_truth\": " << (has_gt ? "true" : "false") << ",\n";
  const auto per_frame = [&](int64_t n) { return num(static_cast<double>(n) / processed); };
  json << "  \"detections\": {\"corners_per_frame\": " << per_frame(sum_corners)
       << ", \"salient_points_per_frame\": " << per_frame(sum_points)
       << ", \"hypotheses_per_frame\": " << per_frame(sum_hypotheses) << "},\n";
  const mapping::MappingStats& ms = pipe.mapper().stats();
  json << "  \"mapping\": {\"resolution_m\": " << num(config.mapping.resolution_m)
       << ", \"occupied_voxels\": " << voxels.size()
       << ", \"points_inserted\": " << ms.points_inserted
       << ", \"points_beyond_range\": " << ms.points_beyond_range
       << ", \"frames_outside_map\": " << frames_outside_map << "}";
  if (map_eval) {
    json << ",\n  \"octomap\": {\"resolution_m\": " << num(config.mapping.resolution_m)
         << ", \"occupied\": " << map_eval->occupied << ", \"phantom\": " << map_eval->phantom
         << ", \"phantom_fraction\": " << num(map_eval->phantom_fraction)
         << ", \"odometry_frame\": " << mapMetricsJson(*map_eval_odom) << "}";
  }
  std::optional<eval::LandmarkMetrics> lm;
  if (has_gt) {
    double ate = 0.0;
    if (Status s = eval::ateRmseM(odom_track, gt_track, &ate); !s) return fail(s.message());
    json << ",\n  \"trajectory\": {\"ate_rmse_m\": {\"odometry\": " << num(ate) << "}}";
    lm = evaluator.finish(db);
    const std::string nested = eval::toJson(*lm, "  ");
    // Merge the evaluator's object into this one (drop its braces).
    const size_t open = nested.find('{');
    const size_t close = nested.rfind('}');
    json << ",\n" << nested.substr(open + 2, close - open - 2);
  } else {
    json << ",\n  \"landmarks\": {\"confirmed\": " << db.numConfirmed()
         << ", \"candidates\": " << db.numCandidates() << "}\n";
  }
  json << "}\n";

  std::ostringstream timing_json;
  timing_json << std::setprecision(6) << "{\n  \"timing_ms\": {";
  const std::pair<const char*, const std::vector<double>*> stages[] = {{"frontend", &t_frontend},
                                                                       {"landmarks", &t_landmarks},
                                                                       {"mapping", &t_mapping},
                                                                       {"total", &t_total}};
  for (size_t i = 0; i < 4; ++i) {
    timing_json << (i ? ", " : "") << '"' << stages[i].first
                << "_median\": " << quantile(*stages[i].second, 0.5) << ", \"" << stages[i].first
                << "_p95\": " << quantile(*stages[i].second, 0.95);
  }
  timing_json << "},\n  \"frames\": " << t_total.size() << "\n}\n";

  // ---- write everything, each file complete or not at all ---------------------------------------
  std::vector<std::pair<std::string, std::string>> files = {
      {"landmarks.csv", csv.str()},
      {"timings.csv", timings_csv.str()},
      {"timing.json", timing_json.str()},
      {"config_used.yaml",
       "# Effective configuration of twocam run on " + args.log_path + "\n" +
           pipeline::toYaml(config)},
  };
  if (odometry_mode) {
    files.emplace_back(
        "trajectory_odom.tum",
        io::toTum(odom_track, "wheel odometry: body pose in the odometry world frame"));
    files.emplace_back("map_voxels.csv", voxelsCsv(voxels));
  }
  if (has_gt)
    files.emplace_back("trajectory_gt.tum",
                       io::toTum(gt_track, "ground truth: body pose in the world frame"));
  if (map_eval) {
    files.emplace_back("map_eval_voxels.csv", eval_voxels_csv.str());
    files.emplace_back("world_outline.csv", worldOutlineCsv(*world));
  }
  for (const auto& [name, content] : files) {
    if (Status s = writeFileAtomically(out / name, content); !s) return fail(s.message());
  }
  if (odometry_mode) {
    if (Status s = pipe.mapper().writeBinary((out / "map.bt").string()); !s)
      return fail(s.message());
  }
  if (sample.taken) {
    const fs::path sdir = out / "sample_frame";
    std::error_code ec;
    fs::create_directories(sdir, ec);
    if (Status s = writePngAtomically(sdir / "left.png", sample.left); !s) return fail(s.message());
    if (Status s = writePngAtomically(sdir / "right.png", sample.right); !s)
      return fail(s.message());
    if (Status s = writeFileAtomically(sdir / "hypotheses.csv", sample.hypotheses_csv); !s)
      return fail(s.message());
  }
  // metrics.json last: its presence says the run completed.
  if (Status s = writeFileAtomically(out / "metrics.json", json.str()); !s)
    return fail(s.message());

  // ---- summary
  // -----------------------------------------------------------------------------------
  std::cout << std::setprecision(4);
  std::cout << "frames: " << processed << " processed, " << skipped << " skipped; per frame median "
            << quantile(t_total, 0.5) << " ms (frontend " << quantile(t_frontend, 0.5)
            << ", landmarks " << quantile(t_landmarks, 0.5) << ", mapping "
            << quantile(t_mapping, 0.5) << ")" << std::endl;
  if (lm) {
    std::cout << "landmarks: " << lm->confirmed << " confirmed, " << lm->correct_confirmed
              << " correct, precision " << lm->precision << " % (" << lm->precision_judged
              << " % of the " << lm->confirmed - lm->unjudged_confirmed
              << " with ground truth at the anchor), median error " << lm->median_error_m << " m"
              << std::endl;
  } else if (odometry_mode) {
    std::cout << "landmarks: " << db.numConfirmed() << " confirmed, " << db.numCandidates()
              << " candidates (no ground truth)" << std::endl;
  }
  if (map_eval) {
    std::cout << "map: " << map_eval->occupied << " occupied voxels at "
              << config.mapping.resolution_m << " m, " << map_eval->phantom << " phantom ("
              << 100.0 * map_eval->phantom_fraction << " %)" << std::endl;
  } else if (odometry_mode) {
    std::cout << "map: " << voxels.size() << " occupied voxels at " << config.mapping.resolution_m
              << " m" << std::endl;
  }
  std::cout << "wrote " << (out / "metrics.json").string()
            << (odometry_mode ? ", map.bt, landmarks.csv, trajectory_odom.tum"
                              : ", landmarks.csv (empty)")
            << (has_gt ? ", trajectory_gt.tum" : "") << ", timings.csv, config_used.yaml"
            << (sample.taken ? ", sample_frame/" : "") << std::endl;
  if (!args.no_pictures) {
    std::cout << "pictures:" << std::endl;
    drawPictures(args.output_dir);
  }
  return 0;
}

}  // namespace twocam::tools
