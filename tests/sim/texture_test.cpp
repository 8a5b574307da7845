#include "sim/texture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <vector>

#include "common/random.h"
#include "support/test_paths.h"

namespace twocam::sim {
namespace {

/// Bilinear resampling of a tiled image may differ by one grey level between two tiles,
/// because the texel's position inside its tile is computed with a rounding error.
constexpr int kResampleGreyTol = 1;
/// Blob feature size may be off by this factor from scale_m: "blob size" is a loose notion
/// (mean-crossing spacing of a smooth random field), the test only guards against gross errors
/// such as a cell size in texels instead of metres.
constexpr double kFeatureSizeFactor = 2.0;

TextureSpec spec(TextureKind kind) {
  TextureSpec s;
  s.kind = kind;
  s.texels_per_m = 400.0;
  return s;
}

ImageU8 raster(const TextureSpec& s, double w_m, double h_m, uint64_t seed = 1) {
  std::mt19937_64 rng = makeRng(seed, RandomStream::kTextures);
  ImageU8 img;
  const Status st = rasterizeTexture(s, w_m, h_m, rng, &img);
  EXPECT_TRUE(st.isOk()) << st.message();
  return img;
}

double meanGrey(const ImageU8& img) {
  double sum = 0.0;
  for (uint8_t g : img.data) sum += g;
  return sum / static_cast<double>(img.data.size());
}

/// Mean length [texels] of runs above / below the mean grey along rows: for a smooth random
/// field this is the typical blob diameter.
double meanRunLengthPx(const ImageU8& img) {
  const double mean = meanGrey(img);
  int64_t crossings = 0;
  int64_t steps = 0;
  for (int v = 0; v < img.height; ++v) {
    for (int u = 1; u < img.width; ++u) {
      crossings += (img(u, v) > mean) != (img(u - 1, v) > mean);
      ++steps;
    }
  }
  return static_cast<double>(steps) / static_cast<double>(std::max<int64_t>(crossings, 1));
}

/// Harris corners (k = 0.04, 5x5 box window, 7x7 non-maximum suppression, response above
/// 1 % of the image's strongest): a plain reimplementation, to keep OpenCV out of the tests.
int countHarrisCorners(const ImageU8& img) {
  const int w = img.width;
  const int h = img.height;
  std::vector<double> ixx(static_cast<size_t>(w) * h, 0.0);
  std::vector<double> iyy(ixx.size(), 0.0);
  std::vector<double> ixy(ixx.size(), 0.0);
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      const double gx = 0.5 * (img(u + 1, v) - img(u - 1, v));
      const double gy = 0.5 * (img(u, v + 1) - img(u, v - 1));
      const size_t i = static_cast<size_t>(v) * w + u;
      ixx[i] = gx * gx;
      iyy[i] = gy * gy;
      ixy[i] = gx * gy;
    }
  }
  std::vector<double> r(ixx.size(), 0.0);
  constexpr int kWin = 2;
  for (int v = kWin + 1; v + kWin + 1 < h; ++v) {
    for (int u = kWin + 1; u + kWin + 1 < w; ++u) {
      double a = 0.0;
      double b = 0.0;
      double c = 0.0;
      for (int dv = -kWin; dv <= kWin; ++dv) {
        for (int du = -kWin; du <= kWin; ++du) {
          const size_t i = static_cast<size_t>(v + dv) * w + (u + du);
          a += ixx[i];
          b += iyy[i];
          c += ixy[i];
        }
      }
      r[static_cast<size_t>(v) * w + u] = a * b - c * c - 0.04 * (a + b) * (a + b);
    }
  }
  const double threshold = 0.01 * *std::max_element(r.begin(), r.end());
  int count = 0;
  constexpr int kNms = 3;
  for (int v = kNms; v + kNms < h; ++v) {
    for (int u = kNms; u + kNms < w; ++u) {
      const double x = r[static_cast<size_t>(v) * w + u];
      if (x <= threshold) continue;
      bool is_max = true;
      for (int dv = -kNms; dv <= kNms && is_max; ++dv) {
        for (int du = -kNms; du <= kNms; ++du) {
          if ((du != 0 || dv != 0) && r[static_cast<size_t>(v + dv) * w + (u + du)] >= x) {
            is_max = false;
            break;
          }
        }
      }
      count += is_max;
    }
  }
  return count;
}

TEST(RasterizeTexture, SizeFollowsTexelsPerMetre) {
  const ImageU8 img = raster(spec(TextureKind::kSolid), 2.0, 0.5);
  EXPECT_EQ(img.width, 800);
  EXPECT_EQ(img.height, 200);
  EXPECT_EQ(img.data.size(), 800u * 200u);
}

TEST(RasterizeTexture, LargeSurfaceIsCappedWithUniformTexelsPerMetre) {
  const ImageU8 img = raster(spec(TextureKind::kSolid), 20.0, 5.0);
  EXPECT_EQ(img.width, kMaxTextureSidePx);
  EXPECT_EQ(img.height, kMaxTextureSidePx / 4);
  const ImageU8 tall = raster(spec(TextureKind::kSolid), 0.5, 30.0);
  EXPECT_EQ(tall.height, kMaxTextureSidePx);
  EXPECT_EQ(tall.width, static_cast<int>(std::lround(0.5 * kMaxTextureSidePx / 30.0)));
}

TEST(RasterizeTexture, TinySurfaceHasAtLeastTwoTexelsPerSide) {
  const ImageU8 img = raster(spec(TextureKind::kBlobs), 0.001, 0.0001);
  EXPECT_EQ(img.width, 2);
  EXPECT_EQ(img.height, 2);
}

TEST(RasterizeTexture, RejectsBadSurfaceAndSpec) {
  std::mt19937_64 rng(1);
  ImageU8 img;
  EXPECT_FALSE(rasterizeTexture(spec(TextureKind::kSolid), 0.0, 1.0, rng, &img).isOk());
  TextureSpec bad = spec(TextureKind::kStripes);
  bad.duty = 1.0;
  EXPECT_FALSE(rasterizeTexture(bad, 1.0, 1.0, rng, &img).isOk());
  bad = spec(TextureKind::kChecker);
  bad.scale_m = 0.0;
  EXPECT_FALSE(rasterizeTexture(bad, 1.0, 1.0, rng, &img).isOk());
}

TEST(RasterizeTexture, RandomKindsAreDeterministicPerSeed) {
  for (TextureKind kind : {TextureKind::kBlobs, TextureKind::kBricks}) {
    const ImageU8 a = raster(spec(kind), 1.0, 0.6, 7);
    const ImageU8 b = raster(spec(kind), 1.0, 0.6, 7);
    const ImageU8 c = raster(spec(kind), 1.0, 0.6, 8);
    EXPECT_EQ(a.data, b.data) << "kind " << static_cast<int>(kind);
    EXPECT_NE(a.data, c.data) << "kind " << static_cast<int>(kind);
  }
}

TEST(RasterizeTexture, StripesArePeriodicAlongUAndConstantAlongV) {
  TextureSpec s = spec(TextureKind::kStripes);
  s.scale_m = 0.05;  // 20 texels
  s.duty = 0.3;
  const ImageU8 img = raster(s, 1.0, 0.25);
  const int period_px = 20;
  int dark = 0;
  for (int u = 0; u < img.width; ++u) {
    if (u + period_px < img.width) {
      EXPECT_EQ(img(u, 0), img(u + period_px, 0)) << "u " << u;
    }
    dark += img(u, 0) == static_cast<uint8_t>(s.grey_low);
    for (int v = 1; v < img.height; ++v) ASSERT_EQ(img(u, v), img(u, 0)) << "u " << u << " v " << v;
  }
  // Exactly 6 of every 20 texel centres fall in the dark 30 % of the period.
  EXPECT_EQ(dark, img.width * 6 / period_px);
  // And it is not trivially periodic with a shorter period.
  bool shorter_period = true;
  for (int u = 0; u + period_px / 2 < img.width; ++u) {
    shorter_period = shorter_period && img(u, 0) == img(u + period_px / 2, 0);
  }
  EXPECT_FALSE(shorter_period);
}

TEST(RasterizeTexture, CheckerSquaresHaveScaleSide) {
  TextureSpec s = spec(TextureKind::kChecker);
  s.scale_m = 0.05;  // 20 texels
  const ImageU8 img = raster(s, 0.5, 0.3);
  for (int v = 0; v < img.height; ++v) {
    for (int u = 0; u < img.width; ++u) {
      const bool low = ((u / 20) + (v / 20)) % 2 == 0;
      ASSERT_EQ(img(u, v), static_cast<uint8_t>(low ? s.grey_low : s.grey_high))
          << "u " << u << " v " << v;
    }
  }
}

TEST(RasterizeTexture, GradientIsMonotonicAlongItsAxis) {
  TextureSpec s = spec(TextureKind::kGradient);
  for (bool along_u : {true, false}) {
    s.gradient_along_u = along_u;
    const ImageU8 img = raster(s, 0.8, 0.6);
    for (int v = 0; v < img.height; ++v) {
      for (int u = 0; u < img.width; ++u) {
        if (along_u) {
          if (u > 0) {
            ASSERT_GE(img(u, v), img(u - 1, v));
          }
          ASSERT_EQ(img(u, v), img(u, 0));
        } else {
          if (v > 0) {
            ASSERT_GE(img(u, v), img(u, v - 1));
          }
          ASSERT_EQ(img(u, v), img(0, v));
        }
      }
    }
    // The ends reach the requested grey levels to within half a texel's step.
    const uint8_t first = img(0, 0);
    const uint8_t last = img(img.width - 1, img.height - 1);
    EXPECT_NEAR(first, s.grey_low, 1.0);
    EXPECT_NEAR(last, s.grey_high, 1.0);
  }
}

TEST(RasterizeTexture, SolidIsMidGrey) {
  const TextureSpec s = spec(TextureKind::kSolid);
  const ImageU8 img = raster(s, 0.3, 0.3);
  for (uint8_t g : img.data) ASSERT_EQ(g, 130);  // (40 + 220) / 2
}

TEST(RasterizeTexture, BricksHaveMortarLinesAndRunningBond) {
  TextureSpec s = spec(TextureKind::kBricks);
  s.scale_m = 0.2;          // brick 80 texels + mortar 4 = 84 pitch
  s.brick_height_m = 0.07;  // 28 texels + 4 mortar = 32 pitch
  s.mortar_m = 0.01;
  const ImageU8 img = raster(s, 1.0, 0.64);
  // Mortar rows: the first 4 texel rows of every 32.
  for (int v = 0; v < img.height; v += 32) {
    for (int u = 0; u < img.width; ++u) ASSERT_EQ(img(u, v), static_cast<uint8_t>(s.grey_low));
  }
  // Bricks are bright with a slight per-brick variation, never as dark as mortar.
  const int mid_row = 16;
  int mortar_joints = 0;
  for (int u = 0; u < img.width; ++u) {
    const uint8_t g = img(u, mid_row);
    if (g == static_cast<uint8_t>(s.grey_low)) {
      ++mortar_joints;
    } else {
      EXPECT_GE(g, s.grey_high - 0.2 * (s.grey_high - s.grey_low));
      EXPECT_LE(g, s.grey_high);
    }
  }
  EXPECT_EQ(mortar_joints, 4 * ((img.width + 83) / 84));
  // Running bond: the next course's joints are offset by half a brick pitch (42 texels).
  EXPECT_EQ(img(0, mid_row), static_cast<uint8_t>(s.grey_low));
  EXPECT_NE(img(0, mid_row + 32), static_cast<uint8_t>(s.grey_low));
  EXPECT_EQ(img(42, mid_row + 32), static_cast<uint8_t>(s.grey_low));
}

TEST(RasterizeTexture, BlobsSpanTheGreyRangeWithFeaturesNearScale) {
  TextureSpec s = spec(TextureKind::kBlobs);
  s.scale_m = 0.08;  // 32 texels
  const double w_m = 1.5;
  const double h_m = 1.0;
  const ImageU8 img = raster(s, w_m, h_m, 3);
  std::vector<uint8_t> sorted = img.data;
  std::sort(sorted.begin(), sorted.end());
  const auto pct = [&sorted](double p) {
    return static_cast<double>(sorted[static_cast<size_t>(p * (sorted.size() - 1))]);
  };
  // The 2nd and 98th percentiles are stretched onto grey_low and grey_high.
  constexpr double kPercentileGreyTol = 2.0;  // subsampled percentile plus rounding
  EXPECT_NEAR(pct(0.02), s.grey_low, kPercentileGreyTol);
  EXPECT_NEAR(pct(0.98), s.grey_high, kPercentileGreyTol);
  // A broad spread, not two levels: the interquartile range is a good part of the range.
  EXPECT_GT(pct(0.75) - pct(0.25), 0.25 * (s.grey_high - s.grey_low));

  const double feature_m = meanRunLengthPx(img) / s.texels_per_m;
  EXPECT_GT(feature_m, s.scale_m / kFeatureSizeFactor);
  EXPECT_LT(feature_m, s.scale_m * kFeatureSizeFactor);

  // Rich texture: several Harris corners per scale_m^2 (6.6 measured with seed 3; the floor
  // leaves a factor 3 for other seeds and detector settings).
  constexpr double kMinCornersPerScaleSq = 2.0;
  const int corners = countHarrisCorners(img);
  const double floor_count = kMinCornersPerScaleSq * w_m * h_m / (s.scale_m * s.scale_m);
  EXPECT_GT(corners, floor_count);
  std::cout << "[          ] blobs scale " << s.scale_m << " m: mean run " << feature_m << " m, "
            << corners << " Harris corners on " << w_m * h_m << " m^2 ("
            << corners * s.scale_m * s.scale_m / (w_m * h_m) << " per scale^2)\n";
}

TEST(RasterizeTexture, BlobFeatureSizeFollowsScale) {
  // Doubling scale_m doubles the feature size (in texels), whatever the texel density.
  TextureSpec s = spec(TextureKind::kBlobs);
  s.scale_m = 0.04;
  const double small = meanRunLengthPx(raster(s, 1.0, 1.0, 5));
  s.scale_m = 0.08;
  const double large = meanRunLengthPx(raster(s, 1.0, 1.0, 5));
  constexpr double kRatioTol = 0.25;  // different random fields: about 10 % scatter measured
  EXPECT_NEAR(large / small, 2.0, 2.0 * kRatioTol);
}

TEST(RasterizeTexture, MissingImageFileIsAnError) {
  TextureSpec s = spec(TextureKind::kImage);
  s.file = "no_such_texture.png";
  s.resolved_path = "/nonexistent/folder/no_such_texture.png";
  std::mt19937_64 rng(1);
  ImageU8 img;
  const Status st = rasterizeTexture(s, 1.0, 1.0, rng, &img);
  EXPECT_FALSE(st.isOk());
  EXPECT_NE(st.message().find("no_such_texture.png"), std::string::npos) << st.message();
}

TEST(RasterizeTexture, ImageIsTiledWithTileWidthScale) {
  // A 16 x 8 binary PGM (written by hand, no OpenCV in tests) with a unique grey per pixel.
  const std::string dir = test::makeTempDir("texture_image");
  const std::string path = dir + "/tile.pgm";
  {
    std::ofstream f(path, std::ios::binary);
    f << "P5\n16 8\n255\n";
    for (int v = 0; v < 8; ++v) {
      for (int u = 0; u < 16; ++u) f.put(static_cast<char>(u * 8 + v * 16 + 10));
    }
  }
  TextureSpec s = spec(TextureKind::kImage);
  s.file = "tile.pgm";
  s.resolved_path = path;
  s.scale_m = 0.1;  // tile 40 x 20 texels
  const ImageU8 img = raster(s, 0.5, 0.3);
  ASSERT_EQ(img.width, 200);
  ASSERT_EQ(img.height, 120);
  for (int v = 0; v + 20 < img.height; ++v) {
    for (int u = 0; u + 40 < img.width; ++u) {
      ASSERT_NEAR(img(u, v), img(u + 40, v), kResampleGreyTol) << "u " << u << " v " << v;
      ASSERT_NEAR(img(u, v), img(u, v + 20), kResampleGreyTol) << "u " << u << " v " << v;
    }
  }
  // Inside a tile the image is magnified 2.5x and sampled bilinearly; the image is linear in
  // the pixel coordinates, so bilinear sampling reproduces grey = 10 + 8 x + 16 y exactly.
  const double x = (13.5 / 40.0) * 16.0 - 0.5;
  const double y = (8.5 / 20.0) * 8.0 - 0.5;
  EXPECT_NEAR(img(13, 8), 10.0 + 8.0 * x + 16.0 * y, kResampleGreyTol);
}

}  // namespace
}  // namespace twocam::sim
