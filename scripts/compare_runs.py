#!/usr/bin/env python3
"""Checks that a refactor left `twocam run` outputs unchanged.

Usage: scripts/compare_runs.py OLD_DIR NEW_DIR [--allow KEY ...]

OLD_DIR and NEW_DIR hold run folders of the same names (out_<world>_n<k>_<policy>, as
scripts/landmark_table.sh writes them), or are two run folders themselves. For each pair:
landmarks.csv and map.bt must be byte-identical, and every metrics.json key of the old run must
exist in the new one with the same value (numbers equal to 10 significant digits, the old
writer's precision; NaN equals NaN). Keys named with --allow (dotted, e.g.
landmarks.precision) may differ; their old and new values are printed. Exits 1 on any
difference, 2 when a folder is missing or there is nothing to compare.
"""
import argparse
import json
import math
import os
import sys


def flatten(obj, prefix=""):
    out = {}
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.update(flatten(v, f"{prefix}{k}."))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out.update(flatten(v, f"{prefix}{i}."))
    else:
        out[prefix[:-1]] = obj
    return out


def same(a, b):
    if isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
        return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if isinstance(a, float) and math.isnan(a):
            return isinstance(b, float) and math.isnan(b)
        if a == b:
            return True
        return abs(a - b) <= 5e-10 * max(abs(a), abs(b))
    return a == b


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


def compare_run(old, new, allow):
    problems = []
    for name in ("landmarks.csv", "map.bt"):
        po, pn = os.path.join(old, name), os.path.join(new, name)
        if not os.path.exists(po):
            continue
        if not os.path.exists(pn):
            problems.append(f"{name}: missing in {new}")
        elif read_bytes(po) != read_bytes(pn):
            problems.append(f"{name}: differs")
    with open(os.path.join(old, "metrics.json")) as f:
        mo = flatten(json.load(f))
    with open(os.path.join(new, "metrics.json")) as f:
        mn = flatten(json.load(f))
    allowed = []
    for key, vo in mo.items():
        if key not in mn:
            problems.append(f"metrics.json {key}: missing")
            continue
        if same(vo, mn[key]):
            continue
        if any(key == a or key.startswith(a + ".") for a in allow):
            allowed.append(f"{key}: {vo} -> {mn[key]}")
        else:
            problems.append(f"metrics.json {key}: {vo} -> {mn[key]}")
    return problems, allowed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--allow", action="append", default=[], help="dotted metrics.json key that may change")
    args = ap.parse_args()
    for d in (args.old, args.new):
        if not os.path.isdir(d):
            print(f"compare_runs: {d}: not a folder", file=sys.stderr)
            return 2
    if os.path.exists(os.path.join(args.old, "metrics.json")):
        pairs = [(args.old, args.new)]
    else:
        names = sorted(n for n in os.listdir(args.old)
                       if os.path.exists(os.path.join(args.old, n, "metrics.json")))
        pairs = [(os.path.join(args.old, n), os.path.join(args.new, n)) for n in names]
    if not pairs:
        print(f"compare_runs: {args.old}: no run folders (metrics.json) to compare", file=sys.stderr)
        return 2
    failed = 0
    for old, new in pairs:
        if not os.path.exists(os.path.join(new, "metrics.json")):
            print(f"MISSING {new}")
            failed += 1
            continue
        problems, allowed = compare_run(old, new, args.allow)
        status = "DIFF" if problems else "same"
        print(f"{status} {os.path.basename(os.path.normpath(new))}")
        for p in problems:
            print(f"    {p}")
        for a in allowed:
            print(f"    allowed {a}")
        failed += bool(problems)
    print(f"{len(pairs) - failed} same, {failed} different")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
