#!/usr/bin/env bash
# Builds the libFuzzer harnesses (tests/fuzz) with clang, ASan and UBSan in build/fuzz and runs
# each for SECONDS seconds (default 20) from the seed corpus with a fixed seed. Exits non-zero on
# a crash, hang (an input over 10 s), leak or sanitizer report; libFuzzer writes the input that
# triggered it to build/fuzz/artifacts/. allocator_may_return_null=1: a huge request returns
# null as glibc's malloc does in production (OpenCV then throws, which the reader reports),
# instead of ASan aborting.
#   scripts/fuzz_smoke.sh [SECONDS] [HARNESS...]     e.g. scripts/fuzz_smoke.sh 600 fuzz_world
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-20}"
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -eq 0 ] && harnesses=(fuzz_world fuzz_config fuzz_rawlog)
sanitize="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER="${CXX_FUZZ:-clang++}" -DCMAKE_CXX_FLAGS="$sanitize" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DTWOCAM_BUILD_FUZZERS=ON -DTWOCAM_BUILD_TESTS=OFF -DTWOCAM_BUILD_TOOLS=OFF \
  ${CMAKE_CXX_COMPILER_LAUNCHER:+-DCMAKE_CXX_COMPILER_LAUNCHER=$CMAKE_CXX_COMPILER_LAUNCHER} >/dev/null
cmake --build build/fuzz -j"${JOBS:-2}" --target "${harnesses[@]}"
mkdir -p build/fuzz/artifacts
status=0
for h in "${harnesses[@]}"; do
  corpus="build/fuzz/corpus/${h#fuzz_}"
  mkdir -p "$corpus"
  echo "== $h: ${seconds} s"
  # The seed corpus is read-only input; new inputs go to the build tree's corpus.
  if ! ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 LSAN_OPTIONS=suppressions=tests/fuzz/lsan.supp \
      UBSAN_OPTIONS=print_stacktrace=1 \
      "build/fuzz/tests/fuzz/$h" "$corpus" "tests/fuzz/corpus/${h#fuzz_}" \
      -seed=1 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -max_len=65536 \
      -artifact_prefix=build/fuzz/artifacts/"$h"- -print_final_stats=1; then
    echo "== $h: FAILED (see build/fuzz/artifacts/)"
    status=1
  fi
done
exit $status
