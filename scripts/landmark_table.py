#!/usr/bin/env python3
"""Prints the policy x world x odometry-noise table (markdown) from the metrics.json files that
scripts/landmark_table.sh leaves in OUT/out_<world>_n<noise>_<policy>/.

Usage: landmark_table.py [OUT] [--texture]
  --texture  instead: confirmed landmarks by the texture at their anchor (metrics.json
             "by_texture": grey-level standard deviation of the 7x7 patch; plain below 4, faint
             4-10, textured from 10), correct / confirmed and precision per class."""
import json
import os
import sys

WORLDS = ["office", "garden", "repetitive", "lowtexture"]
NOISE = ["0", "1", "3"]
POLICIES = ["consistency", "wta-lrc", "seen-count", "culling", "inlier-ratio"]


def fmt(value, pattern):
    return "n/a" if value is None else pattern.format(value)


def runs(out):
    """Yields (world, noise, policy, metrics.json contents or None when missing) in table order."""
    for w in WORLDS:
        for n in NOISE:
            for p in POLICIES:
                path = os.path.join(out, f"out_{w}_n{n}_{p}", "metrics.json")
                if not os.path.exists(path):
                    yield w, n, p, None
                    continue
                with open(path) as f:
                    yield w, n, p, json.load(f)


def texture_table(out):
    print("| world | odometry noise | policy | plain: correct / confirmed | faint | textured |")
    print("| --- | --- | --- | --- | --- | --- |")
    for w, n, p, metrics in runs(out):
        if metrics is None:
            continue
        rows = metrics.get("by_texture")
        if rows is None:
            print(f"| {w} | x{n} | {p} | no by_texture (older run) | | |")
            continue
        cells = []
        for r in rows:
            prec = fmt(100.0 * r["correct"] / r["confirmed"] if r["confirmed"] else None, "{:.1f} %")
            cells.append(f"{r['correct']} / {r['confirmed']} ({prec})")
        print(f"| {w} | x{n} | {p} | " + " | ".join(cells) + " |")


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    flags = [a for a in sys.argv[1:] if a.startswith("--")]
    unknown = [f for f in flags if f != "--texture"]
    if unknown:
        sys.exit(f"landmark_table.py: unknown option {unknown[0]} (usage: landmark_table.py [OUT] [--texture])")
    out = args[0] if args else "out/experiments"
    if "--texture" in flags:
        texture_table(out)
        return
    print("| world | odometry noise | policy | confirmed | correct | precision | precision (strict) "
          "| precision (judged) | correct distinct points | median error [mm] | frames to confirm |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for w, n, p, metrics in runs(out):
        if metrics is None:
            print(f"| {w} | x{n} | {p} | missing | | | | | | | |")
            continue
        lm = metrics["landmarks"]
        err = lm.get("median_error_m")
        # From the counts, so the table reads the same from any version's metrics.json.
        # METRICS.md precision = correct / confirmed, where a landmark on a depth edge (anchor
        # pixel without ground truth) is correct on the near or the far surface ("Depth edges",
        # 2026-12-02); strict counts every such landmark as wrong; "judged" leaves them out.
        # Runs from before that rule have correct_confirmed = the strict count.
        conf = lm["confirmed"]
        if "correct_confirmed_strict" in lm:
            strict, corr = lm["correct_confirmed_strict"], lm["correct_confirmed"]
        else:
            strict = lm["correct_confirmed"]
            corr = strict + lm.get("unjudged_near_side", 0) + lm.get("unjudged_far_side", 0)
        judged = conf - lm.get("unjudged_confirmed", 0)
        precision = 100.0 * corr / conf if conf else None
        precision_strict = 100.0 * strict / conf if conf else None
        precision_judged = 100.0 * strict / judged if judged else None
        print(f"| {w} | x{n} | {p} | {conf} | {corr} "
              f"| {fmt(precision, '{:.2f} %')} "
              f"| {fmt(precision_strict, '{:.2f} %')} "
              f"| {fmt(precision_judged, '{:.2f} %')} "
              f"| {fmt(lm.get('correct_distinct_points'), '{}')} "
              f"| {fmt(None if err is None else 1000 * err, '{:.1f}')} "
              f"| {fmt(lm.get('frames_to_confirm_median'), '{:.0f}')} |")


if __name__ == "__main__":
    main()
