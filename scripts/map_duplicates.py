#!/usr/bin/env python3
"""Counts a multi-session map's duplicate landmarks (issue 25, docs/store.md).

Usage: scripts/map_duplicates.py MAP.db [--radius 0.02] [--runs OUT_1 OUT_2 ...]

For each session after the first: of the landmarks it inserted (landmarks.session = that
session), how many lie within RADIUS metres (map frame) of a landmark of an earlier session, i.e.
points the map already had that the session mapped again. Also, as the baseline of the same test
inside one session, how many of the first session's landmarks have another first-session landmark
within RADIUS. Reads the store with python3's sqlite3 (read only); prints one line per figure.

In a densely textured world distinct corners lie within 2 cm of each other (the baseline says how
often), so for simulated logs --runs gives the run folders of the sessions, in session order
(`twocam run` outputs: landmarks.csv, trajectory_gt.tum): each landmark's true point is its anchor
pixel at the true depth seen from the true pose (as METRICS.md's landmarks.duplicate_fraction),
and a later session's confirmation is a duplicate when its true point and an earlier session's
project within 1 px in u, v and disparity of each other in the true camera of the confirming
frame: the run's own duplicate test, across sessions.
"""
import argparse
import math
import sqlite3
import sys
from collections import defaultdict


def grid(points, cell):
    g = defaultdict(list)
    for i, p in enumerate(points):
        g[tuple(int(math.floor(c / cell)) for c in p)].append(i)
    return g


def near(g, points, p, cell, radius, skip=None):
    """True when a point of `points` (indexed by grid g) other than index `skip` is within
    radius of p."""
    k = tuple(int(math.floor(c / cell)) for c in p)
    r2 = radius * radius
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                for i in g.get((k[0] + dx, k[1] + dy, k[2] + dz), ()):
                    if i == skip:
                        continue
                    q = points[i]
                    if sum((a - b) ** 2 for a, b in zip(p, q)) <= r2:
                        return True
    return False


def quat_matrix(qw, qx, qy, qz):
    return [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
            [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
            [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]


def apply(T, p):
    R, t = T
    return tuple(sum(R[i][j] * p[j] for j in range(3)) + t[i] for i in range(3))


def compose(A, B):
    Ra, ta = A
    Rb, tb = B
    R = [[sum(Ra[i][k] * Rb[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return R, apply(A, tb)


def inverse(T):
    R, t = T
    Rt = [[R[j][i] for j in range(3)] for i in range(3)]
    return Rt, tuple(-sum(Rt[i][j] * t[j] for j in range(3)) for i in range(3))


def parse_rig(text):
    vals = {}
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("T_b_cl:"):
            body = line[len("T_b_cl:"):].strip().strip("{}")
            for kv in body.split(","):
                k, v = kv.split(":")
                vals["T_" + k.strip()] = float(v)
        elif ":" in line and not line.endswith(":"):
            k, v = line.split(":", 1)
            vals[k.strip()] = float(v)
    T_b_cl = (quat_matrix(vals["T_qw"], vals["T_qx"], vals["T_qy"], vals["T_qz"]),
              (vals["T_x_m"], vals["T_y_m"], vals["T_z_m"]))
    return vals, T_b_cl


def true_poses(run_dir):
    poses = []
    with open(f"{run_dir}/trajectory_gt.tum") as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            _, x, y, z, qx, qy, qz, qw = (float(v) for v in line.split())
            poses.append((quat_matrix(qw, qx, qy, qz), (x, y, z)))
    return poses  # one per frame, frames from 0


def read_tum(path):
    out = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            t, x, y, z, qx, qy, qz, qw = (float(v) for v in line.split())
            out[round(t, 6)] = (quat_matrix(qw, qx, qy, qz), (x, y, z))
    return out


def map_from_run(run_dir):
    """T_m_o of a run relocalised in the map: its first map-frame pose against its estimate."""
    m = read_tum(f"{run_dir}/trajectory_map.tum")
    e = read_tum(f"{run_dir}/trajectory_est.tum")
    t = min(m)
    return compose(m[t], inverse(e[t]))


def true_points(run_dir, rig, T_b_cl, in_map=None):
    """(confirmed_frame, true point, in the map) of the run's own confirmed landmarks with ground
    truth; with in_map (T_m_o, grid and points of the map's rows of the session) whether each is
    a row of the map (else merged into an earlier landmark, or not recorded)."""
    import csv
    poses = true_poses(run_dir)
    out = []
    with open(f"{run_dir}/landmarks.csv") as f:
        for r in csv.DictReader(f):
            if r["confirmed"] != "1" or not r["anchor_d_gt"]:
                continue  # a candidate, or restored from the map / no truth at its anchor
            row = True
            if in_map is not None:
                T_m_o, g, pts = in_map
                p_m = apply(T_m_o, (float(r["x"]), float(r["y"]), float(r["z"])))
                row = near(g, pts, p_m, 0.001, 0.001)
            u, v = float(r["anchor_u"]), float(r["anchor_v"])
            z = rig["fx_px"] * rig["baseline_m"] / float(r["anchor_d_gt"])
            p_cl = ((u - rig["cx_px"]) / rig["fx_px"] * z, (v - rig["cy_px"]) / rig["fy_px"] * z, z)
            T_w_cl = compose(poses[int(r["anchor_frame"])], T_b_cl)
            out.append((int(r["confirmed_frame"]), apply(T_w_cl, p_cl), row))
    return out, poses


def truth_duplicates(run_dirs, rig_text, by_session):
    rig, T_b_cl = parse_rig(rig_text)
    fb = rig["fx_px"] * rig["baseline_m"]
    cell = 0.1
    earlier, _ = true_points(run_dirs[0], rig, T_b_cl)
    earlier = [p for _, p, _ in earlier]
    for k, run_dir in enumerate(run_dirs[1:], start=2):
        rows = by_session.get(k, [])
        pts, poses = true_points(run_dir, rig, T_b_cl,
                                 (map_from_run(run_dir), grid(rows, 0.001), rows))
        g = grid(earlier, cell)
        dup = {True: 0, False: 0}
        count = {True: 0, False: 0}
        for frame, p, row in pts:
            T_cl_w = inverse(compose(poses[frame], T_b_cl))

            def uvd(q):
                c = apply(T_cl_w, q)
                if c[2] <= 0:
                    return None
                return (rig["fx_px"] * c[0] / c[2] + rig["cx_px"],
                        rig["fy_px"] * c[1] / c[2] + rig["cy_px"], fb / c[2])

            a = uvd(p)
            key = tuple(int(math.floor(c / cell)) for c in p)
            found = False
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dz in (-1, 0, 1):
                        for i in g.get((key[0] + dx, key[1] + dy, key[2] + dz), ()):
                            b = uvd(earlier[i])
                            if a and b and all(abs(x - y) <= 1.0 for x, y in zip(a, b)):
                                found = True
                                break
                        if found:
                            break
                    if found:
                        break
                if found:
                    break
            dup[row] += found
            count[row] += 1
        n = count[True] + count[False]
        print(f"session {k} (true points, {run_dir}): of its {n} confirmations with ground truth "
              f"{count[True]} are rows of the map, {dup[True]} of those "
              f"({100.0 * dup[True] / max(1, count[True]):.2f} %) the true point of an earlier "
              f"session's landmark (within 1 px in u, v, d); {count[False]} not rows (merged into "
              f"an earlier landmark), {dup[False]} of those "
              f"({100.0 * dup[False] / max(1, count[False]):.2f} %) an earlier one's true point")
        earlier.extend(p for _, p, row in pts if row)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map")
    ap.add_argument("--radius", type=float, default=0.02, help="metres (default 0.02)")
    ap.add_argument("--runs", nargs="+", help="the sessions' run folders (simulated logs)")
    a = ap.parse_args()
    try:
        db = sqlite3.connect(f"file:{a.map}?mode=ro", uri=True)
        rows = db.execute("SELECT session, x, y, z FROM landmarks").fetchall()
    except sqlite3.Error as e:
        print(f"map_duplicates: {a.map}: {e}", file=sys.stderr)
        return 1
    by_session = defaultdict(list)
    for s, x, y, z in rows:
        by_session[s].append((x, y, z))
    sessions = sorted(by_session)
    print(f"map: {a.map}, {len(rows)} landmarks, sessions {sessions}, radius {a.radius} m")
    if not sessions:
        return 0
    cell = a.radius
    first = by_session[sessions[0]]
    g1 = grid(first, cell)
    inner = sum(1 for i, p in enumerate(first) if near(g1, first, p, cell, a.radius, skip=i))
    print(f"session {sessions[0]}: {len(first)} landmarks, {inner} "
          f"({100.0 * inner / max(1, len(first)):.2f} %) with another of the session within "
          f"{a.radius} m (baseline)")
    earlier = list(first)
    total_dup = 0
    for s in sessions[1:]:
        g = grid(earlier, cell)
        pts = by_session[s]
        dup = sum(1 for p in pts if near(g, earlier, p, cell, a.radius))
        total_dup += dup
        print(f"session {s}: {len(pts)} landmarks inserted, {dup} "
              f"({100.0 * dup / max(1, len(pts)):.2f} % of them) within {a.radius} m of an "
              f"earlier session's")
        earlier.extend(pts)
    if len(sessions) > 1:
        print(f"duplicates of earlier sessions: {total_dup} of {len(rows)} map rows "
              f"({100.0 * total_dup / max(1, len(rows)):.2f} %)")
    if a.runs:
        rig_text = db.execute("SELECT rig FROM sessions ORDER BY id LIMIT 1").fetchone()[0]
        truth_duplicates(a.runs, rig_text, by_session)
    return 0


if __name__ == "__main__":
    sys.exit(main())
