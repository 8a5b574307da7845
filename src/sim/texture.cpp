#include "sim/texture.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>

#include "common/quiet_stderr.h"

namespace twocam::sim {

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

/// Blobs: coarse random grid cell as a fraction of scale_m. Cubic interpolation of i.i.d.
/// values crosses the mean on average every 2 cells, so blobs are about scale_m across.
constexpr double kBlobCellPerScale = 0.5;
/// Blobs: amplitude of the second octave (half the cell size) relative to the first; adds
/// fine detail (more corners) without changing the dominant size.
constexpr double kBlobDetailAmplitude = 0.35;
/// Blobs: percentiles mapped to grey_low and grey_high; robust to the few extreme texels.
constexpr double kBlobLowPercentile = 0.02;
constexpr double kBlobHighPercentile = 0.98;
/// Blobs: at most this many texels are sorted to find the percentiles.
constexpr size_t kPercentileSamples = 1 << 20;
/// Bricks: largest darkening of one brick, as a fraction of grey_high - grey_low.
constexpr double kBrickGreyVariation = 0.12;

/// Texel grid of a surface: size and the metres-to-texel scales actually used per axis.
struct TexelGrid {
  int width_px = 0;
  int height_px = 0;
  double u_px_per_m = 0.0;
  double v_px_per_m = 0.0;
  /// Surface coordinates of texel centres measured from the (-w/2, -h/2) corner [m].
  [[nodiscard]] double uOf(int i) const { return (i + 0.5) / u_px_per_m; }
  [[nodiscard]] double vOf(int j) const { return (j + 0.5) / v_px_per_m; }
};

TexelGrid makeGrid(double width_m, double height_m, double texels_per_m) {
  const double longest_m = std::max(width_m, height_m);
  const double tpm = std::min(texels_per_m, kMaxTextureSidePx / longest_m);
  auto side = [tpm](double len_m) {
    return std::clamp(static_cast<int>(std::lround(len_m * tpm)), 2, kMaxTextureSidePx);
  };
  TexelGrid g;
  g.width_px = side(width_m);
  g.height_px = side(height_m);
  // The texture spans the surface exactly, so the per-axis scale follows the rounded size.
  g.u_px_per_m = g.width_px / width_m;
  g.v_px_per_m = g.height_px / height_m;
  return g;
}

uint8_t toGrey(double g) { return cv::saturate_cast<uint8_t>(g); }

/// Mean-zero random field with cells of cell_m, resampled onto the texel grid.
cv::Mat randomOctave(const TexelGrid& g, double cell_m, std::mt19937_64& rng) {
  // Detail below one texel cannot be shown; clamping also bounds the coarse grid's size.
  cell_m = std::max(cell_m, 1.0 / std::min(g.u_px_per_m, g.v_px_per_m));
  // Cells in texels along each axis; the grid gets a margin cell before and two after the
  // surface so cubic interpolation has all four neighbours everywhere.
  const double cell_u_px = cell_m * g.u_px_per_m;
  const double cell_v_px = cell_m * g.v_px_per_m;
  const int nu = static_cast<int>(std::ceil(g.width_px / cell_u_px)) + 4;
  const int nv = static_cast<int>(std::ceil(g.height_px / cell_v_px)) + 4;
  cv::Mat coarse(nv, nu, CV_32F);
  std::uniform_real_distribution<float> uniform(-0.5F, 0.5F);
  for (int r = 0; r < nv; ++r) {
    auto* row = coarse.ptr<float>(r);
    for (int c = 0; c < nu; ++c) row[c] = uniform(rng);
  }
  // Resample with an explicit map (texel centre u -> coarse coordinate u / cell + 1.5, past the
  // margin) rather than cv::resize, so the cell size is exact in metres whatever the rounding
  // of the texel grid. When cells are smaller than texels the result is aliased noise, which
  // is what such a surface looks like from afar anyway.
  cv::Mat map_u(g.height_px, g.width_px, CV_32F);
  cv::Mat map_v(g.height_px, g.width_px, CV_32F);
  for (int j = 0; j < g.height_px; ++j) {
    auto* mu = map_u.ptr<float>(j);
    auto* mv = map_v.ptr<float>(j);
    const float cv_j = static_cast<float>((j + 0.5) / cell_v_px + 1.5);
    for (int i = 0; i < g.width_px; ++i) {
      mu[i] = static_cast<float>((i + 0.5) / cell_u_px + 1.5);
      mv[i] = cv_j;
    }
  }
  cv::Mat fine;
  cv::remap(coarse, fine, map_u, map_v, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
  return fine;
}

void rasterizeBlobs(const TextureSpec& spec,
                    const TexelGrid& g,
                    std::mt19937_64& rng,
                    ImageU8* out) {
  const double cell_m = kBlobCellPerScale * spec.scale_m;
  cv::Mat field = randomOctave(g, cell_m, rng);
  field += kBlobDetailAmplitude * randomOctave(g, 0.5 * cell_m, rng);

  // Robust stretch to [grey_low, grey_high] from percentiles of a subsample.
  const auto total = static_cast<size_t>(field.total());
  const size_t stride = std::max<size_t>(1, total / kPercentileSamples);
  std::vector<float> samples;
  samples.reserve(total / stride + 1);
  const auto* data = field.ptr<float>(0);  // continuous: made by remap
  for (size_t k = 0; k < total; k += stride) samples.push_back(data[k]);
  auto percentile = [&samples](double p) {
    const auto idx = static_cast<size_t>(p * static_cast<double>(samples.size() - 1));
    std::nth_element(
        samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(idx), samples.end());
    return static_cast<double>(samples[idx]);
  };
  const double lo = percentile(kBlobLowPercentile);
  const double hi = percentile(kBlobHighPercentile);
  const double gain = hi > lo ? (spec.grey_high - spec.grey_low) / (hi - lo) : 0.0;
  for (int j = 0; j < g.height_px; ++j) {
    const auto* src = field.ptr<float>(j);
    uint8_t* dst = out->row(j);
    for (int i = 0; i < g.width_px; ++i) {
      const double v = spec.grey_low + gain * (src[i] - lo);
      dst[i] = toGrey(std::clamp(
          v, std::min(spec.grey_low, spec.grey_high), std::max(spec.grey_low, spec.grey_high)));
    }
  }
}

void rasterizeChecker(const TextureSpec& spec, const TexelGrid& g, ImageU8* out) {
  for (int j = 0; j < g.height_px; ++j) {
    const auto row_cell = static_cast<int64_t>(std::floor(g.vOf(j) / spec.scale_m));
    uint8_t* dst = out->row(j);
    for (int i = 0; i < g.width_px; ++i) {
      const auto col_cell = static_cast<int64_t>(std::floor(g.uOf(i) / spec.scale_m));
      dst[i] = toGrey(((row_cell + col_cell) % 2 == 0) ? spec.grey_low : spec.grey_high);
    }
  }
}

void rasterizeStripes(const TextureSpec& spec, const TexelGrid& g, ImageU8* out) {
  std::vector<uint8_t> line(static_cast<size_t>(g.width_px));
  for (int i = 0; i < g.width_px; ++i) {
    const double phase = g.uOf(i) / spec.scale_m;
    const bool dark = phase - std::floor(phase) < spec.duty;
    line[static_cast<size_t>(i)] = toGrey(dark ? spec.grey_low : spec.grey_high);
  }
  for (int j = 0; j < g.height_px; ++j) std::copy(line.begin(), line.end(), out->row(j));
}

void rasterizeBricks(const TextureSpec& spec,
                     const TexelGrid& g,
                     std::mt19937_64& rng,
                     ImageU8* out) {
  const double pitch_u = spec.scale_m + spec.mortar_m;
  const double pitch_v = spec.brick_height_m + spec.mortar_m;
  const int rows = static_cast<int>(std::ceil(g.height_px / g.v_px_per_m / pitch_v)) + 1;
  // One extra brick per row for the half-brick offset of odd rows.
  const int cols = static_cast<int>(std::ceil(g.width_px / g.u_px_per_m / pitch_u)) + 2;
  std::uniform_real_distribution<double> darken(0.0, kBrickGreyVariation);
  std::vector<double> brick_grey(static_cast<size_t>(rows) * cols);
  for (double& b : brick_grey) b = spec.grey_high - darken(rng) * (spec.grey_high - spec.grey_low);

  for (int j = 0; j < g.height_px; ++j) {
    const double v = g.vOf(j);
    const int row = std::min(rows - 1, static_cast<int>(std::floor(v / pitch_v)));
    const bool mortar_row = v - row * pitch_v < spec.mortar_m;
    const double offset = (row % 2 == 1) ? 0.5 * pitch_u : 0.0;
    uint8_t* dst = out->row(j);
    for (int i = 0; i < g.width_px; ++i) {
      const double u = g.uOf(i) + offset;
      const int col = std::min(cols - 1, static_cast<int>(std::floor(u / pitch_u)));
      const bool mortar = mortar_row || u - col * pitch_u < spec.mortar_m;
      dst[i] = toGrey(mortar ? spec.grey_low : brick_grey[static_cast<size_t>(row) * cols + col]);
    }
  }
}

void rasterizeGradient(const TextureSpec& spec, const TexelGrid& g, ImageU8* out) {
  const double range = spec.grey_high - spec.grey_low;
  for (int j = 0; j < g.height_px; ++j) {
    uint8_t* dst = out->row(j);
    for (int i = 0; i < g.width_px; ++i) {
      const double t = spec.gradient_along_u ? (i + 0.5) / g.width_px : (j + 0.5) / g.height_px;
      dst[i] = toGrey(spec.grey_low + t * range);
    }
  }
}

Status rasterizeImage(const TextureSpec& spec, const TexelGrid& g, ImageU8* out) {
  const std::string& path = spec.resolved_path.empty() ? spec.file : spec.resolved_path;
  cv::Mat img = imreadQuietly(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) {
    return Status::error("texture image '" + path + "' (file '" + spec.file +
                         "') cannot be read as an image");
  }
  const double tile_w_m = spec.scale_m;
  const double tile_h_m = spec.scale_m * img.rows / img.cols;
  // Shrink the image to the tile's texel size first: area averaging avoids the aliasing that
  // point sampling a large photo onto few texels would cause.
  const int tile_w_px = std::max(1, static_cast<int>(std::lround(tile_w_m * g.u_px_per_m)));
  const int tile_h_px = std::max(1, static_cast<int>(std::lround(tile_h_m * g.v_px_per_m)));
  if (tile_w_px < img.cols || tile_h_px < img.rows) {
    cv::Mat small;
    cv::resize(img,
               small,
               cv::Size(std::min(tile_w_px, img.cols), std::min(tile_h_px, img.rows)),
               0.0,
               0.0,
               cv::INTER_AREA);
    img = small;
  }
  // Texel centre (u, v) -> image pixel coordinates inside the tile, wrapped.
  cv::Mat map_u(g.height_px, g.width_px, CV_32F);
  cv::Mat map_v(g.height_px, g.width_px, CV_32F);
  for (int j = 0; j < g.height_px; ++j) {
    const double tv = g.vOf(j) / tile_h_m;
    const auto y = static_cast<float>((tv - std::floor(tv)) * img.rows - 0.5);
    auto* mu = map_u.ptr<float>(j);
    auto* mv = map_v.ptr<float>(j);
    for (int i = 0; i < g.width_px; ++i) {
      const double tu = g.uOf(i) / tile_w_m;
      mu[i] = static_cast<float>((tu - std::floor(tu)) * img.cols - 0.5);
      mv[i] = y;
    }
  }
  cv::Mat texture;
  cv::remap(img, texture, map_u, map_v, cv::INTER_LINEAR, cv::BORDER_WRAP);
  for (int j = 0; j < g.height_px; ++j) {
    const auto* src = texture.ptr<uint8_t>(j);
    std::copy(src, src + g.width_px, out->row(j));
  }
  return Status::ok();
}

}  // namespace

Status rasterizeTexture(
    const TextureSpec& spec, double width_m, double height_m, std::mt19937_64& rng, ImageU8* out) {
  TWOCAM_CHECK(out != nullptr) << "rasterizeTexture needs an output image";
  if (!(width_m > 0.0 && height_m > 0.0 && std::isfinite(width_m) && std::isfinite(height_m))) {
    std::ostringstream msg;
    msg << "texture surface is " << width_m << " m x " << height_m << " m; both must be > 0";
    return Status::error(msg.str());
  }
  if (!(spec.texels_per_m > 0.0)) {
    std::ostringstream msg;
    msg << "texels_per_m = " << spec.texels_per_m << "; must be > 0";
    return Status::error(msg.str());
  }
  const bool needs_scale = spec.kind != TextureKind::kGradient && spec.kind != TextureKind::kSolid;
  if (needs_scale && !(spec.scale_m > 0.0)) {
    std::ostringstream msg;
    msg << "texture scale_m = " << spec.scale_m << "; must be > 0";
    return Status::error(msg.str());
  }
  if (spec.kind == TextureKind::kStripes && !(spec.duty > 0.0 && spec.duty < 1.0)) {
    std::ostringstream msg;
    msg << "stripes duty = " << spec.duty << "; must be in (0, 1)";
    return Status::error(msg.str());
  }
  if (spec.kind == TextureKind::kBricks && !(spec.brick_height_m > 0.0 && spec.mortar_m >= 0.0)) {
    std::ostringstream msg;
    msg << "bricks brick_height_m = " << spec.brick_height_m << ", mortar_m = " << spec.mortar_m
        << "; need brick_height_m > 0 and mortar_m >= 0";
    return Status::error(msg.str());
  }

  const TexelGrid g = makeGrid(width_m, height_m, spec.texels_per_m);
  ImageU8 img(g.width_px, g.height_px);
  switch (spec.kind) {
    case TextureKind::kBlobs:
      rasterizeBlobs(spec, g, rng, &img);
      break;
    case TextureKind::kChecker:
      rasterizeChecker(spec, g, &img);
      break;
    case TextureKind::kStripes:
      rasterizeStripes(spec, g, &img);
      break;
    case TextureKind::kBricks:
      rasterizeBricks(spec, g, rng, &img);
      break;
    case TextureKind::kGradient:
      rasterizeGradient(spec, g, &img);
      break;
    case TextureKind::kSolid:
      std::fill(img.data.begin(), img.data.end(), toGrey(0.5 * (spec.grey_low + spec.grey_high)));
      break;
    case TextureKind::kImage: {
      const Status s = rasterizeImage(spec, g, &img);
      if (!s.isOk()) return s;
      break;
    }
  }
  *out = std::move(img);
  return Status::ok();
}

}  // namespace twocam::sim
