#!/usr/bin/env bash
# Relocalisation in a saved map, as issue 25 measures it (docs/relocalization.md):
#   for office and garden: a map from the world's default log (twocam run --map), then 20 second
#   logs of 15 frames started elsewhere (--start-waypoint K, other noise: --noise-seed), each
#   localised in the map (--localize-only); then 10 logs of each world against the other's map
#   (must be refused). Prints the figures; everything is kept under OUT.
# Usage: scripts/relocalization_trials.sh [OUT]   (default /tmp/twocam_relocalization)
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/tools/twocam
O=${1:-/tmp/twocam_relocalization}
mkdir -p "$O"
waypoints() { python3 -c "
import re
t = open('worlds/$1.yaml').read()
print(re.search(r'waypoints:\s*\[(.*)\]\s*\n', t).group(1).count('['))"; }
for w in office garden; do
  $B simulate worlds/$w.yaml -o "$O/$w.rawlog" -q > /dev/null 2>&1
  rm -f "$O/${w}_map.db"*
  $B run "$O/$w.rawlog" -o "$O/${w}_mapper" -q --no-pictures --map "$O/${w}_map.db" > "$O/${w}_mapper.log" 2>&1
  n=$(waypoints $w)
  for i in $(seq 0 19); do
    $B simulate worlds/$w.yaml --start-waypoint $((i % n)) --noise-seed $((101 + i)) --frames 15 \
      -o "$O/${w}_t$i.rawlog" -q > /dev/null 2>&1
    $B run "$O/${w}_t$i.rawlog" -o "$O/${w}_t${i}_out" -q --no-pictures --map "$O/${w}_map.db" \
      --localize-only > "$O/${w}_t$i.log" 2>&1
  done
done
for i in $(seq 0 9); do
  $B run "$O/garden_t$i.rawlog" -o "$O/x_go_$i" -q --no-pictures --map "$O/office_map.db" --localize-only > /dev/null 2>&1
  $B run "$O/office_t$i.rawlog" -o "$O/x_og_$i" -q --no-pictures --map "$O/garden_map.db" --localize-only > /dev/null 2>&1
done
python3 - "$O" <<'PY'
import json, sys
o = sys.argv[1]
def reloc(path):
    return json.load(open(path + "/metrics.json"))["relocalization"]
for w in ("office", "garden"):
    rs = [reloc(f"{o}/{w}_t{i}_out") for i in range(20)]
    ok = [r for r in rs if 0 <= r["frame"] < 10]
    good = [r for r in ok if r["error_m"] <= 0.05 and r["error_deg"] <= 1.0]
    print(f"{w}: placed within 10 frames {len(ok)}/20, within 5 cm / 1 deg {len(good)}/20, "
          f"frames {[r['frame'] for r in rs]}, "
          f"error max {max(r['error_m'] for r in ok):.3f} m {max(r['error_deg'] for r in ok):.2f} deg, "
          f"attempt median of medians {sorted(r['attempt_ms_median'] for r in rs)[10]:.0f} ms")
wrong = [reloc(f"{o}/x_{p}_{i}")["frame"] >= 0 for p in ("go", "og") for i in range(10)]
print(f"other world's map: {sum(wrong)} of {len(wrong)} accepted")
PY
