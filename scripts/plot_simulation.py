#!/usr/bin/python3
"""Top-down plot of a simulated run: world outline, true path and wheel-odometry path.

Usage: scripts/plot_simulation.py PREVIEW_DIR   (the folder `twocam simulate` writes:
trajectory.csv, world_outline.csv); writes PREVIEW_DIR/trajectory.png.
"""
import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    d = Path(sys.argv[1])
    try:
        traj = read_csv(d / "trajectory.csv")
    except OSError as e:
        print(f"plot_simulation: cannot read {d / 'trajectory.csv'}: {e}", file=sys.stderr)
        return 1
    if not traj:
        print("plot_simulation: trajectory.csv has no rows", file=sys.stderr)
        return 1
    fig, ax = plt.subplots(figsize=(9, 7))
    outline = d / "world_outline.csv"
    if outline.exists():
        shapes = {}
        for r in read_csv(outline):
            shapes.setdefault((r["shape"], r["name"], r["kind"]), []).append((float(r["x_m"]), float(r["y_m"])))
        first = True
        for (_, _, kind), pts in shapes.items():
            xs, ys = zip(*pts)
            if kind == "floor":
                ax.plot(xs, ys, color="0.85", lw=0.8, zorder=1)
            elif kind == "overhead":
                ax.plot(xs, ys, color="0.6", lw=1.0, ls=":", zorder=2)
            else:
                ax.plot(xs, ys, color="0.35", lw=1.6 if kind == "wall" else 1.0, zorder=2,
                        label="world (walls, objects)" if first else None)
                first = False
    tx = [float(r["true_x_m"]) for r in traj]
    ty = [float(r["true_y_m"]) for r in traj]
    ox = [float(r["odom_x_m"]) for r in traj]
    oy = [float(r["odom_y_m"]) for r in traj]
    ax.plot(tx, ty, color="tab:green", lw=2, label="true path", zorder=3)
    ax.plot(ox, oy, color="tab:red", lw=1.5, ls="--", label="wheel odometry", zorder=4)
    ax.plot(tx[0], ty[0], "o", color="black", label="start", zorder=5)
    err = math.hypot(tx[-1] - ox[-1], ty[-1] - oy[-1])
    length = sum(math.hypot(tx[i + 1] - tx[i], ty[i + 1] - ty[i]) for i in range(len(tx) - 1))
    ax.set_title(f"{len(traj)} frames, {length:.1f} m driven; final odometry error {err:.2f} m")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    out = d / "trajectory.png"
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"plot: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
