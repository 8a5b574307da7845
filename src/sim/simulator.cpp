#include "sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "common/random.h"

namespace twocam::sim {

void applyImageNoise(const ImageU8& clean,
                     const CameraRadiometry& radiometry,
                     double sigma_grey,
                     uint64_t noise_seed,
                     ImageU8* observed) {
  const cv::Mat in(clean.height, clean.width, CV_8UC1, const_cast<uint8_t*>(clean.data.data()));
  cv::Mat f;
  in.convertTo(f, CV_32F, radiometry.gain, radiometry.offset_grey);
  if (sigma_grey > 0.0) {
    cv::Mat noise(f.size(), CV_32F);
    cv::RNG rng(noise_seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma_grey);
    f += noise;
  }
  *observed = ImageU8(clean.width, clean.height);
  cv::Mat out(clean.height, clean.width, CV_8UC1, observed->data.data());
  f.convertTo(out, CV_8U);  // rounds and saturates to [0, 255]
}

Simulator::Simulator(World world, std::unique_ptr<StereoRenderer> renderer)
    : world_(std::move(world)),
      renderer_(std::move(renderer)),
      motion_(world_.robot, world_.odometry_noise, world_.seed, kStartTimeNs) {}

Status Simulator::create(const World& world,
                         const RendererOptions& options,
                         std::unique_ptr<Simulator>* out) {
  if (Status st = world.validate(); !st) return st;
  std::mt19937_64 texture_rng =
      makeRng(world.texture_seed.value_or(world.seed), RandomStream::kTextures);
  std::vector<TexturedMesh> meshes;
  if (Status st = buildMeshes(world, texture_rng, &meshes); !st) return st;
  std::unique_ptr<StereoRenderer> renderer;
  if (Status st = StereoRenderer::create(world, std::move(meshes), options, &renderer); !st)
    return st;
  out->reset(new Simulator(world, std::move(renderer)));
  return Status::ok();
}

void Simulator::next(SimFrame* frame) {
  const MotionSample m = motion_.next();
  frame->index = frame_index_;
  frame->stereo.t_ns = m.t_ns;
  frame->odometry.t_ns = m.t_ns;
  frame->odometry.pose = m.odom_pose;
  frame->ground_truth.t_ns = m.t_ns;
  frame->ground_truth.T_w_b = toIsometry(m.true_pose);
  const Eigen::Isometry3d T_w_cl = frame->ground_truth.T_w_b * world_.rig.T_b_cl;
  renderer_->render(
      T_w_cl, &clean_left_, &clean_right_, &frame->ground_truth.depth_left, &frame->render_stats);
  // One noise seed per frame and camera from the image-noise stream.
  std::mt19937_64 rng =
      makeRng(world_.seed, RandomStream::kImageNoise, static_cast<uint64_t>(frame_index_));
  const uint64_t seed_left = rng(), seed_right = rng();
  applyImageNoise(clean_left_,
                  world_.image_noise.left,
                  world_.image_noise.sigma_grey,
                  seed_left,
                  &frame->stereo.left);
  applyImageNoise(clean_right_,
                  world_.image_noise.right,
                  world_.image_noise.sigma_grey,
                  seed_right,
                  &frame->stereo.right);
  ++frame_index_;
}

}  // namespace twocam::sim
