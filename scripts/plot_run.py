#!/usr/bin/python3
"""Pictures of one `twocam run` output folder, for a robotics engineer.

Usage: scripts/plot_run.py OUTDIR [--sample-only]

Reads OUTDIR/metrics.json (required), landmarks.csv, trajectory_odom.tum, trajectory_est.tum,
trajectory_gt.tum, timings.csv, localization.csv, slip_events.csv, map_voxels.csv,
map_eval_voxels.csv, world_outline.csv and sample_frame/{left.png,right.png,hypotheses.csv} (all
optional) and writes into OUTDIR/pictures/:
  map_topdown.png             landmarks, map voxels and tracks seen from above (the robot's world
                              frame; plus the map's voxels against the true world when available)
  localization.png            per-frame position error of the estimate and of odometry, confirmed
                              landmarks in the pose, slip events and the frames flagged as slips
  confidence_histogram.png    landmark confidence, confirmed vs candidates, correct vs wrong
  precision_vs_threshold.png  precision [%] and landmark count against the confidence threshold
  timings.png                 per-frame stage timings and per-frame counts
  sample_frame.png            the sample stereo pair with every disparity hypothesis of its corners
A picture whose inputs are absent is skipped with a note. --sample-only draws sample_frame.png only.
Exit status: 0 when every picture whose inputs exist was written, 1 when OUTDIR or metrics.json is
unusable or some input file is malformed (the other pictures are still written), 2 on bad usage.
"""
import csv
import json
import math
import sys
from pathlib import Path

try:
    import numpy as np
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: E402
    from matplotlib.collections import PolyCollection  # noqa: E402
    from matplotlib.lines import Line2D  # noqa: E402
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"plot_run: {e}; install Debian's python3-matplotlib and python3-numpy", file=sys.stderr)
    sys.exit(1)

PROG = "plot_run"
DPI = 110


class InputError(Exception):
    """A malformed input file; the message names the file and the problem."""


class Skip(Exception):
    """A picture cannot be drawn because its inputs are absent or empty."""


# ----------------------------------------------------------------------------------------- reading

def read_csv(path):
    """Rows of a CSV file as dicts; [] for a zero-byte or header-only file."""
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            header = reader.fieldnames or []
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise InputError(f"cannot read {path}: {e}") from None
    for i, r in enumerate(rows):
        if None in r or any(v is None for v in r.values()):
            raise InputError(f"{path}: line {i + 2} has {len([v for v in r.values() if v is not None])}"
                             f" fields, the header has {len(header)}")
    return rows


def column(rows, name, path, default=None):
    """Float column as a numpy array (empty cells and 'nan' give NaN).

    A missing column raises InputError unless a default is given (then a constant array)."""
    if not rows:
        return np.zeros(0)
    if name not in rows[0]:
        if default is not None:
            return np.full(len(rows), float(default))
        raise InputError(f"{path}: no column '{name}' (has: {', '.join(rows[0].keys())})")
    out = np.empty(len(rows))
    for i, r in enumerate(rows):
        v = r[name].strip()
        try:
            out[i] = float(v) if v else math.nan
        except ValueError:
            raise InputError(f"{path}: line {i + 2}: column '{name}' is not a number: {v!r}") from None
    return out


def read_tum(path):
    """TUM trajectory 't x y z qx qy qz qw' as an (N, 8) array; '#' lines and blank lines skipped."""
    poses = []
    try:
        with open(path) as f:
            for n, line in enumerate(f, 1):
                line = line.strip()
                if not line or line.startswith("#"):
                    continue
                parts = line.replace(",", " ").split()
                if len(parts) != 8:
                    raise InputError(f"{path}: line {n} has {len(parts)} fields, TUM needs 8 "
                                     "(t x y z qx qy qz qw)")
                try:
                    poses.append([float(p) for p in parts])
                except ValueError:
                    raise InputError(f"{path}: line {n} is not numeric: {line[:60]!r}") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"cannot read {path}: {e}") from None
    return np.array(poses).reshape(-1, 8)


def read_image(path):
    """Grey image as a float array in [0, 1]."""
    import matplotlib.image as mpimg
    try:
        img = mpimg.imread(str(path))
    except Exception as e:  # PIL raises several unrelated types for broken files
        raise InputError(f"cannot read image {path}: {e}") from None
    img = np.asarray(img, dtype=float)
    if img.ndim == 3:
        img = img[..., :3].mean(axis=2)
    if img.ndim != 2 or img.size == 0:
        raise InputError(f"{path}: not a 2-D image (shape {img.shape})")
    if img.max() > 1.0:
        img = img / 255.0
    return img


def num(value):
    """A JSON number as float, or NaN for null / missing / non-numeric."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def load_metrics(path):
    try:
        with open(path) as f:
            m = json.load(f)
    except FileNotFoundError:
        raise InputError(f"no metrics.json in {path.parent} (is it a `twocam run` output folder?)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"cannot read {path}: {e}") from None
    except json.JSONDecodeError as e:
        raise InputError(f"{path} is not valid JSON: {e}") from None
    if not isinstance(m, dict):
        raise InputError(f"{path}: expected a JSON object at the top level, found {type(m).__name__}")
    for key in ("landmarks", "octomap", "timing_ms"):
        if key in m and not isinstance(m[key], dict):
            raise InputError(f"{path}: '{key}' should be an object, found {type(m[key]).__name__}")
    if "calibration" in m and not isinstance(m["calibration"], list):
        raise InputError(f"{path}: 'calibration' should be a list, found {type(m['calibration']).__name__}")
    # Wall-clock times live in timing.json beside metrics.json (metrics.json stays identical from
    # run to run); take them from there when metrics.json has none.
    timing_path = path.parent / "timing.json"
    if "timing_ms" not in m and timing_path.exists():
        try:
            with open(timing_path) as f:
                t = json.load(f)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise InputError(f"{timing_path} is not valid JSON: {e}") from None
        if isinstance(t, dict) and isinstance(t.get("timing_ms"), dict):
            m["timing_ms"] = t["timing_ms"]
    return m


class Run:
    """Lazily loaded contents of OUTDIR."""

    def __init__(self, outdir, metrics):
        self.dir = outdir
        self.metrics = metrics
        self._cache = {}

    def path(self, name):
        return self.dir / name

    def has(self, name):
        return self.path(name).is_file()

    def csv(self, name):
        if name not in self._cache:
            self._cache[name] = read_csv(self.path(name))
        return self._cache[name]

    def tum(self, name):
        key = "tum:" + name
        if key not in self._cache:
            self._cache[key] = read_tum(self.path(name)) if self.has(name) else None
        return self._cache[key]

    def landmarks(self):
        """dict of numpy columns of landmarks.csv, or None when the file is absent."""
        if "lm" not in self._cache:
            if not self.has("landmarks.csv"):
                self._cache["lm"] = None
            else:
                p = self.path("landmarks.csv")
                rows = self.csv("landmarks.csv")
                lm = {k: column(rows, k, p) for k in ("x", "y", "z", "confirmed", "confidence")}
                lm["verdict"] = column(rows, "verdict", p, default=-1)
                lm["verdict"][np.isnan(lm["verdict"])] = -1
                lm["n"] = len(rows)
                self._cache["lm"] = lm
        return self._cache["lm"]

    @property
    def ground_truth(self):
        return bool(self.metrics.get("ground_truth", False))


def save(fig, run, name):
    out_dir = run.dir / "pictures"
    out_dir.mkdir(exist_ok=True)
    out = out_dir / name
    fig.savefig(out, dpi=DPI)
    plt.close(fig)
    print(f"plot: {out}")
    return out


# ----------------------------------------------------------------------------------------- drawing

def voxel_squares(x, y, size):
    """Top-down squares of voxels (duplicates in the same column removed)."""
    if len(x) == 0:
        return np.zeros((0, 4, 2))
    key = np.round(np.stack([x, y, size], axis=1), 4)
    key = np.unique(key, axis=0)
    cx, cy, h = key[:, 0], key[:, 1], key[:, 2] / 2
    return np.stack([np.stack([cx - h, cy - h], 1), np.stack([cx + h, cy - h], 1),
                     np.stack([cx + h, cy + h], 1), np.stack([cx - h, cy + h], 1)], axis=1)


def draw_outline(ax, run):
    rows = run.csv("world_outline.csv")
    p = run.path("world_outline.csv")
    if not rows:
        return False
    for k in ("shape", "kind", "x_m", "y_m"):
        if k not in rows[0]:
            raise InputError(f"{p}: no column '{k}'")
    shapes = {}
    for i, r in enumerate(rows):
        try:
            shapes.setdefault((r["shape"], r["kind"]), []).append((float(r["x_m"]), float(r["y_m"])))
        except ValueError:
            raise InputError(f"{p}: line {i + 2}: x_m/y_m not numeric") from None
    for (_, kind), pts in shapes.items():
        xs, ys = zip(*pts)
        if kind == "floor":
            continue
        if kind == "overhead":
            ax.plot(xs, ys, color="0.55", lw=1.0, ls="--", zorder=2)
        else:
            ax.plot(xs, ys, color="0.25", lw=1.8 if kind == "wall" else 1.1, zorder=2)
    return True


def draw_track(ax, traj, label, style):
    if traj is None or len(traj) == 0:
        return None
    ax.plot(traj[:, 1], traj[:, 2], label=f"{label} ({len(traj)} poses)", zorder=6, **style)
    first = not getattr(ax, "_twocam_start_drawn", False)
    ax.plot(traj[0, 1], traj[0, 2], "o", color="black", ms=5, zorder=7, label="start" if first else None)
    ax._twocam_start_drawn = True
    return traj[:, 1:3]


ODOM_STYLE = dict(color="tab:red", lw=1.6, ls="--")
TRUE_STYLE = dict(color="tab:green", lw=2.0)
EST_STYLE = dict(color="tab:blue", lw=1.4)


def view_box(full, robust):
    """Axis box (lo, hi) that shows all `full` points and the central 98 % of the `robust` points
    (a few landmarks or voxels kilometres away should not shrink the map to a dot)."""
    pts = [np.asarray(c).reshape(-1, 2) for c in full if c is not None and len(c)]
    for c in robust:
        if c is None or not len(c):
            continue
        c = np.asarray(c).reshape(-1, 2)
        pts.append(np.percentile(c, [1, 99], axis=0) if len(c) >= 50 else c)
    if not pts:
        return np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    allp = np.concatenate(pts)
    allp = allp[np.isfinite(allp).all(axis=1)]
    if not len(allp):
        return np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = np.maximum(0.05 * (hi - lo).max(), 0.3)
    return lo - pad, hi + pad


def n_outside(pts, box):
    if pts is None or not len(pts):
        return 0
    lo, hi = box
    return int(((pts < lo) | (pts > hi)).any(axis=1).sum())


def plot_map_topdown(run):
    odom = run.tum("trajectory_odom.tum")
    gt = run.tum("trajectory_gt.tum")
    odom = odom if odom is not None and len(odom) else None
    gt = gt if gt is not None and len(gt) else None
    est = run.tum("trajectory_est.tum")
    est = est if est is not None and len(est) else None
    mode = (run.metrics.get("localization") or {}).get("mode", "?")
    lm = run.landmarks()
    lm = lm if lm is not None and lm["n"] else None
    vox_sq = None
    if run.has("map_voxels.csv"):
        rows = run.csv("map_voxels.csv")
        p = run.path("map_voxels.csv")
        vox_n = len(rows)
        vox_sq = voxel_squares(column(rows, "x", p), column(rows, "y", p), column(rows, "size", p))
    have_eval = run.has("map_eval_voxels.csv")
    if odom is None and gt is None and lm is None and (vox_sq is None or not len(vox_sq)) and not have_eval:
        raise Skip("no trajectory, landmarks or map voxels")

    # --- data of the right panel first, so both panels can be sized together
    if have_eval:
        rows = run.csv("map_eval_voxels.csv")
        p = run.path("map_eval_voxels.csv")
        ex, ey, esize = column(rows, "x", p), column(rows, "y", p), column(rows, "size", p)
        phantom = column(rows, "phantom", p) > 0.5
        eval_n = len(rows)
        outline_pts = []
        if run.has("world_outline.csv") and run.csv("world_outline.csv"):
            orows = run.csv("world_outline.csv")
            outline_pts = [column(orows, "x_m", run.path("world_outline.csv")),
                           column(orows, "y_m", run.path("world_outline.csv"))]
            outline_pts = np.stack(outline_pts, axis=1)
        eval_xy = np.stack([ex, ey], axis=1)
        box_r = view_box([outline_pts, None if gt is None else gt[:, 1:3]], [eval_xy])

    lm_xy = conf = None
    if lm is not None:
        conf = lm["confirmed"] > 0.5
        lm_xy = np.stack([lm["x"], lm["y"]], axis=1)
    robust = [lm_xy[conf] if conf is not None and conf.any() else lm_xy]
    if vox_sq is not None and len(vox_sq):
        robust.append(vox_sq.mean(axis=1))
    box_l = view_box([None if odom is None else odom[:, 1:3], None if gt is None else gt[:, 1:3],
                      None if est is None else est[:, 1:3]], robust)

    spans = [box_l[1] - box_l[0]] + ([box_r[1] - box_r[0]] if have_eval else [])
    ratio = max(s[1] / max(s[0], 1e-9) for s in spans)
    panel_w = 7.5
    fig_h = min(11.0, max(4.5, panel_w * ratio)) + 1.3
    ncols = 2 if have_eval else 1
    fig, axes = plt.subplots(1, ncols, figsize=(panel_w * ncols + 1.6, fig_h), squeeze=False)

    # --- left: odometry frame
    ax = axes[0, 0]
    if vox_sq is not None and len(vox_sq):
        ax.add_collection(PolyCollection(vox_sq, facecolors="0.72", edgecolors="none", zorder=1,
                                         label=f"map voxels ({vox_n}, top-down)"))
    draw_track(ax, odom, "odometry track", ODOM_STYLE)
    draw_track(ax, gt, "true track", TRUE_STYLE)
    draw_track(ax, est, f"estimated track ({mode})", EST_STYLE)
    n_conf = n_cand = 0
    if lm is not None:
        n_conf, n_cand = int(conf.sum()), int((~conf).sum())
        if n_cand:
            ax.scatter(lm["x"][~conf], lm["y"][~conf], s=2, c="0.45", alpha=0.5, linewidths=0,
                       zorder=3, label=f"candidate landmarks ({n_cand})")
        if n_conf:
            order = np.argsort(lm["confidence"][conf])  # most confident drawn on top
            sc = ax.scatter(lm["x"][conf][order], lm["y"][conf][order], s=5,
                            c=lm["confidence"][conf][order], cmap="viridis", vmin=0, vmax=1,
                            linewidths=0, zorder=4)
            ax.scatter([], [], s=5, color=plt.get_cmap("viridis")(0.9),  # legend proxy
                       label=f"confirmed landmarks ({n_conf}, colour = confidence)")
            fig.colorbar(sc, ax=ax, fraction=0.04, pad=0.02, label="confirmed landmark confidence")
    ax.set_xlim(box_l[0][0], box_l[1][0])
    ax.set_ylim(box_l[0][1], box_l[1][1])
    sub = [f"{n_conf} confirmed, {n_cand} candidate landmarks"]
    if lm is not None:
        hid_conf, hid_cand = n_outside(lm_xy[conf], box_l), n_outside(lm_xy[~conf], box_l)
        if hid_conf or hid_cand:
            sub.append(f"outside the view: {hid_conf} confirmed, {hid_cand} candidates")
    frame_name = "estimated" if est is not None else "odometry"
    ax.set_title(f"the robot's world frame ({frame_name} poses: what the robot built)\n" + "; ".join(sub),
                 fontsize=10)
    finish_topdown(ax)

    # --- right: true world frame
    if have_eval:
        ax = axes[0, 1]
        outline = run.has("world_outline.csv") and draw_outline(ax, run)
        good_sq = voxel_squares(ex[~phantom], ey[~phantom], esize[~phantom])
        ph_sq = voxel_squares(ex[phantom], ey[phantom], esize[phantom])
        if len(good_sq):
            ax.add_collection(PolyCollection(good_sq, facecolors="tab:blue", alpha=0.4, edgecolors="none",
                                             zorder=3, label=f"voxels near a surface ({int((~phantom).sum())})"))
        if len(ph_sq):
            ax.add_collection(PolyCollection(ph_sq, facecolors="red", alpha=0.85, edgecolors="none",
                                             zorder=4, label=f"phantom voxels ({int(phantom.sum())})"))
        draw_track(ax, gt, "true track", TRUE_STYLE)
        draw_track(ax, est if est is not None else odom, "track the map was built with",
                   EST_STYLE if est is not None else ODOM_STYLE)
        if outline:
            ax.plot([], [], color="0.25", lw=1.8, label="world (walls, objects)")
            ax.plot([], [], color="0.55", lw=1.0, ls="--", label="overhead objects")
        ax.set_xlim(box_r[0][0], box_r[1][0])
        ax.set_ylim(box_r[0][1], box_r[1][1])
        om = run.metrics.get("octomap", {}) or {}
        frac = num(om.get("phantom_fraction"))
        if math.isnan(frac) and eval_n:
            frac = phantom.sum() / eval_n
        if not math.isnan(frac) and frac > 1.0:  # written in percent
            frac /= 100.0
        res = num(om.get("resolution_m"))
        t = f"{int(phantom.sum())} phantom of {eval_n} occupied voxels"
        if not math.isnan(frac):
            t += f" (phantom_fraction {frac:.1%})"
        if not math.isnan(res):
            t += f", resolution {res:.2f} m"
        hidden = n_outside(eval_xy[phantom], box_r)
        if hidden:
            t += f"\n{hidden} phantom voxels outside the view"
        ax.set_title("the map as built, against the true world\n" + t, fontsize=10)
        finish_topdown(ax, "x [m] (true world)", "y [m] (true world)")
    fig.suptitle(run_label(run), fontsize=11)
    fig.tight_layout()
    return save(fig, run, "map_topdown.png")


def finish_topdown(ax, xlabel="x [m] (robot's world: forward)", ylabel="y [m] (robot's world: left)"):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    leg = ax.legend(loc="best", fontsize=8, markerscale=3, framealpha=0.85)
    if leg:
        leg.set_zorder(10)


def run_label(run):
    m = run.metrics
    parts = [f"policy {m.get('policy', '?')}", f"{m.get('frames', '?')} frames",
             "ground truth" if run.ground_truth else "no ground truth"]
    return f"{run.dir.name}: " + ", ".join(parts)


def plot_confidence_histogram(run):
    lm = run.landmarks()
    if lm is None:
        raise Skip("no landmarks.csv")
    if lm["n"] == 0:
        raise Skip("landmarks.csv has no landmarks")
    bins = np.linspace(0, 1, 21)
    conf = lm["confirmed"] > 0.5
    v = lm["verdict"]
    judged = bool((v != -1).any())
    panels = []
    for name, sel in (("confirmed landmarks", conf), ("candidate landmarks", ~conf)):
        ok = sel & np.isfinite(lm["confidence"])
        c, vs = np.clip(lm["confidence"][ok], 0, 1), v[ok]
        if judged:
            parts = [(c[vs == 1], "correct", "tab:green"), (c[vs == 0], "wrong", "tab:red"),
                     (c[vs == -1], "unjudged", "0.55")]
            parts = [q for q in parts if len(q[0])]
        else:
            parts = [(c, "no verdicts (no ground truth)", "tab:blue" if sel is conf else "0.45")] if len(c) else []
        panels.append((name, sel, vs, parts))
    # log y when the bin counts span more than two decades; then overlay instead of stacking,
    # because stacked segments on a log axis hide the small (wrong) counts
    counts = np.concatenate([np.histogram(q[0], bins=bins)[0] for *_, parts in panels for q in parts]
                            or [np.zeros(1)])
    counts = counts[counts > 0]
    log = bool(len(counts)) and counts.max() / counts.min() > 100

    fig, axes = plt.subplots(1, 2, figsize=(13, 5), sharex=True)
    for ax, (name, sel, vs, parts) in zip(axes, panels):
        if not parts:
            ax.text(0.5, 0.5, "none", transform=ax.transAxes, ha="center", va="center", color="0.4")
        elif log:
            for data, label, colour in parts:
                ax.hist(data, bins=bins, histtype="stepfilled", color=colour, alpha=0.25)
                ax.hist(data, bins=bins, histtype="step", color=colour, lw=2,
                        label=f"{label} ({len(data)})")
        else:
            ax.hist([q[0] for q in parts], bins=bins, stacked=True, color=[q[2] for q in parts],
                    label=[f"{q[1]} ({len(q[0])})" for q in parts], edgecolor="white", linewidth=0.5)
        if parts:  # confirmed landmarks crowd the right end, so their legend goes left
            ax.legend(fontsize=8, loc="upper left" if sel is conf else "best")
        t = f"{name}: {int(sel.sum())}"
        j = vs != -1
        if judged and j.any():
            t += f", {100.0 * (vs[j] == 1).mean():.1f}% of judged correct"
        ax.set_title(t, fontsize=10)
        ax.set_xlabel("confidence")
        if log:
            ax.set_yscale("log")
            ax.set_ylabel("landmarks per bin (log scale, overlaid)")
        else:
            ax.set_ylabel("landmarks per bin" + (" (stacked)" if judged else ""))
        ax.grid(True, axis="y", alpha=0.3)
        ax.set_xlim(0, 1)
    fig.suptitle("landmark confidence (bins of 0.05) — " + run_label(run), fontsize=11)
    fig.tight_layout()
    return save(fig, run, "confidence_histogram.png")


def plot_precision_vs_threshold(run):
    cal = run.metrics.get("calibration") or []
    pts = []
    for i, e in enumerate(cal):
        if not isinstance(e, dict):
            raise InputError(f"{run.path('metrics.json')}: calibration[{i}] is not an object")
        pts.append((num(e.get("threshold")), num(e.get("precision")), num(e.get("landmarks"))))
    pts = [p for p in pts if not math.isnan(p[0])]
    lm = run.landmarks()
    fine = None
    if lm is not None and lm["n"]:
        j = lm["verdict"] != -1
        if j.any():
            c, ok = lm["confidence"][j], lm["verdict"][j] == 1
            th = np.linspace(0, 1, 101)
            n = np.array([(c >= t).sum() for t in th])
            good = np.array([(ok & (c >= t)).sum() for t in th])
            with np.errstate(invalid="ignore", divide="ignore"):
                prec = np.where(n > 0, 100.0 * good / np.maximum(n, 1), np.nan)
            fine = (th, prec, n)
    if not pts and fine is None:
        raise Skip("no calibration in metrics.json and no judged landmarks in landmarks.csv")
    if fine is None and all(math.isnan(q[1]) for q in pts):
        raise Skip("no precision at any calibration threshold (no judged landmarks)")

    fig, ax = plt.subplots(figsize=(9, 6.5))
    ax2 = ax.twinx()
    handles = []
    if fine is not None:
        th, prec, n = fine
        handles += ax.plot(th, prec, color="tab:blue", lw=1.8,
                           label="precision, landmarks.csv (judged landmarks, step 0.01)")
        handles += ax2.plot(th, n, color="tab:orange", lw=1.2, ls="--",
                            label="landmarks ≥ threshold, landmarks.csv (judged)")
    if pts:
        t, p, n = (np.array(a) for a in zip(*pts))
        ok = ~np.isnan(p)
        handles += ax.plot(t[ok], p[ok], "o", color="navy", ms=7, mfc="white", mew=2,
                           label="precision, metrics.json calibration")
        for tt in t[~ok]:
            ax.axvline(tt, color="0.7", lw=0.8, ls=":")
        if (~ok).any():
            handles.append(Line2D([], [], color="0.7", lw=0.8, ls=":",
                                  label="calibration threshold with no landmarks (precision n/a)"))
        okn = ~np.isnan(n)
        handles += ax2.plot(t[okn], n[okn], "s", color="tab:orange", ms=6,
                            label="landmarks ≥ threshold, metrics.json calibration")
        below = True
        for tt, pp in zip(t, p):
            if not math.isnan(pp):  # alternate below / above so close thresholds stay readable
                ax.annotate(f"{pp:.1f}%", (tt, pp), textcoords="offset points", xytext=(0, -15 if below else 8),
                            ha="center", fontsize=7, color="navy")
                below = not below
    ax.set_xlabel("confidence threshold (landmarks with confidence ≥ threshold)")
    ax.set_ylabel("precision [%] (correct / judged)")
    ax2.set_ylabel("number of landmarks ≥ threshold", color="tab:orange")
    ax2.tick_params(axis="y", colors="tab:orange")
    ax2.set_ylim(bottom=0)
    ax.set_xlim(-0.02, 1.02)
    allp = []
    if fine is not None:
        allp += list(fine[1][~np.isnan(fine[1])])
    allp += [p for _, p, _ in pts if not math.isnan(p)]
    lo = min(allp) if allp else 0.0
    ax.set_ylim(max(0.0, math.floor(lo / 5) * 5 - 5), 101)
    ax.grid(True, alpha=0.3)
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=8, frameon=False)
    ax.set_zorder(ax2.get_zorder() + 1)
    ax.patch.set_visible(False)
    lmm = run.metrics.get("landmarks") or {}
    sub = ""
    if "precision" in lmm:
        pr = num(lmm.get("precision"))
        sub = (f"; confirmed: {lmm.get('correct_confirmed', '?')} correct of {lmm.get('confirmed', '?')}"
               + (f" ({pr:.1f}%)" if not math.isnan(pr) else ""))
    ax.set_title("precision against confidence threshold\n" + run_label(run) + sub, fontsize=10)
    fig.tight_layout(rect=(0, 0.01 + 0.032 * ((len(handles) + 1) // 2), 1, 1))
    return save(fig, run, "precision_vs_threshold.png")


def plot_timings(run):
    if not run.has("timings.csv"):
        raise Skip("no timings.csv")
    rows = run.csv("timings.csv")
    p = run.path("timings.csv")
    if not rows:
        raise Skip("timings.csv has no rows")
    frame = column(rows, "frame", p)
    tm = run.metrics.get("timing_ms") or {}
    fig, (ax, axc) = plt.subplots(2, 1, figsize=(12, 8), sharex=True,
                                  gridspec_kw=dict(height_ratios=[3, 2]))
    stages = [(s, c) for s, c in (("frontend", "tab:blue"), ("landmarks", "tab:orange"),
                                  ("localization", "tab:red"), ("mapping", "tab:green"))
              if f"{s}_ms" in rows[0]]
    if stages:
        ys, labels = [], []
        for s, _ in stages:
            y = np.nan_to_num(column(rows, f"{s}_ms", p))
            med = num(tm.get(f"{s}_median"))
            if math.isnan(med):
                med = float(np.median(y))
            p95 = num(tm.get(f"{s}_p95"))
            labels.append(f"{s}: median {med:.2f} ms" + (f", p95 {p95:.2f}" if not math.isnan(p95) else ""))
            ys.append(y)
        ax.stackplot(frame, *ys, labels=labels, colors=[c for _, c in stages], alpha=0.8, linewidth=0)
    if "total_ms" in rows[0]:
        tot = column(rows, "total_ms", p)
        med = num(tm.get("total_median"))
        if math.isnan(med):
            med = float(np.nanmedian(tot))
        ax.plot(frame, tot, color="black", lw=0.8, label=f"total: median {med:.2f} ms")
        top = np.nanpercentile(tot, 99) if np.isfinite(tot).any() else None
        if top and np.nanmax(tot) > 3 * top:  # one slow frame should not flatten the rest
            ax.set_ylim(0, 1.3 * top)
            ax.text(0.99, 0.97, f"clipped: max {np.nanmax(tot):.1f} ms", transform=ax.transAxes,
                    ha="right", va="top", fontsize=8, color="0.3")
    if not stages and "total_ms" not in rows[0]:
        ax.text(0.5, 0.5, "no *_ms columns", transform=ax.transAxes, ha="center")
    ax.set_ylabel("time per frame [ms] (stacked)")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("per-frame timings — " + run_label(run), fontsize=10)
    counts = [(k, c) for k, c in (("corners", "tab:purple"), ("hypotheses", "tab:brown"),
                                  ("candidates", "0.5"), ("confirmed", "tab:green")) if k in rows[0]]
    top = 0.0
    for k, c in counts:
        y = column(rows, k, p)
        top = max(top, float(np.nanmax(y)) if np.isfinite(y).any() else 0.0)
        last = y[~np.isnan(y)][-1] if np.isfinite(y).any() else math.nan
        axc.plot(frame, y, color=c, lw=1.2, label=f"{k} (last {last:.0f})")
    if counts:
        axc.legend(loc="upper left", fontsize=8, ncol=len(counts))
    axc.set_ylabel("count per frame")
    axc.set_xlabel("frame")
    axc.set_ylim(0, 1.22 * top if top > 0 else 1)  # headroom for the legend
    axc.grid(True, alpha=0.3)
    fig.tight_layout()
    return save(fig, run, "timings.png")


def plot_localization(run):
    if not run.has("localization.csv"):
        raise Skip("no localization.csv")
    rows = run.csv("localization.csv")
    p = run.path("localization.csv")
    if not rows:
        raise Skip("localization.csv has no rows")
    t = column(rows, "t_s", p)
    used = column(rows, "landmarks_used", p)
    visual = column(rows, "visual", p) > 0.5
    flagged = column(rows, "slip_flagged", p) > 0.5
    err_odo = column(rows, "odometry_error_m", p)
    err_est = column(rows, "estimate_error_m", p)
    lo = run.metrics.get("localization") or {}
    mode = lo.get("mode", "?")
    tr = run.metrics.get("trajectory") or {}
    ate = tr.get("ate_rmse_m") or {}
    fig, (ax, axl) = plt.subplots(2, 1, figsize=(12, 7.5), sharex=True,
                                  gridspec_kw=dict(height_ratios=[3, 2]))
    if np.isfinite(err_odo).any():
        ax.plot(t, 100 * err_odo, **ODOM_STYLE,
                label=f"odometry (ATE {100 * num(ate.get('odometry')):.1f} cm)")
    if np.isfinite(err_est).any() and mode != "odometry":
        ax.plot(t, 100 * err_est, **EST_STYLE,
                label=f"estimate, {mode} (ATE {100 * num(ate.get(mode)):.1f} cm)")
    if not np.isfinite(err_odo).any():
        ax.text(0.5, 0.5, "no ground truth: no pose error", transform=ax.transAxes, ha="center")
    events = []
    if run.has("slip_events.csv"):
        er = run.csv("slip_events.csv")
        ep = run.path("slip_events.csv")
        if er:
            events = list(zip(column(er, "time_s", ep), column(er, "dx_m", ep), column(er, "dy_m", ep),
                              column(er, "dyaw_deg", ep)))
    for k, (ts, dx, dy, dyaw) in enumerate(events):
        for a in (ax, axl):
            a.axvline(ts, color="tab:orange", lw=1.2, alpha=0.8, zorder=1,
                      label="slip event (world)" if k == 0 and a is ax else None)
        ax.text(ts, 1.0, f" {100 * math.hypot(dx, dy):.0f} cm, {dyaw:.1f}°", transform=ax.get_xaxis_transform(),
                rotation=90, va="top", ha="right", fontsize=7, color="tab:orange")
    if flagged.any():
        top = np.nanmax(100 * err_est) if np.isfinite(err_est).any() else 1.0
        ax.plot(t[flagged], np.full(int(flagged.sum()), 0.95 * top), "v", color="black", ms=7,
                label=f"flagged as slip ({int(flagged.sum())})")
    ax.set_ylabel("position error against the truth [cm]")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title("localisation — " + run_label(run), fontsize=10)
    axl.plot(t, used, color="tab:blue", lw=1.0, label="confirmed landmarks in the pose (inliers)")
    if (~visual).any():
        axl.plot(t[~visual], np.zeros(int((~visual).sum())), "|", color="tab:red", ms=10,
                 label=f"odometry only ({int((~visual).sum())} frames)")
    axl.set_ylabel("landmarks per frame")
    axl.set_xlabel("time [s]")
    axl.set_ylim(bottom=-5)
    axl.grid(True, alpha=0.3)
    axl.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return save(fig, run, "localization.png")


TRUTH_COLOURS = {1: "lime", 0: "red", -1: "0.75"}
STATE_STYLE = {-1: ("deepskyblue", "not in database"), 0: ("orange", "candidate landmark"),
               1: ("magenta", "confirmed landmark")}


def plot_sample_frame(run):
    sf = run.dir / "sample_frame"
    need = [sf / "left.png", sf / "right.png", sf / "hypotheses.csv"]
    missing = [q.name for q in need if not q.is_file()]
    if len(missing) == 3:
        raise Skip("no sample_frame/ folder")
    if missing:
        raise Skip(f"sample_frame/ lacks {', '.join(missing)}")
    left, right = read_image(need[0]), read_image(need[1])
    rows = read_csv(need[2])
    p = need[2]
    h = {k: column(rows, k, p) for k in ("frame", "corner", "u", "v", "rank", "d")}
    h["truth"] = np.nan_to_num(column(rows, "truth", p, default=-1), nan=-1).astype(int)
    h["state"] = np.nan_to_num(column(rows, "landmark_state", p, default=-1), nan=-1).astype(int)
    frames = np.unique(h["frame"][~np.isnan(h["frame"])]) if rows else np.zeros(0)
    frame_no = int(frames[0]) if len(frames) else None
    if len(frames) > 1:  # one frame is expected; keep the first
        keep = h["frame"] == frames[0]
        h = {k: v[keep] for k, v in h.items()}

    H1, W1 = left.shape
    H2, W2 = right.shape
    gap = max(8, H1 // 20)
    W = max(W1, W2)
    canvas = np.ones((H1 + gap + H2, W))
    canvas[:H1, :W1] = left
    canvas[H1 + gap:, :W2] = right
    oy = H1 + gap  # right image offset

    # fixed margins in inches: the image keeps its aspect and the title and legend always fit
    img_w = 9.5 if W >= 400 else 7.0
    img_h = img_w * (H1 + gap + H2) / W
    top_in, bottom_in, side_in = 0.65, 0.6, 0.1
    fig = plt.figure(figsize=(img_w + 2 * side_in, img_h + top_in + bottom_in))
    fw, fh = fig.get_size_inches()
    ax = fig.add_axes((side_in / fw, bottom_in / fh, img_w / fw, img_h / fh))
    ax.imshow(canvas, cmap="gray", vmin=-0.25, vmax=1.25, interpolation="nearest")  # muted: markers pop
    ax.text(4, 4, "left (reference)", color="yellow", fontsize=9, va="top",
            bbox=dict(facecolor="black", alpha=0.5, pad=1, lw=0))
    ax.text(4, oy + 4, "right: hypotheses at (u - d, v)", color="yellow", fontsize=9, va="top",
            bbox=dict(facecolor="black", alpha=0.5, pad=1, lw=0))

    n_rows = len(h["u"])
    corners = {}
    for i in range(n_rows):
        corners.setdefault(int(h["corner"][i]), []).append(i)
    # corners on the left image, coloured by landmark state
    first = np.array([idx[0] for idx in corners.values()], dtype=int)
    for s, (col, name) in STATE_STYLE.items():
        sel = first[h["state"][first] == s] if len(first) else first
        if len(sel):
            ax.plot(h["u"][sel], h["v"][sel], "+", color=col, ms=5, mew=1.0, ls="none")
    # lines for a subset of ambiguous corners
    ambiguous = [c for c, idx in sorted(corners.items()) if len(idx) > 1]
    if len(ambiguous) > 40:
        pick = np.linspace(0, len(ambiguous) - 1, 40).round().astype(int)
        shown = [ambiguous[k] for k in pick]
    else:
        shown = ambiguous
    for c in shown:
        for i in corners[c]:
            ax.plot([h["u"][i], h["u"][i] - h["d"][i]], [h["v"][i], oy + h["v"][i]],
                    color=TRUTH_COLOURS.get(h["truth"][i], "0.75"),
                    lw=1.1 if h["rank"][i] == 0 else 0.6, alpha=0.7 if h["rank"][i] == 0 else 0.45)
        i0 = corners[c][0]
        ax.plot(h["u"][i0], h["v"][i0], "o", mfc="none", mec="yellow", ms=6, mew=1.0)
    # hypotheses on the right image: best filled, others hollow; colour by truth
    xr, yr = h["u"] - h["d"], oy + h["v"]
    for t, col in TRUTH_COLOURS.items():
        best = (h["truth"] == t) & (h["rank"] == 0)
        other = (h["truth"] == t) & (h["rank"] != 0)
        ax.plot(xr[other], yr[other], "o", mfc="none", mec=col, ms=4, mew=0.8, ls="none")
        ax.plot(xr[best], yr[best], "o", color=col, mec="black", ms=4, mew=0.4, ls="none")
    ax.set_xlim(-0.5, W - 0.5)
    ax.set_ylim(H1 + gap + H2 - 0.5, -0.5)
    ax.set_xticks([])
    ax.set_yticks([])

    n_c = len(corners)
    tr = h["truth"]
    best = h["rank"] == 0
    judged_best = best & (tr != -1)
    t = (f"frame {frame_no if frame_no is not None else '?'}: {n_c} corners, {n_rows} hypotheses "
         f"({(tr == 1).sum()} true, {(tr == 0).sum()} false, {(tr == -1).sum()} unknown), "
         f"{len(ambiguous)} corners with >1 hypothesis")
    if judged_best.any():
        t += f"\nbest hypothesis true for {100.0 * (tr[judged_best] == 1).mean():.1f}% of judged corners"
    t += f"; lines for {len(shown)} ambiguous corners (yellow rings)"
    ax.set_title(t, fontsize=9)
    handles = [Line2D([], [], marker="o", color=TRUTH_COLOURS[1], mec="black", ls="none", label="best (rank 0), true"),
               Line2D([], [], marker="o", color=TRUTH_COLOURS[0], mec="black", ls="none", label="best, false"),
               Line2D([], [], marker="o", mfc="none", mec=TRUTH_COLOURS[1], ls="none", label="other rank, true"),
               Line2D([], [], marker="o", mfc="none", mec=TRUTH_COLOURS[0], ls="none", label="other rank, false"),
               Line2D([], [], marker="o", mfc="none", mec=TRUTH_COLOURS[-1], ls="none", label="truth unknown")]
    handles += [Line2D([], [], marker="+", color=col, ls="none", mew=1.5, label=f"corner: {name}")
                for col, name in STATE_STYLE.values()]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    return save(fig, run, "sample_frame.png")


# -------------------------------------------------------------------------------------------- main

PICTURES = [("map_topdown", plot_map_topdown), ("localization", plot_localization),
            ("confidence_histogram", plot_confidence_histogram),
            ("precision_vs_threshold", plot_precision_vs_threshold), ("timings", plot_timings),
            ("sample_frame", plot_sample_frame)]


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    flags = [a for a in argv if a.startswith("--")]
    if len(args) != 1 or any(f not in ("--sample-only",) for f in flags) or "--help" in flags:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    outdir = Path(args[0])
    if not outdir.is_dir():
        print(f"{PROG}: OUTDIR is not a directory: {outdir}", file=sys.stderr)
        return 1
    try:
        metrics = load_metrics(outdir / "metrics.json")
    except InputError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    run = Run(outdir, metrics)
    todo = [p for p in PICTURES if p[0] == "sample_frame"] if "--sample-only" in flags else PICTURES
    written, skipped, failed = [], [], []
    for name, fn in todo:
        try:
            fn(run)
            written.append(name)
        except Skip as e:
            print(f"{PROG}: skipped {name}.png: {e}")
            skipped.append(name)
        except InputError as e:
            plt.close("all")
            print(f"{PROG}: {name}.png not written: {e}", file=sys.stderr)
            failed.append(name)
        except OSError as e:
            plt.close("all")
            print(f"{PROG}: {name}.png not written: {e}", file=sys.stderr)
            failed.append(name)

    lmm = metrics.get("landmarks") or {}
    bits = [f"policy {metrics.get('policy', '?')}", f"{metrics.get('frames', '?')} frames"]
    if "confirmed" in lmm:
        bits.append(f"{lmm['confirmed']} confirmed landmarks")
    pr = num(lmm.get("precision"))
    if not math.isnan(pr):
        bits.append(f"precision {pr:.1f}%")
    om = metrics.get("octomap") or {}
    if "occupied" in om:
        bits.append(f"{om['occupied']} occupied voxels" +
                    (f", {om['phantom']} phantom" if "phantom" in om else ""))
    print(f"{PROG}: {len(written)} pictures in {outdir / 'pictures'}"
          + (f", {len(skipped)} skipped" if skipped else "")
          + (f", {len(failed)} FAILED ({', '.join(failed)})" if failed else "")
          + " — " + ", ".join(bits))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
