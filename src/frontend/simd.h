#pragma once
/// The one SIMD choice of the frontend: which build of its hot loops Harris (harris.h), the
/// salient SAD kernels (sad_kernels.h) and the dense matcher (dense_sad.h) run. Every choice gives
/// the same results bit for bit (tests Harris.EverySimdChoiceGivesTheSameCorners,
/// SadKernels.*BitIdenticalToScalar, DenseSad.EverySimdChoiceGivesTheSameDisparities); the choice
/// exists for tests (cross-checking) and benchmarks (speed-up figures). resolveSimd() is the one
/// place that turns kAuto into what this CPU runs.

#include <cstdint>
#include <string>

#include "common/status.h"

namespace twocam::frontend {

/// What exists per component:
///
/// | choice  | Harris                  | salient SAD kernels        | dense SAD               |
/// | ------- | ----------------------- | -------------------------- | ----------------------- |
/// | kScalar | baseline build          | portable C++ loops         | baseline build          |
/// | kSse2   | baseline build          | SSE2 intrinsics, 16 lanes  | baseline build          |
/// | kAvx2   | AVX2 build              | AVX2 intrinsics, 32 lanes  | AVX2 build              |
///
/// "Baseline build" is plain C++ compiled for the target's baseline ISA, which on x86-64 the
/// compiler auto-vectorises with SSE2; Harris and dense have no hand-written SSE2 path, so there
/// kSse2 and kScalar are the same code. Some helpers (row-support sums, cost minima) use SSE2
/// intrinsics under every choice on x86-64: SSE2 is part of x86-64, so there is no narrower path.
enum class Simd : uint8_t {
  kAuto,    ///< The fastest this build and CPU run: kAvx2, else kSse2 (x86-64), else kScalar.
  kScalar,  ///< No hand-written SIMD, no AVX2 build (see the table).
  kSse2,    ///< SSE2 (the x86-64 baseline); no AVX2.
  kAvx2,    ///< AVX2 (checked at run time: validate() rejects it on a CPU without AVX2).
};

/// True when `simd` can run on this build and CPU (kAuto and kScalar always can).
[[nodiscard]] bool simdAvailable(Simd simd);

/// The concrete choice kAuto stands for on this CPU; other values are returned unchanged.
[[nodiscard]] Simd resolveSimd(Simd simd);

/// "auto", "scalar", "sse2" or "avx2".
[[nodiscard]] const char* simdName(Simd simd);

/// Parses simdName()'s spellings; an error naming the accepted ones otherwise.
Status parseSimd(const std::string& name, Simd* simd);

/// OK when simdAvailable(simd), else an error starting with `key` ("frontend.simd = avx2; ...").
Status checkSimd(const char* key, Simd simd);

}  // namespace twocam::frontend
