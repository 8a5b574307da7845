#include "frontend/simd.h"

namespace twocam::frontend {
namespace {

bool cpuHasAvx2() {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

struct SimdName {
  Simd simd;
  const char* name;
};
constexpr SimdName kSimdNames[] = {
    {Simd::kAuto, "auto"}, {Simd::kScalar, "scalar"}, {Simd::kSse2, "sse2"}, {Simd::kAvx2, "avx2"}};

}  // namespace

bool simdAvailable(Simd simd) {
  switch (simd) {
    case Simd::kAuto:
    case Simd::kScalar:
      return true;
    case Simd::kSse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
    case Simd::kAvx2:
      return cpuHasAvx2();
  }
  return false;
}

Simd resolveSimd(Simd simd) {
  if (simd != Simd::kAuto) return simd;
  if (cpuHasAvx2()) return Simd::kAvx2;
#if defined(__SSE2__)
  return Simd::kSse2;
#else
  return Simd::kScalar;
#endif
}

const char* simdName(Simd simd) {
  for (const SimdName& s : kSimdNames) {
    if (s.simd == simd) return s.name;
  }
  return "unknown";
}

Status parseSimd(const std::string& name, Simd* simd) {
  for (const SimdName& s : kSimdNames) {
    if (name == s.name) {
      *simd = s.simd;
      return Status::ok();
    }
  }
  return Status::error("unknown SIMD choice '" + name + "'; expected auto, scalar, sse2 or avx2");
}

Status checkSimd(const char* key, Simd simd) {
  if (simdAvailable(simd)) return Status::ok();
  return Status::error(std::string(key) + " = " + simdName(simd) +
                       "; this CPU or build cannot run it (use auto)");
}

}  // namespace twocam::frontend
