#pragma once
/// The SAD cost-curve kernels of the salient matcher (salient_sad.h) and their run-time choice:
/// scalar C++, SSE2 (16 disparities per instruction) or AVX2 (32, checked at run time). One left
/// pixel is compared against consecutive right pixels, summed in uint16 lanes; every kernel gives
/// the scalar kernel's result bit for bit. Which one runs is the frontend's one SIMD choice
/// (simd.h); the kernels take it as `kernel` (kAuto resolved by resolveSimd()). Also the
/// Birchfield-Tomasi sampling intervals.

#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>

#include "common/image.h"
#include "frontend/simd.h"

namespace twocam::frontend {

namespace internal {

/// The SAD cost-curve kernel, exposed for tests and benchmarks:
/// cost[j] = sum_{i<w} |win[i] - strip[i + j]| for j in [0, n) (zero_mean == false), or with
/// each window's rounded mean removed when offsets != nullptr: cost[j] = sum_i |win[i] -
/// strip[i + j] + offsets[j]|, offsets[j] = round(mean(strip[j..j+w)) - mean(win)).
/// Reads strip[0, paddedLength(n, kernel) + w - 1) and writes cost[0, paddedLength(n, kernel));
/// entries at j >= n are unspecified. w in [1, 63], n in [1, 256].
void sadCurve(Simd kernel,
              const uint8_t* win,
              int w,
              const uint8_t* strip,
              const int16_t* offsets,
              int n,
              uint16_t* cost);

/// Prefix cost curves of plain SAD, one pass for several window lengths:
/// outs[k][j] = sum_{i < ends[k]} |win[i] - strip[i + j]| for j in [0, n), k < num_ends, with
/// ends increasing and ends[num_ends - 1] <= 125 (sums stay below 2^15). Differences of two
/// prefixes give any window inside [0, ends[last]). Reads strip[0, paddedLength(n, kernel) +
/// ends[last] - 1) and writes outs[k][0, paddedLength(n, kernel)).
void sadPrefixCurves(Simd kernel,
                     const uint8_t* win,
                     const uint8_t* strip,
                     int n,
                     const int* ends,
                     int num_ends,
                     uint16_t* const* outs);

/// sadPrefixCurves with each strip pixel widened to an interval (Birchfield-Tomasi):
/// outs[k][j] = sum_{i < ends[k]} max(0, strip_lo[i + j] - win[i], win[i] - strip_hi[i + j]),
/// strip_lo <= strip_hi element-wise. strip_hi == nullptr is plain SAD against strip_lo. Reads
/// both strips as sadPrefixCurves reads its one.
void intervalPrefixCurves(Simd kernel,
                          const uint8_t* win,
                          const uint8_t* strip_lo,
                          const uint8_t* strip_hi,
                          int n,
                          const int* ends,
                          int num_ends,
                          uint16_t* const* outs);

/// sadCurve with each strip pixel widened to an interval [strip_lo, strip_hi] (see
/// intervalPrefixCurves); with offsets, the distance of win[i] + offsets[j] to the interval.
/// strip_hi == nullptr is sadCurve.
void intervalCurve(Simd kernel,
                   const uint8_t* win,
                   int w,
                   const uint8_t* strip_lo,
                   const uint8_t* strip_hi,
                   const int16_t* offsets,
                   int n,
                   uint16_t* cost);

/// Birchfield-Tomasi intervals of every row of `image`: lo (hi) is the smallest (largest) of
/// I(x) and the two half-pixel values (I(x) + I(x -+ 1) + 1) / 2 that exist. Resizes lo, hi.
void samplingIntervals(const ImageU8& image, ImageU8* lo, ImageU8* hi);

/// n rounded up to the kernel's vector width (kAuto resolved to the CPU's kernel).
int paddedLength(int n, Simd kernel);

}  // namespace internal

}  // namespace twocam::frontend
