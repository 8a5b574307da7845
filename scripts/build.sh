#!/usr/bin/env bash
# Configures and builds TwoCam. Usage: scripts/build.sh [preset] (release, debug, asan, bench).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
cmake --preset "$preset" -G Ninja >/dev/null
cmake --build --preset "$preset" 2>/dev/null || cmake --build "build/$preset" -j "$(nproc)"
