#pragma once
/// The stereo-rig simulator: a world in, one stereo frame, odometry sample and ground truth
/// out per call. Emits the same StereoFrame / OdometrySample structs a log reader does.

#include <cstdint>
#include <memory>

#include "common/frames.h"
#include "common/status.h"
#include "sim/motion.h"
#include "sim/renderer.h"
#include "sim/world.h"

namespace twocam::sim {

/// Time stamp of frame 0 [ns]. Not zero, because MRPT treats a zero time stamp as invalid.
constexpr int64_t kStartTimeNs = 1'000'000'000;
/// Resolution of MRPT's clock [ns]; simulated time stamps are multiples of it.
constexpr int64_t kMrptTickNs = 100;

/// One simulated frame.
struct SimFrame {
  int index = 0;
  StereoFrame stereo;
  OdometrySample odometry;
  GroundTruthFrame ground_truth;
  RenderStats render_stats;
};

/// Applies the image formation model to a noise-free rendering:
/// observed = clamp(round(gain * clean + offset + N(0, sigma^2)), 0, 255).
/// The noise comes from an OpenCV RNG seeded with noise_seed (same seed, same image).
void applyImageNoise(const ImageU8& clean,
                     const CameraRadiometry& radiometry,
                     double sigma_grey,
                     uint64_t noise_seed,
                     ImageU8* observed);

class Simulator {
 public:
  /// Tessellates the world, rasterises its textures and opens the renderer.
  static Status create(const World& world,
                       const RendererOptions& options,
                       std::unique_ptr<Simulator>* out);

  /// Simulates the next frame (0, 1, 2, ...).
  void next(SimFrame* frame);

  const World& world() const { return world_; }
  const StereoRenderer& renderer() const { return *renderer_; }

 private:
  Simulator(World world, std::unique_ptr<StereoRenderer> renderer);
  World world_;
  std::unique_ptr<StereoRenderer> renderer_;
  MotionSimulator motion_;
  int frame_index_ = 0;
  ImageU8 clean_left_, clean_right_;
};

}  // namespace twocam::sim
