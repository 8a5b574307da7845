#pragma once
/// Inputs shared by the frontend benchmarks: a seeded synthetic 640x480 rectified stereo pair
/// (blurred random texture, three fronto-parallel layers at known disparities, sensor noise),
/// built once outside the timed loops so every benchmark times the same pixels.

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/image.h"
#include "frontend/cv_interop.h"

namespace twocam::bench {

constexpr int kBenchWidth = 640;
constexpr int kBenchHeight = 480;
constexpr uint64_t kBenchSeed = 20261122;

struct BenchStereoPair {
  ImageU8 left;
  ImageU8 right;
  /// True disparity of every left pixel [px] (integer layers).
  ImageF32 disparity;
};

/// Texture with features at a few pixels' scale: uniform noise blurred with sigma 1.5 px,
/// contrast stretched to [0, 255].
inline cv::Mat benchTexture(cv::RNG& rng, int width, int height) {
  cv::Mat noise(height, width, CV_32F);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  cv::Mat out;
  cv::normalize(noise, noise, 0.0, 255.0, cv::NORM_MINMAX);
  noise.convertTo(out, CV_8U);
  return out;
}

/// The pair: background at 8 px, a box at 24 px and a nearer box at 48 px disparity.
inline const BenchStereoPair& benchStereoPair() {
  static const BenchStereoPair kPair = [] {
    cv::RNG rng(kBenchSeed);
    struct Layer {
      cv::Rect rect;
      int d_px;
    };
    const Layer layers[] = {{cv::Rect(0, 0, kBenchWidth, kBenchHeight), 8},
                            {cv::Rect(120, 80, 260, 220), 24},
                            {cv::Rect(330, 200, 200, 200), 48}};
    cv::Mat left(kBenchHeight, kBenchWidth, CV_8U, cv::Scalar(0));
    cv::Mat right(kBenchHeight, kBenchWidth, CV_8U, cv::Scalar(0));
    cv::Mat disp(kBenchHeight, kBenchWidth, CV_32F, cv::Scalar(0));
    // Painter's order: each layer's texture is drawn in the left image at its rectangle and in
    // the right image shifted left by its disparity, so nearer layers occlude farther ones.
    for (const Layer& layer : layers) {
      const int d = layer.d_px;
      // texel(i) with i = x + d shows at left column rect.x + x and at right column rect.x + x - d.
      const cv::Mat tex = benchTexture(rng, layer.rect.width + 2 * d, layer.rect.height);
      const bool background = layer.rect.x == 0 && layer.rect.width == kBenchWidth;
      for (int v = 0; v < layer.rect.height; ++v) {
        const int row = layer.rect.y + v;
        for (int x = 0; x < layer.rect.width; ++x) {
          left.at<uint8_t>(row, layer.rect.x + x) = tex.at<uint8_t>(v, x + d);
          disp.at<float>(row, layer.rect.x + x) = static_cast<float>(d);
        }
        // The background extends beyond the left camera's view, so it fills the right image's
        // last d columns too; boxes end where they end.
        const int x_end = background ? layer.rect.width + d : layer.rect.width;
        for (int x = 0; x < x_end; ++x) {
          const int ur = layer.rect.x + x - d;
          if (ur >= 0 && ur < kBenchWidth) right.at<uint8_t>(row, ur) = tex.at<uint8_t>(v, x + d);
        }
      }
    }
    cv::Mat noise(kBenchHeight, kBenchWidth, CV_16S);
    for (cv::Mat* img : {&left, &right}) {
      rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
      cv::Mat img16;
      img->convertTo(img16, CV_16S);
      img16 += noise;
      img16.convertTo(*img, CV_8U);
    }
    BenchStereoPair p;
    p.left = frontend::toImageU8(left);
    p.right = frontend::toImageU8(right);
    p.disparity = frontend::toImageF32(disp);
    return p;
  }();
  return kPair;
}

}  // namespace twocam::bench
