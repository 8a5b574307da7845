#!/usr/bin/env bash
# The main job: install what is missing, build, simulate the default world (worlds/office.yaml),
# run the whole pipeline on it (frontend, landmark database, localisation, OctoMap) and write results a person
# can look at into out/ (override with TWOCAM_OUT=DIR).
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
echo "== run the pipeline on it"
build/release/tools/twocam run "$OUT/office.rawlog" -o "$OUT/office_run"
R="$OUT/office_run"
echo
echo "Results:"
echo "  log (MRPT rawlog, opens in RawLogViewer): $OUT/office.rawlog  (images: $OUT/office_Images/)"
echo "  stereo frames and true depth:             $OUT/office_preview/contact_sheet.png"
echo "  map seen from above (landmarks, voxels):  $R/pictures/map_topdown.png"
echo "  pose error, estimate against odometry:    $R/pictures/localization.png"
echo "  landmark confidence, precision:           $R/pictures/confidence_histogram.png, $R/pictures/precision_vs_threshold.png"
echo "  a frame with corners and hypotheses:      $R/pictures/sample_frame.png"
echo "  per-frame timings:                        $R/pictures/timings.png"
echo "  OctoMap (open with octovis):              $R/map.bt"
echo "  metrics (METRICS.md keys):                $R/metrics.json"
echo "  landmarks, trajectories, config:          $R/landmarks.csv, $R/trajectory_{est,odom,gt}.tum, $R/config_used.yaml"
