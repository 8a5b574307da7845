#!/usr/bin/env bash
# The test command: installs what is missing, builds (Release), runs the whole test suite,
# then the sanitizer build (ASan + UBSan) and its tests unless TWOCAM_SKIP_ASAN=1.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
echo "== release build and tests"
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_COMPILE_WARNING_AS_ERROR=ON >/dev/null
cmake --build build/release -j "$(nproc)"
(cd build/release && ctest --output-on-failure -j "$(nproc)")
if [ "${TWOCAM_SKIP_ASAN:-0}" != "1" ]; then
  echo "== sanitizer build (ASan + UBSan) and tests"
  cmake -S . -B build/asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTWOCAM_SANITIZERS=ON \
        -DCMAKE_COMPILE_WARNING_AS_ERROR=ON >/dev/null
  cmake --build build/asan -j "$(nproc)"
  # Mesa's llvmpipe and libEGL keep allocations alive until exit; leaks there are not ours.
  (cd build/asan && ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j "$(nproc)")
fi
