#!/usr/bin/env bash
# The main job: install what is missing, build, simulate the default world (worlds/office.yaml)
# and write results a person can look at into out/ (override with TWOCAM_OUT=DIR).
# Extra arguments go to `twocam simulate` (e.g. --frames 100 --seed 3).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${TWOCAM_OUT:-out}"
scripts/setup.sh
echo "== build (Release)"
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build/release -j "$(nproc)" --target twocam
mkdir -p "$OUT"
echo "== simulate worlds/office.yaml"
build/release/tools/twocam simulate worlds/office.yaml -o "$OUT/office.rawlog" "$@"
/usr/bin/python3 scripts/plot_simulation.py "$OUT/office_preview"
echo
echo "Results:"
echo "  log (MRPT rawlog, opens in RawLogViewer): $OUT/office.rawlog  (images: $OUT/office_Images/)"
echo "  stereo frames and true depth:             $OUT/office_preview/contact_sheet.png"
echo "  true vs wheel-odometry path:              $OUT/office_preview/trajectory.png"
echo "  timing:                                   $OUT/office_preview/simulate.json"
