#pragma once
/// Appearance descriptors at corners of the left image, for relocalisation (issue 25 part 3,
/// docs/relocalization.md): OpenCV's ORB descriptor (rBRIEF, 256 bits) computed at given corners,
/// or a normalised grey patch (16 x 16 px averaged to 8 x 8, zero mean, quantised to int8).
/// Corners whose descriptor cannot be formed (too close to the border, or a flat patch) get none
/// and are reported.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"

namespace twocam::frontend {

enum class DescriptorKind : uint8_t {
  kOrb,    ///< OpenCV ORB at the corner, upright (angle 0: the rig does not roll), 32 bytes
  kPatch,  ///< normalised 8 x 8 patch, 64 int8, compared by 1 - NCC
};

/// "orb" or "patch".
Status parseDescriptorKind(const std::string& name, DescriptorKind* kind);
const char* descriptorKindName(DescriptorKind kind);

/// Bytes a descriptor of this kind uses in Descriptor::bytes: 32 for ORB, 64 for the patch.
int descriptorBytes(DescriptorKind kind);

inline constexpr int kMaxDescriptorBytes = 64;
/// Side of the patch descriptor's grid: 8 x 8 = 64 values.
inline constexpr int kPatchGrid = 8;

/// One descriptor: its kind and bytes (the first descriptorBytes(kind) are used, the rest 0).
/// Patch values are int8 stored in the bytes.
struct Descriptor {
  DescriptorKind kind = DescriptorKind::kOrb;
  std::array<uint8_t, kMaxDescriptorBytes> bytes{};
};

struct DescriptorOptions {
  DescriptorKind kind = DescriptorKind::kOrb;
  /// Side of the grey patch the patch descriptor averages to 8 x 8 [px]: a multiple of 8.
  /// 16 px = 2 x 2 px cells, the size of the SAD window's neighbourhood; larger patches are more
  /// distinctive but change more with viewpoint.
  int patch_size_px = 16;
  /// Patches whose grey standard deviation is below this are flat and get no descriptor [grey].
  double min_patch_std_grey = 2.0;

  [[nodiscard]] Status validate(const char* prefix = "descriptors.") const;
};

/// Descriptors of a list of corners.
struct DescribedCorners {
  /// One per kept corner, in input order.
  std::vector<Descriptor> descriptors;
  /// Index into the input corners of each descriptor.
  std::vector<uint32_t> kept;
  /// Input corners that got no descriptor: too near the border (ORB: OpenCV's edge threshold of
  /// 31 px; patch: the patch must fit), or a flat patch.
  std::vector<uint32_t> dropped;
};

/// Border [px] a corner needs on every side for a descriptor of this kind.
int descriptorBorderPx(const DescriptorOptions& options);

/// Descriptors of `corners` in `left` (8-bit grey). Errors for an empty image or invalid
/// options. Deterministic.
Status describeCorners(const ImageU8& left,
                       const std::vector<Corner>& corners,
                       const DescriptorOptions& options,
                       DescribedCorners* out);

/// Hamming distance of two ORB descriptors [bits], 0..256.
int hammingDistance(const Descriptor& a, const Descriptor& b);
/// 1 - normalised cross-correlation of two patch descriptors, 0 (same) .. 2 (inverted).
double patchDistance(const Descriptor& a, const Descriptor& b);
/// The distance of the kind: Hamming bits / 256 for ORB (0..1), 1 - NCC for the patch (0..2).
/// CHECK-fails when the kinds differ.
double descriptorDistance(const Descriptor& a, const Descriptor& b);

}  // namespace twocam::frontend
