#!/usr/bin/env bash
# Format and static checks: clang-format --dry-run -Werror over every tracked C++ file, then
# clang-tidy (.clang-tidy) over every tracked .cpp file with the compile commands of a
# configure in build/lint. Exits non-zero on any finding. Usage:
#   scripts/lint.sh                 both checks, whole tree
#   scripts/lint.sh --format-only   only clang-format
#   scripts/lint.sh --tidy-only [FILE.cpp ...]   only clang-tidy (the named files, or all)
set -euo pipefail
# Debian's GCC defaults to C++17 so CMake passes no -std flag; clang-tidy 14 would parse C++14.
cd "$(dirname "$0")/.."
mode=all
case "${1:-}" in
  --format-only) mode=format; shift ;;
  --tidy-only) mode=tidy; shift ;;
esac
if [ "$mode" != tidy ]; then
  echo "== clang-format"
  mapfile -t files < <(git ls-files '*.cpp' '*.h')
  clang-format --dry-run -Werror "${files[@]}"
  echo "clang-format: ${#files[@]} files formatted"
fi
if [ "$mode" != format ]; then
  echo "== clang-tidy"
  cmake -S . -B build/lint -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
        -DTWOCAM_BUILD_BENCHMARKS=ON >/dev/null
  if [ $# -gt 0 ]; then
    mapfile -t sources < <(printf '%s\n' "$@" | grep -E '\.cpp$' || true)
  else
    mapfile -t sources < <(git ls-files '*.cpp')
  fi
  [ ${#sources[@]} -gt 0 ] || exit 0
  printf '%s\n' "${sources[@]}" | xargs -P "$(nproc)" -n 4 clang-tidy -p build/lint --quiet --extra-arg=-std=gnu++17
  echo "clang-tidy: ${#sources[@]} files clean"
fi
