#!/usr/bin/env python3
"""Prints the policy x world x odometry-noise table (markdown) from the metrics.json files that
scripts/landmark_table.sh leaves in OUT/out_<world>_n<noise>_<policy>/."""
import json
import os
import sys

WORLDS = ["office", "garden", "repetitive", "lowtexture"]
NOISE = ["0", "1", "3"]
POLICIES = ["consistency", "wta-lrc", "seen-count", "culling", "inlier-ratio"]


def fmt(value, pattern):
    return "n/a" if value is None else pattern.format(value)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "out/experiments"
    print("| world | odometry noise | policy | confirmed | correct | precision | precision (judged) "
          "| median error [mm] | frames to confirm |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for w in WORLDS:
        for n in NOISE:
            for p in POLICIES:
                path = os.path.join(out, f"out_{w}_n{n}_{p}", "metrics.json")
                if not os.path.exists(path):
                    print(f"| {w} | x{n} | {p} | missing | | | | | |")
                    continue
                with open(path) as f:
                    lm = json.load(f)["landmarks"]
                err = lm.get("median_error_m")
                # From the counts, so the table reads the same from any version's metrics.json:
                # METRICS.md precision = correct / confirmed; "judged" leaves out landmarks whose
                # anchor pixel has no ground truth (depth edges).
                conf, corr = lm["confirmed"], lm["correct_confirmed"]
                judged = conf - lm.get("unjudged_confirmed", 0)
                lm["precision"] = 100.0 * corr / conf if conf else None
                lm["precision_judged"] = 100.0 * corr / judged if judged else None
                print(f"| {w} | x{n} | {p} | {lm['confirmed']} | {lm['correct_confirmed']} "
                      f"| {fmt(lm.get('precision'), '{:.2f} %')} "
                      f"| {fmt(lm.get('precision_judged'), '{:.2f} %')} "
                      f"| {fmt(None if err is None else 1000 * err, '{:.1f}')} "
                      f"| {fmt(lm.get('frames_to_confirm_median'), '{:.0f}')} |")


if __name__ == "__main__":
    main()
