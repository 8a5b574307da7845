#!/usr/bin/env bash
# The test command: installs what is missing, checks format and clang-tidy (scripts/lint.sh),
# builds (Release), runs the whole test suite, a short seeded fuzz run of the readers
# (scripts/fuzz_smoke.sh, when clang is there), then the sanitizer build (ASan + UBSan) and its
# tests. TWOCAM_SKIP_LINT=1, TWOCAM_SKIP_FUZZ=1 and TWOCAM_SKIP_ASAN=1 skip those steps.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
if [ "${TWOCAM_SKIP_LINT:-0}" != "1" ]; then
  scripts/lint.sh
fi
echo "== release build and tests"
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_COMPILE_WARNING_AS_ERROR=ON >/dev/null
cmake --build build/release -j "$(nproc)"
(cd build/release && ctest --output-on-failure -j "$(nproc)")
if [ "${TWOCAM_SKIP_FUZZ:-0}" != "1" ] && [ -x scripts/fuzz_smoke.sh ]; then
  echo "== fuzz smoke run (libFuzzer, fixed seed): world, config and rawlog readers"
  # The rawlog reader decodes JPEGs stored inside a log itself (src/io/embedded_images.h), so
  # MRPT's libjpeg, whose default error handler calls exit(1), never sees a corrupt one.
  # Ten minutes of one harness: scripts/fuzz_smoke.sh 600 fuzz_rawlog (docs/recorded_data.md).
  scripts/fuzz_smoke.sh "${TWOCAM_FUZZ_SECONDS:-20}" fuzz_world fuzz_config fuzz_rawlog
fi
if [ "${TWOCAM_SKIP_ASAN:-0}" != "1" ]; then
  echo "== sanitizer build (ASan + UBSan) and tests"
  cmake -S . -B build/asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTWOCAM_SANITIZERS=ON \
        -DCMAKE_COMPILE_WARNING_AS_ERROR=ON >/dev/null
  cmake --build build/asan -j "$(nproc)"
  # Mesa's llvmpipe and libEGL keep allocations alive until exit; leaks there are not ours.
  # allocator_may_return_null: a corrupt log can ask OpenCV's cv::Mat for exabytes; malloc then
  # returns null and OpenCV throws, which the reader turns into an error (as in a normal build),
  # where ASan's default would abort the test.
  (cd build/asan && ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j "$(nproc)")
fi
