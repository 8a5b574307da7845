// RawlogReader: TwoCam's own logs and other tools' (docs/recorded_data.md). The writer is in
// rawlog_writer.cpp.
#include "io/rawlog.h"

#include <mrpt/img/CImage.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationComment.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DQuat.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <new>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/quiet_stderr.h"
#include "io/embedded_images.h"
#include "io/log_guards.h"
#include "io/rawlog_format.h"

namespace twocam::io {

namespace fs = std::filesystem;
using internal::AllocationCap;
using internal::BadSizeError;
using internal::fromMrptPose;
using internal::fromMrptTime;
using internal::kEndPrefix;
using internal::kHeaderPrefix;
using internal::kMaxForeignImagePixels;
using internal::kMaxForeignImageSidePx;
using internal::kMaxObjectAllocationBytes;
using internal::kSyntheticOdometryField;
using internal::PeekableStream;
using internal::peekRangeImageSize;
using internal::rejectedImageReason;

namespace {
/// Reads an image with the C library's stderr (fd 2) silenced: libpng prints "libpng error:
/// ..." there for a corrupt file before OpenCV returns an empty image, and TwoCam reports the
/// failure in its own words instead. Process-wide while it runs (single-threaded callers).
cv::Mat imreadQuietly(const std::string& path, int flags) {
  const QuietStderr quiet;
  try {
    return cv::imread(path, flags);
  } catch (const cv::Exception&) {
    return cv::Mat();
  }
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// Reader

struct RawlogReader::Impl {
  mrpt::io::CFileGZInputStream stream;
  PeekableStream peekable{stream};
  std::string path;
  std::string images_dir;
  bool is_twocam = false;
  bool saw_end_marker = false;
  /// The header's note on synthetic odometry, when it has one.
  std::optional<std::string> synthetic_odometry;
  bool rig_known = false;
  /// Frames come from the stereo observations with this label (the first one seen); others
  /// (a second stereo camera) are skipped.
  std::string stereo_label;
  std::deque<mrpt::obs::CObservation::Ptr> pending;
  bool eof = false;
  /// Sensory-frame logs: odometry accumulated from CActionRobotMovement2D increments (MRPT's
  /// convention: the action collection before a sensory frame is the motion since the
  /// previous one). Set once the log has had a movement action.
  std::optional<mrpt::poses::CPose2D> action_odometry;
  /// A read error met after a complete frame (while looking for observations that belong to
  /// it): the frame is delivered and the error reported by the following next().
  std::optional<std::string> deferred_error;

  /// Image size of the log's stereo rig once known (0 before).
  int rig_width_px = 0;
  int rig_height_px = 0;

  /// Refuses a depth image whose declared size the log does not allow, before MRPT allocates
  /// it (MRPT 2.5's aligned allocator returns null for a huge request and the resize then
  /// writes through it: a one-byte change of the size field crashed `twocam run`).
  void checkNextObjectSizes() {
    const auto size = peekRangeImageSize(peekable);
    if (!size) return;
    const auto [rows, cols] = *size;
    std::ostringstream os;
    if (is_twocam && rig_width_px > 0) {
      if (rows == static_cast<uint32_t>(rig_height_px) &&
          cols == static_cast<uint32_t>(rig_width_px))
        return;
      os << "depth image declares " << cols << "x" << rows << " pixels; the log's rig is "
         << rig_width_px << "x" << rig_height_px << " (corrupt log)";
    } else {
      if (rows <= kMaxForeignImageSidePx && cols <= kMaxForeignImageSidePx &&
          uint64_t{rows} * cols <= kMaxForeignImagePixels)
        return;
      os << "depth image declares " << cols << "x" << rows << " pixels, above the limit of "
         << kMaxForeignImageSidePx << " per side and " << kMaxForeignImagePixels
         << " in all (corrupt log)";
    }
    throw BadSizeError(os.str());
  }

  /// Reads the next observation (flattening sensory frames and odometry actions).
  /// Returns nullptr at the end; throws on corrupt data.
  mrpt::obs::CObservation::Ptr read() {
    while (pending.empty()) {
      if (eof) return nullptr;
      mrpt::serialization::CSerializable::Ptr obj;
      peekable.takeRejection();
      checkNextObjectSizes();
      try {
        const AllocationCap cap(kMaxObjectAllocationBytes);
        auto arch = mrpt::serialization::archiveFrom(peekable);
        obj = arch.ReadObject();
      } catch (const mrpt::serialization::CExceptionEOF&) {
        // An image rejected by the stream's filter, whose size fields were wrong: the object
        // no longer parses after it. Its reason says more than MRPT's.
        if (auto why = peekable.takeRejection()) throw std::runtime_error(*why);
        eof = true;
        return nullptr;
      } catch (const std::bad_alloc&) {
        throw BadSizeError("an object declares a size above " +
                           std::to_string(kMaxObjectAllocationBytes >> 20) + " MiB (corrupt log)");
      } catch (const std::exception&) {
        if (auto why = peekable.takeRejection()) throw std::runtime_error(*why);
        throw;
      }
      if (auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(obj)) {
        if (auto c = std::dynamic_pointer_cast<mrpt::obs::CObservationComment>(obs)) {
          if (c->text.rfind(kHeaderPrefix, 0) == 0) {
            is_twocam = true;
            const size_t at = c->text.find(kSyntheticOdometryField);
            if (at != std::string::npos)
              synthetic_odometry = c->text.substr(at + std::strlen(kSyntheticOdometryField));
          }
          if (c->text.rfind(kEndPrefix, 0) == 0) saw_end_marker = true;
          continue;
        }
        pending.push_back(obs);
      } else if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
        for (const auto& o : *sf) {
          // The accumulated action odometry goes in front of each stereo observation of the
          // frame, with its time stamp, so that an explicit CObservationOdometry with the same
          // stamp (before or after it) takes precedence.
          if (action_odometry &&
              std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(o)) {
            auto odo = std::make_shared<mrpt::obs::CObservationOdometry>();
            odo->sensorLabel = "ACTIONS";
            odo->timestamp = o->timestamp;
            odo->odometry = *action_odometry;
            pending.push_back(odo);
          }
          if (o) pending.push_back(o);
        }
      } else if (auto acts = std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(obj)) {
        // Sensory-frame logs carry wheel odometry as increments; TwoCam works with accumulated
        // odometry, so the increments are composed from the first one on (odometry frame =
        // body pose before the first increment).
        if (auto mv = acts->getBestMovementEstimation()) {
          mrpt::poses::CPose2D increment = mv->rawOdometryIncrementReading;
          if (mv->estimationMethod != mrpt::obs::CActionRobotMovement2D::emOdometry &&
              mv->poseChange) {
            mv->poseChange->getMean(increment);
          }
          action_odometry = action_odometry.value_or(mrpt::poses::CPose2D()) + increment;
        }
      }
    }
    auto o = pending.front();
    pending.pop_front();
    return o;
  }

  /// Loads one image of a stereo observation as 8-bit grey. Errors name the image.
  Status loadImage(const mrpt::img::CImage& img, const char* side, ImageU8* out) const {
    cv::Mat grey;
    if (img.isExternallyStored()) {
      std::string file = img.getExternalStorageFile();
      // An embedded image the look-ahead stream rejected (embedded_images.h).
      if (auto reason = rejectedImageReason(file))
        return Status::error(side + (" image: " + *reason));
      if (!fs::path(file).is_absolute()) file = images_dir + "/" + file;
      std::error_code ec;
      if (!fs::is_regular_file(file, ec))
        return Status::error(std::string(side) + " image file '" + file + "' is missing");
      grey = imreadQuietly(file, cv::IMREAD_GRAYSCALE);
      if (grey.empty())
        return Status::error("cannot read " + std::string(side) + " image file '" + file + "'");
    } else {
      const cv::Mat& m = img.asCvMatRef();
      if (m.empty()) return Status::error(std::string(side) + " image has no data");
      if (m.depth() != CV_8U)
        return Status::error(std::string(side) + " image is not 8-bit (only 8-bit grey or colour)");
      if (m.channels() == 3)
        cv::cvtColor(m, grey, cv::COLOR_BGR2GRAY);
      else if (m.channels() == 1)
        grey = m;
      else
        return Status::error(std::string(side) + " image has " + std::to_string(m.channels()) +
                             " channels (only 1 or 3)");
    }
    *out = ImageU8(grey.cols, grey.rows);
    for (int v = 0; v < grey.rows; ++v)
      std::memcpy(out->row(v), grey.ptr<uint8_t>(v), static_cast<size_t>(grey.cols));
    return Status::ok();
  }
};

RawlogReader::~RawlogReader() = default;

const std::optional<std::string>& RawlogReader::syntheticOdometry() const {
  return impl_->synthetic_odometry;
}

std::string imagesDirectoryFor(const std::string& rawlog_path) {
  // MRPT's convention (CRawlog::detectImagesDirectory, whose fallback drops a path separator
  // in MRPT 2.5, so it is redone here).
  const fs::path p(rawlog_path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  for (const char* suffix : {"_Images", "_images", "_IMAGES"}) {
    const fs::path cand = dir / (p.stem().string() + suffix);
    std::error_code ec;
    if (fs::is_directory(cand, ec)) return cand.string();
  }
  return (dir / "Images").string();
}

namespace {
StereoRig rigFromObservation(const mrpt::obs::CObservationStereoImages& obs) {
  StereoRig rig;
  rig.width_px = static_cast<int>(obs.leftCamera.ncols);
  rig.height_px = static_cast<int>(obs.leftCamera.nrows);
  rig.fx_px = obs.leftCamera.fx();
  rig.fy_px = obs.leftCamera.fy();
  rig.cx_px = obs.leftCamera.cx();
  rig.cy_px = obs.leftCamera.cy();
  rig.baseline_m = mrpt::poses::CPose3D(obs.rightCameraPose).x();
  rig.T_b_cl = fromMrptPose(mrpt::poses::CPose3D(obs.cameraPose));
  return rig;
}

/// One line of an exception's text. MRPT's exceptions nest ("Original exception:") and carry
/// banners and back traces; the innermost "Message:" line says what went wrong.
std::string shortWhat(const std::exception& e) {
  std::istringstream in(e.what());
  std::string line;
  std::string message;
  while (std::getline(in, line)) {
    const size_t at = line.find("Message:");
    if (at != std::string::npos) message = line.substr(at + 8);
  }
  if (message.empty()) {
    message = e.what();
    message = message.substr(0, message.find('\n'));
  }
  message.erase(0, message.find_first_not_of(' '));
  constexpr size_t kMaxChars = 240;
  return message.size() > kMaxChars ? message.substr(0, kMaxChars) + "..." : message;
}

/// A bool as MRPT deserialised it: MRPT reads the byte straight into the bool, so a corrupt log
/// can leave a value other than 0 or 1, which C++ may not load as a bool (UBSan: "load of value
/// 129"). nullopt for such a byte.
std::optional<bool> storedBool(const bool& b) {
  unsigned char byte = 0;
  std::memcpy(&byte, &b, 1);
  if (byte > 1) return std::nullopt;
  return byte == 1;
}

/// MRPT's convention for rectified stereo images (CObservationStereoImages::areImagesRectified):
/// all distortion parameters zero. TwoCam's frontend needs rectified rows.
Status checkRectified(const mrpt::obs::CObservationStereoImages& obs) {
  for (const auto* cam : {&obs.leftCamera, &obs.rightCamera}) {
    for (double k : cam->dist) {
      if (k != 0.0) {
        return Status::error(
            std::string("stereo images are not rectified (") +
            (cam == &obs.leftCamera ? "left" : "right") +
            " camera has non-zero distortion; MRPT marks rectified pairs with zero distortion)");
      }
    }
  }
  return Status::ok();
}

/// Whether a later observation's calibration equals the log's rig (first observation). They are
/// stored doubles and a calibration does not change within a log, so only rounding is allowed.
bool sameCalibration(const StereoRig& a, const StereoRig& b) {
  constexpr double kRelTol = 1e-9;
  auto near = [&](double x, double y) {
    return std::abs(x - y) <= kRelTol * std::max({1.0, std::abs(x), std::abs(y)});
  };
  return a.width_px == b.width_px && a.height_px == b.height_px && near(a.fx_px, b.fx_px) &&
         near(a.fy_px, b.fy_px) && near(a.cx_px, b.cx_px) && near(a.cy_px, b.cy_px) &&
         near(a.baseline_m, b.baseline_m) && a.T_b_cl.isApprox(b.T_b_cl, kRelTol);
}
}  // namespace

namespace {
/// Ground truth must be finite and within kMaxLogCoordinateM: the evaluation converts
/// coordinates to integers (voxel keys, distinct-point counts). Odometry is delivered as read:
/// `twocam run` skips a frame with non-finite odometry with a warning (docs/recorded_data.md).
Status checkFinite(const LogFrame& frame) {
  const auto bad = [](double v) { return !std::isfinite(v) || std::abs(v) > kMaxLogCoordinateM; };
  std::ostringstream os;
  os.precision(17);
  if (frame.ground_truth) {
    const Eigen::Matrix4d& M = frame.ground_truth->T_w_b.matrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        if (!std::isfinite(M(r, c)) || (c == 3 && bad(M(r, c)))) {
          os << "ground-truth pose has a non-finite entry or a translation beyond "
             << kMaxLogCoordinateM << " m (" << M(0, 3) << ", " << M(1, 3) << ", " << M(2, 3)
             << ")";
          return Status::error(os.str());
        }
      }
    const ImageF32& d = frame.ground_truth->depth_left;
    for (float v : d.data) {
      if (!std::isfinite(v))
        return Status::error("ground-truth depth image has a non-finite value");
    }
  }
  return Status::ok();
}
}  // namespace

Status RawlogReader::open(const std::string& path, std::unique_ptr<RawlogReader>* out) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    return Status::error("cannot open log '" + path + "': no such file");
  std::unique_ptr<RawlogReader> r(new RawlogReader());
  r->impl_ = std::make_unique<Impl>();
  r->impl_->path = path;
  if (!r->impl_->stream.open(path)) return Status::error("cannot open log '" + path + "'");
  r->impl_->images_dir = imagesDirectoryFor(path);
  // Peek until the first stereo observation to learn the rig.
  int observations = 0;
  try {
    std::deque<mrpt::obs::CObservation::Ptr> seen;
    while (true) {
      auto o = r->impl_->read();
      if (!o) break;
      ++observations;
      seen.push_back(o);
      if (auto s = std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(o)) {
        if (Status st = checkRectified(*s); !st)
          return Status::error("log '" + path + "': " + st.message());
        r->rig_ = rigFromObservation(*s);
        r->impl_->rig_width_px = r->rig_.width_px;
        r->impl_->rig_height_px = r->rig_.height_px;
        r->impl_->stereo_label = s->sensorLabel;
        r->impl_->rig_known = true;
        break;
      }
    }
    for (auto it = seen.rbegin(); it != seen.rend(); ++it) r->impl_->pending.push_front(*it);
  } catch (const std::exception& e) {
    return Status::error("cannot read log '" + path +
                         "': corrupt, truncated or not an MRPT rawlog (" + shortWhat(e) + ")");
  }
  if (!r->impl_->rig_known) {
    return Status::error("log '" + path +
                         "' has no stereo images (no CObservationStereoImages among its " +
                         std::to_string(observations) + " observations)");
  }
  if (Status st = r->rig_.validate(); !st)
    return Status::error("log '" + path + "': bad stereo calibration: " + st.message());
  *out = std::move(r);
  return Status::ok();
}

bool RawlogReader::next(LogFrame* frame, Status* status) {
  *status = Status::ok();
  auto fail = [&](const std::string& message) {
    *status = Status::error("log '" + impl_->path + "', frame " + std::to_string(index_) + ": " +
                            message);
    return false;
  };
  if (impl_->deferred_error) {
    const std::string message = *impl_->deferred_error;
    impl_->deferred_error.reset();
    impl_->eof = true;
    impl_->pending.clear();
    return fail(message);
  }
  try {
    // Find the next stereo observation; odometry and ground truth with its time stamp that
    // come right after it (or right before) belong to the frame.
    std::optional<OdometrySample> odo_before;
    bool odo_before_synthetic = false;
    mrpt::obs::CObservationStereoImages::Ptr stereo;
    while (!stereo) {
      auto o = impl_->read();
      if (!o) {
        if (impl_->is_twocam && !impl_->saw_end_marker)
          *status = Status::error("log '" + impl_->path + "' ends without its end marker after " +
                                  std::to_string(index_) + " frames: truncated?");
        return false;
      }
      if (auto s = std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(o)) {
        if (s->sensorLabel == impl_->stereo_label) stereo = s;
      } else if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o)) {
        odo_before = OdometrySample{fromMrptTime(od->timestamp),
                                    Pose2{od->odometry.x(), od->odometry.y(), od->odometry.phi()}};
        odo_before_synthetic = od->sensorLabel == kSyntheticOdometryLabel;
      }
    }
    *frame = LogFrame();
    frame->index = index_;
    frame->stereo.t_ns = fromMrptTime(stereo->timestamp);
    if (odo_before && odo_before->t_ns == frame->stereo.t_ns) {
      frame->odometry = odo_before;
      frame->odometry_synthetic = odo_before_synthetic;
    }
    if (Status st = checkRectified(*stereo); !st) return fail(st.message());
    if (!sameCalibration(rigFromObservation(*stereo), rig_))
      return fail("stereo calibration differs from the first frame's");
    const std::optional<bool> has_right = storedBool(stereo->hasImageRight);
    if (!has_right)
      return fail("corrupt log: the stereo observation's hasImageRight is not 0 or 1");
    if (!*has_right) return fail("stereo observation has no right image");
    if (Status st = impl_->loadImage(stereo->imageLeft, "left", &frame->stereo.left); !st)
      return fail(st.message());
    if (Status st = impl_->loadImage(stereo->imageRight, "right", &frame->stereo.right); !st)
      return fail(st.message());
    const ImageU8& l = frame->stereo.left;
    const ImageU8& r = frame->stereo.right;
    const auto& lc = stereo->leftCamera;
    const auto& rc = stereo->rightCamera;
    if (l.width != static_cast<int>(lc.ncols) || l.height != static_cast<int>(lc.nrows) ||
        r.width != static_cast<int>(rc.ncols) || r.height != static_cast<int>(rc.nrows) ||
        l.width != r.width || l.height != r.height) {
      std::ostringstream os;
      os << "images " << l.width << "x" << l.height << " (left) / " << r.width << "x" << r.height
         << " (right) do not match the observation's calibration " << lc.ncols << "x" << lc.nrows
         << " / " << rc.ncols << "x" << rc.nrows << " (both images must have the calibrated size)";
      return fail(os.str());
    }
    // Following observations with the same time stamp.
    while (true) {
      mrpt::obs::CObservation::Ptr o;
      try {
        o = impl_->read();
      } catch (const BadSizeError&) {
        throw;  // the frame's own depth image: this frame fails
      } catch (const std::exception& e) {
        impl_->deferred_error = "corrupt or truncated log: " + shortWhat(e);
        break;
      }
      if (!o) break;
      if (fromMrptTime(o->timestamp) != frame->stereo.t_ns ||
          std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(o)) {
        impl_->pending.push_front(o);
        break;
      }
      if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o)) {
        frame->odometry = OdometrySample{
            frame->stereo.t_ns, Pose2{od->odometry.x(), od->odometry.y(), od->odometry.phi()}};
        frame->odometry_synthetic = od->sensorLabel == kSyntheticOdometryLabel;
      } else if (auto gp = std::dynamic_pointer_cast<mrpt::obs::CObservationRobotPose>(o)) {
        if (!frame->ground_truth) frame->ground_truth = GroundTruthFrame{};
        frame->ground_truth->t_ns = frame->stereo.t_ns;
        frame->ground_truth->T_w_b = fromMrptPose(gp->pose.mean);
      } else if (auto d = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(o)) {
        const std::optional<bool> has_range = storedBool(d->hasRangeImage);
        if (!has_range) throw BadSizeError("the depth image's hasRangeImage is not 0 or 1");
        if (d->sensorLabel != kGtDepthLabel || !*has_range) continue;
        d->load();
        if (!frame->ground_truth) frame->ground_truth = GroundTruthFrame{};
        auto& img = frame->ground_truth->depth_left;
        img = ImageF32(static_cast<int>(d->rangeImage.cols()),
                       static_cast<int>(d->rangeImage.rows()));
        for (int v = 0; v < img.height; ++v)
          for (int u = 0; u < img.width; ++u)
            img(u, v) =
                static_cast<float>(d->rangeImage(v, u) * static_cast<double>(d->rangeUnits));
      }
    }
  } catch (const std::exception& e) {
    impl_->eof = true;
    impl_->pending.clear();
    return fail("corrupt or truncated log: " + shortWhat(e));
  }
  if (Status st = checkFinite(*frame); !st) {
    impl_->eof = true;
    impl_->pending.clear();
    return fail(st.message());
  }
  ++index_;
  return true;
}

}  // namespace twocam::io
