#!/usr/bin/env bash
# The landmark-confidence experiment of issue 4: every policy x every world x three odometry
# noise levels (0 = exact, 1 = the world's default, 3 = three times it). Simulates the worlds
# into OUT (default out/experiments), runs `twocam run` once per cell and prints the table
# (scripts/landmark_table.py). About 15 minutes on one core. Usage: scripts/landmark_table.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/experiments}"
twocam=build/release/tools/twocam
[ -x "$twocam" ] || scripts/build.sh release
mkdir -p "$out"
for w in office garden repetitive lowtexture; do
  for n in 0 1 3; do
    log="$out/${w}_n${n}.rawlog"
    [ -f "$log" ] || "$twocam" simulate "worlds/$w.yaml" -o "$log" --odometry-noise-scale "$n" -q
    for p in consistency wta-lrc seen-count culling inlier-ratio; do
      echo "== $w, noise x$n, $p"
      "$twocam" run "$log" -o "$out/out_${w}_n${n}_${p}" --policy "$p" -q
    done
  done
done
python3 scripts/landmark_table.py "$out"
