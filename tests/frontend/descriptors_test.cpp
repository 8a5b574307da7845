#include "frontend/descriptors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace twocam::frontend {
namespace {

constexpr int kWidth = 200;
constexpr int kHeight = 120;
/// A brightness change (gain and offset) leaves 1 - NCC at 0 up to int8 quantisation.
constexpr double kQuantisationTol = 0.02;

/// Smoothed random texture: every corner has a distinctive neighbourhood.
ImageU8 texture(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> grey(0, 255);
  ImageU8 raw(kWidth, kHeight);
  for (auto& p : raw.data) p = static_cast<uint8_t>(grey(rng));
  ImageU8 out(kWidth, kHeight);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      int sum = 0, n = 0;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const int uu = std::clamp(u + du, 0, kWidth - 1), vv = std::clamp(v + dv, 0, kHeight - 1);
          sum += raw(uu, vv);
          ++n;
        }
      }
      out(u, v) = static_cast<uint8_t>(sum / n);
    }
  }
  return out;
}

/// The image shifted by (du, dv) px: out(u, v) = in(u - du, v - dv), edges clamped.
ImageU8 shifted(const ImageU8& in, int du, int dv) {
  ImageU8 out(in.width, in.height);
  for (int v = 0; v < in.height; ++v)
    for (int u = 0; u < in.width; ++u)
      out(u, v) = in(std::clamp(u - du, 0, in.width - 1), std::clamp(v - dv, 0, in.height - 1));
  return out;
}

ImageU8 brightened(const ImageU8& in, double gain, double offset) {
  ImageU8 out = in;
  for (auto& p : out.data) p = static_cast<uint8_t>(std::clamp(gain * p + offset, 0.0, 255.0));
  return out;
}

Descriptor describeOne(const ImageU8& image, Corner c, DescriptorKind kind) {
  DescriptorOptions o;
  o.kind = kind;
  DescribedCorners out;
  EXPECT_TRUE(describeCorners(image, {c}, o, &out).isOk());
  EXPECT_EQ(out.descriptors.size(), 1u);
  return out.descriptors.empty() ? Descriptor{} : out.descriptors[0];
}

class DescriptorKinds : public ::testing::TestWithParam<DescriptorKind> {};

TEST_P(DescriptorKinds, IdenticalPatchHasDistanceZero) {
  const ImageU8 image = texture(1);
  const Descriptor a = describeOne(image, {100, 60, 1.0f}, GetParam());
  const Descriptor b = describeOne(image, {100, 60, 1.0f}, GetParam());
  EXPECT_EQ(a.kind, GetParam());
  EXPECT_EQ(descriptorDistance(a, b), 0.0);
}

TEST_P(DescriptorKinds, ShiftedOrBrighterPatchIsCloserThanAnUnrelatedOne) {
  const ImageU8 image = texture(2);
  const Corner c{100, 60, 1.0f};
  const Descriptor ref = describeOne(image, c, GetParam());
  // The same scene point one pixel to the right (sub-cell shift) and under another exposure.
  const Descriptor moved = describeOne(shifted(image, 1, 0), {101, 60, 1.0f}, GetParam());
  const Descriptor bright = describeOne(brightened(image, 1.3, 12.0), c, GetParam());
  // Unrelated: another place of the same image, and another texture.
  const Descriptor other_place = describeOne(image, {60, 50, 1.0f}, GetParam());
  const Descriptor other_texture = describeOne(texture(3), c, GetParam());
  const double d_moved = descriptorDistance(ref, moved);
  const double d_bright = descriptorDistance(ref, bright);
  const double d_unrelated =
      std::min(descriptorDistance(ref, other_place), descriptorDistance(ref, other_texture));
  EXPECT_EQ(descriptorDistance(ref, moved), 0.0) << "an integer shift moves the corner with it";
  EXPECT_LT(d_bright, 0.5 * d_unrelated);
  // Half a cell of misregistration: the corner at the old pixel of the shifted image.
  const Descriptor off = describeOne(shifted(image, 1, 0), c, GetParam());
  EXPECT_LT(descriptorDistance(ref, off), d_unrelated);
  EXPECT_LE(d_moved, d_bright);
}

INSTANTIATE_TEST_SUITE_P(OrbAndPatch,
                         DescriptorKinds,
                         ::testing::Values(DescriptorKind::kOrb, DescriptorKind::kPatch));

TEST(PatchDescriptor, BrightnessChangeKeepsDistanceNearZero) {
  const ImageU8 image = texture(4);
  const Descriptor a = describeOne(image, {80, 40, 1.0f}, DescriptorKind::kPatch);
  const Descriptor b =
      describeOne(brightened(image, 0.7, 30.0), {80, 40, 1.0f}, DescriptorKind::kPatch);
  EXPECT_LT(patchDistance(a, b), kQuantisationTol);
  EXPECT_GT(patchDistance(a, describeOne(image, {120, 80, 1.0f}, DescriptorKind::kPatch)),
            10.0 * kQuantisationTol);
}

TEST(Descriptors, CornersNearTheBorderOrOnFlatGreyGetNoneAndAreReported) {
  const ImageU8 image = texture(5);
  for (DescriptorKind kind : {DescriptorKind::kOrb, DescriptorKind::kPatch}) {
    DescriptorOptions o;
    o.kind = kind;
    const int b = descriptorBorderPx(o);
    const std::vector<Corner> corners = {{100, 60, 1.0f},
                                         {b - 1, 60, 1.0f},
                                         {100, b - 1, 1.0f},
                                         {kWidth - b + 1, 60, 1.0f},
                                         {100, kHeight - b + 1, 1.0f},
                                         {0, 0, 1.0f},
                                         {b, b, 1.0f}};
    DescribedCorners out;
    ASSERT_TRUE(describeCorners(image, corners, o, &out).isOk());
    EXPECT_EQ(out.kept, (std::vector<uint32_t>{0, 6})) << descriptorKindName(kind);
    EXPECT_EQ(out.dropped, (std::vector<uint32_t>{1, 2, 3, 4, 5})) << descriptorKindName(kind);
    EXPECT_EQ(out.descriptors.size(), 2u);
  }
  // The patch descriptor refuses a flat patch (no structure to normalise).
  const ImageU8 flat(kWidth, kHeight, 90);
  DescriptorOptions o;
  o.kind = DescriptorKind::kPatch;
  DescribedCorners out;
  ASSERT_TRUE(describeCorners(flat, {{100, 60, 1.0f}}, o, &out).isOk());
  EXPECT_TRUE(out.descriptors.empty());
  EXPECT_EQ(out.dropped, (std::vector<uint32_t>{0}));
}

TEST(Descriptors, BadOptionsAndEmptyImageAreErrorsNamingTheKey) {
  DescriptorOptions o;
  o.patch_size_px = 12;
  const Status s = o.validate();
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("descriptors.patch_size_px"), std::string::npos) << s.message();
  DescribedCorners out;
  EXPECT_FALSE(describeCorners(ImageU8{}, {{1, 1, 1.0f}}, DescriptorOptions{}, &out).isOk());
  DescriptorKind kind{};
  EXPECT_TRUE(parseDescriptorKind("patch", &kind).isOk());
  EXPECT_EQ(kind, DescriptorKind::kPatch);
  const Status bad = parseDescriptorKind("sift", &kind);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.message().find("sift"), std::string::npos);
}

TEST(Descriptors, HammingDistanceCountsBits) {
  Descriptor a, b;
  b.bytes[0] = 0xFF;
  b.bytes[31] = 0x01;
  b.bytes[40] = 0xFF;  // beyond ORB's 32 bytes: ignored
  EXPECT_EQ(hammingDistance(a, b), 9);
  EXPECT_DOUBLE_EQ(descriptorDistance(a, b), 9.0 / 256.0);
}

}  // namespace
}  // namespace twocam::frontend
