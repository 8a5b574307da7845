#pragma once
/// Procedural and file textures rasterised for rendering.

#include <random>

#include "common/image.h"
#include "common/status.h"
#include "sim/world.h"

namespace twocam::sim {

/// Largest texture side [texels]; larger surfaces get fewer texels per metre.
constexpr int kMaxTextureSidePx = 4096;

/// Rasterises a texture for a surface of width_m x height_m (u along width, v along height,
/// texel (0, 0) at the surface's (-width/2, -height/2) corner). Resolution is
/// spec.texels_per_m, reduced if a side would exceed kMaxTextureSidePx.
/// Random textures draw from rng only. Image textures are tiled with tile width spec.scale_m
/// (height from the image's aspect ratio); an unreadable image file is an error.
Status rasterizeTexture(
    const TextureSpec& spec, double width_m, double height_m, std::mt19937_64& rng, ImageU8* out);

}  // namespace twocam::sim
