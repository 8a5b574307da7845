#pragma once
/// Seeded random streams. Every random draw in TwoCam comes from a stream made here from a
/// user-visible seed and a fixed stream id, so components draw independently (OpenVINS style):
/// changing how many numbers the image noise uses does not change the odometry noise.

#include <cstdint>
#include <random>

namespace twocam {

/// Fixed stream ids. Never renumber: that would change every simulated log.
enum class RandomStream : uint64_t {
  kTextures = 1,
  kImageNoise = 2,
  kOdometryNoise = 3,
};

/// SplitMix64 finaliser: spreads nearby seeds over the whole state space.
inline uint64_t mixSeed(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// The generator of one stream for a given seed; sub_id separates e.g. textures of different
/// shapes.
inline std::mt19937_64 makeRng(uint64_t seed, RandomStream stream, uint64_t sub_id = 0) {
  return std::mt19937_64(mixSeed(mixSeed(seed ^ mixSeed(static_cast<uint64_t>(stream))) + sub_id));
}

}  // namespace twocam
