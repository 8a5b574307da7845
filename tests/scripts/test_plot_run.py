#!/usr/bin/python3
"""Tests scripts/plot_run.py on synthetic `twocam run` output folders.

Usage: /usr/bin/python3 tests/scripts/test_plot_run.py [-v]
The script is found through TWOCAM_SOURCE_DIR, or relative to this file. Exits 77 (ctest skip)
when python3-matplotlib or python3-numpy is not installed.
"""
import json
import math
import os
import random
import struct
import subprocess
import sys
import tempfile
import unittest
import zlib
from pathlib import Path

SKIP = 77
try:
    import matplotlib  # noqa: F401
    import numpy  # noqa: F401
except ImportError as e:
    print(f"test_plot_run: skipped, {e} (install python3-matplotlib and python3-numpy)")
    sys.exit(SKIP)

SOURCE_DIR = Path(os.environ.get("TWOCAM_SOURCE_DIR", Path(__file__).resolve().parents[2]))
SCRIPT = SOURCE_DIR / "scripts" / "plot_run.py"
ALL_PICTURES = ["map_topdown.png", "localization.png", "confidence_histogram.png",
                "precision_vs_threshold.png", "timings.png", "sample_frame.png"]

LANDMARK_HEADER = ("id,x,y,z,confirmed,confidence,n_obs,first_frame,anchor_frame,anchor_u,anchor_v,"
                   "anchor_d,confirmed_frame,verdict,error_m,anchor_d_gt,estimate_anchor_d")
TIMINGS_HEADER = "frame,frontend_ms,landmarks_ms,mapping_ms,total_ms,corners,hypotheses,candidates,confirmed"


# ------------------------------------------------------------------------------ synthetic run output

def write_grey_png(path, width, height, pixel):
    """8-bit grey PNG (what the C++ side writes), pixel(x, y) -> 0..255; stdlib only."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)  # filter type none
        raw.extend(pixel(x, y) for x in range(width))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(bytes(raw))) + chunk(b"IEND", b""))
    Path(path).write_bytes(png)


WALLS = [((0, 0), (6, 0)), ((6, 0), (6, 4)), ((6, 4), (0, 4)), ((0, 4), (0, 0))]
BOX = [(4.0, 0.8), (4.6, 0.8), (4.6, 1.4), (4.0, 1.4), (4.0, 0.8)]
CYL_C, CYL_R = (1.8, 2.9), 0.3
SHELF = [(0.2, 3.4), (2.5, 3.4), (2.5, 3.8), (0.2, 3.8), (0.2, 3.4)]


def true_pose(i, n):
    a = 2 * math.pi * i / n
    return 3.0 + 2.0 * math.sin(a), 2.0 - 1.1 * math.cos(a), a


def odom_from_true(x, y, i, n):
    # odometry drifts: slowly growing rotation about the start plus a small scale error
    x0, y0, _ = true_pose(0, n)
    ang = 0.06 * i / n
    dx, dy = 1.02 * (x - x0), 1.02 * (y - y0)
    return x0 + dx * math.cos(ang) - dy * math.sin(ang), y0 + dx * math.sin(ang) + dy * math.cos(ang)


def surface_point(rng):
    r = rng.random()
    if r < 0.7:
        (x0, y0), (x1, y1) = rng.choice(WALLS)
        t = rng.random()
        return x0 + t * (x1 - x0), y0 + t * (y1 - y0), rng.uniform(0, 2.5)
    if r < 0.85:
        t = rng.random()
        side = rng.randrange(4)
        (x0, y0), (x1, y1) = BOX[side], BOX[side + 1]
        return x0 + t * (x1 - x0), y0 + t * (y1 - y0), rng.uniform(0, 0.8)
    a = rng.uniform(0, 2 * math.pi)
    return CYL_C[0] + CYL_R * math.cos(a), CYL_C[1] + CYL_R * math.sin(a), rng.uniform(0, 1.5)


def write_full_run(d, n_frames=150, n_landmarks=600, seed=7, ground_truth=True):
    """Every file `twocam run` may write, for a small simulated run."""
    rng = random.Random(seed)
    d.mkdir(parents=True, exist_ok=True)
    res = 0.1
    # trajectories
    with open(d / "trajectory_odom.tum", "w") as fo, open(d / "trajectory_gt.tum", "w") as fg:
        fo.write("# timestamp tx ty tz qx qy qz qw\n")
        fg.write("# ground truth body poses\n")
        for i in range(n_frames):
            x, y, yaw = true_pose(i, n_frames)
            ox, oy = odom_from_true(x, y, i, n_frames)
            q = f"0 0 {math.sin(yaw / 2):.6f} {math.cos(yaw / 2):.6f}"
            fg.write(f"{i / 15:.6f} {x:.6f} {y:.6f} 0.3 {q}\n")
            fo.write(f"{i / 15:.6f} {ox:.6f} {oy:.6f} 0.3 {q}\n")
    # landmarks
    lm_rows, true_pts, odom_pts = [], [], []
    for k in range(n_landmarks):
        tx, ty, tz = surface_point(rng)
        frame = rng.randrange(n_frames)
        confirmed = rng.random() < 0.55
        if confirmed:
            conf = min(1.0, max(0.3, rng.betavariate(8, 1)))
            correct = rng.random() < 0.93 + 0.06 * conf - 0.05
        else:
            conf = rng.betavariate(2, 4)
            correct = rng.random() < 0.55
        err = abs(rng.gauss(0, 0.02)) if correct else rng.uniform(0.15, 3.0)
        a = rng.uniform(0, 2 * math.pi)
        ex, ey = tx + err * math.cos(a), ty + err * math.sin(a)
        if rng.random() < 0.01:  # a few far-away wrong ones, as real runs have
            ex, ey, err, correct = ex + 12, ey - 5, 13.0, False
        ox, oy = odom_from_true(ex, ey, frame, n_frames)
        unjudged = rng.random() < 0.04 or not ground_truth
        verdict = -1 if unjudged else (1 if correct else 0)
        d_est = rng.uniform(4, 60)
        lm_rows.append(f"{k},{ox:.5f},{oy:.5f},{tz:.4f},{int(confirmed)},{conf:.5f},{rng.randint(3, 60)},"
                       f"{frame},{frame},{rng.randint(0, 159)},{rng.randint(0, 119)},{d_est:.3f},"
                       f"{frame + 10 if confirmed else -1},{verdict},"
                       f"{'' if unjudged else f'{err:.5f}'},{'' if unjudged else f'{d_est + err:.3f}'},"
                       f"{d_est:.3f}")
        if confirmed:
            odom_pts.append((ox, oy, tz))
            true_pts.append((ex, ey, tz, err))
    (d / "landmarks.csv").write_text(LANDMARK_HEADER + "\n" + "\n".join(lm_rows) + "\n")
    # voxels
    def vox(v):
        return (math.floor(v / res) + 0.5) * res
    occ = {}
    for x, y, z in odom_pts:
        key = (vox(x), vox(y), vox(z))
        occ[key] = min(0.97, occ.get(key, 0.5) + 0.15)
    with open(d / "map_voxels.csv", "w") as f:
        f.write("x,y,z,size,probability\n")
        for (x, y, z), p in sorted(occ.items()):
            f.write(f"{x:.3f},{y:.3f},{z:.3f},{res},{p:.3f}\n")
    ev = {}
    for x, y, z, err in true_pts:
        ev[(vox(x), vox(y), vox(z))] = err
    n_phantom = 0
    with open(d / "map_eval_voxels.csv", "w") as f:
        f.write("x,y,z,size,distance_m,phantom\n")
        for (x, y, z), err in sorted(ev.items()):
            phantom = int(err > 2 * res)
            n_phantom += phantom
            f.write(f"{x:.3f},{y:.3f},{z:.3f},{res},{err:.4f},{phantom}\n")
    # world outline (same column layout as `twocam simulate`)
    shapes = [("room_floor", "floor", [(0, 0), (6, 0), (6, 4), (0, 4), (0, 0)]),
              ("room_walls", "wall", [WALLS[0][0]] + [w[1] for w in WALLS]),
              ("desk", "box", BOX),
              ("bin", "cylinder", [(CYL_C[0] + CYL_R * math.cos(2 * math.pi * t / 16),
                                    CYL_C[1] + CYL_R * math.sin(2 * math.pi * t / 16)) for t in range(17)]),
              ("shelf", "overhead", SHELF)]
    with open(d / "world_outline.csv", "w") as f:
        f.write("shape,name,kind,x_m,y_m\n")
        for i, (name, kind, pts) in enumerate(shapes):
            for x, y in pts:
                f.write(f"{i},{name},{kind},{x:g},{y:g}\n")
    # timings
    with open(d / "timings.csv", "w") as f:
        f.write(TIMINGS_HEADER + "\n")
        cand = conf_n = 0
        for i in range(n_frames):
            fe, lmk, mp = rng.gauss(1.0, 0.08), rng.gauss(1.4, 0.2) + (5 if i == 0 else 0), rng.gauss(0.6, 0.1)
            corners = rng.randint(900, 1200)
            cand = max(0, cand + rng.randint(-20, 60))
            conf_n += rng.randint(0, 8) if i > 10 else 0
            f.write(f"{i},{fe:.4f},{lmk:.4f},{mp:.4f},{fe + lmk + mp:.4f},{corners},"
                    f"{int(corners * 2.6)},{cand},{conf_n}\n")
    # localisation: an estimated track, per-frame errors, two slip events, one flagged
    with open(d / "localization.csv", "w") as f, open(d / "trajectory_est.tum", "w") as fe:
        f.write("frame,t_s,visual,landmarks_used,slip_flagged,odometry_error_m,estimate_error_m\n")
        for i in range(n_frames):
            visual = int(i > 3 and i % 37 != 0)
            f.write(f"{i},{i / 15:.4f},{visual},{rng.randint(20, 400) * visual},{int(i == 61)},"
                    f"{0.001 * i:.5f},{0.005 + 0.002 * rng.random():.5f}\n")
            x, y, _ = true_pose(i, n_frames)
            fe.write(f"{i / 15:.6f} {x + 0.004:.5f} {y - 0.003:.5f} 0 0 0 0 1\n")
    (d / "slip_events.csv").write_text("frame,time_s,dx_m,dy_m,dyaw_deg\n60,4.0,0.04,0,1.5\n"
                                       "120,8.0,0.1,0.02,-3\n")
    # sample frame: textured left image, right = left shifted by the disparity 6 px
    W, H, D = 160, 120, 6
    sf = d / "sample_frame"
    sf.mkdir(exist_ok=True)
    tex = [[rng.randrange(256) for _ in range(W + D)] for _ in range(H)]
    write_grey_png(sf / "left.png", W, H, lambda x, y: (tex[y][x] + tex[y // 4][x // 4]) // 2)
    write_grey_png(sf / "right.png", W, H,
                   lambda x, y: (tex[y][min(W + D - 1, x + D)] + tex[y // 4][min(W + D - 1, x + D) // 4]) // 2)
    with open(sf / "hypotheses.csv", "w") as f:
        f.write("frame,corner,u,v,rank,d,cost,lr_consistent,landmark_state,truth\n")
        for c in range(60):
            u, v = rng.randint(D + 20, W - 3), rng.randint(3, H - 3)
            n_h = rng.choice([1, 1, 2, 3, 4])
            ds = [D + rng.choice([0, 0, 0, 0.5, 7, 13, -3]) for _ in range(n_h)]
            state = rng.choice([-1, -1, 0, 1])
            for r, dd in enumerate(sorted(ds, key=lambda x: abs(x - D) + rng.random())):
                truth = (int(abs(dd - D) <= 1) if ground_truth else -1) if c % 15 else -1
                f.write(f"42,{c},{u},{v},{r},{dd:.2f},{100 + 40 * r},{int(r == 0)},{state},{truth}\n")
    # metrics
    cal = []
    n_occ = len(ev)
    for t in [0, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99, 1.01]:
        sel = [r.split(",") for r in lm_rows if r.split(",")[13] != "-1" and float(r.split(",")[5]) >= t]
        good = sum(s[13] == "1" for s in sel)
        cal.append({"threshold": t, "landmarks": len(sel), "correct": good,
                    "precision": 100.0 * good / len(sel) if sel else None})
    metrics = {
        "log": "/tmp/sims/office.rawlog", "policy": "consistency", "source": "sad",
        "frames": n_frames, "frames_skipped": 0, "ground_truth": ground_truth,
        "timing_ms": {"frontend_median": 1.0, "frontend_p95": 1.13, "landmarks_median": 1.41,
                      "landmarks_p95": 1.75, "mapping_median": 0.6, "mapping_p95": 0.77,
                      "total_median": 3.01, "total_p95": 3.5},
        "landmarks": {"precision": 95.2, "confirmed": len(odom_pts),
                      "correct_confirmed": int(0.952 * len(odom_pts)), "candidates": n_landmarks - len(odom_pts)},
        "localization": {"mode": "fused", "visual_fraction": 0.95},
        "trajectory": {"ate_rmse_m": {"odometry": 0.07, "fused": 0.006}},
        "octomap": {"occupied": len(occ), "phantom": n_phantom,
                    "phantom_fraction": n_phantom / n_occ if n_occ else 0.0, "resolution_m": res},
        "calibration": cal,
    }
    (d / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics


def write_minimal_no_gt(d, n_frames=80):
    """A run on a real log without ground truth: the four files always written, no landmarks."""
    d.mkdir(parents=True, exist_ok=True)
    (d / "metrics.json").write_text(json.dumps({
        "log": "recorded.rawlog", "policy": "wta-lrc", "frames": n_frames, "ground_truth": False,
        "timing_ms": {"frontend_median": 1.1, "landmarks_median": 1.3, "mapping_median": 0.0,
                      "total_median": 2.4},
        "landmarks": {"confirmed": 0, "candidates": 0}}))
    (d / "landmarks.csv").write_text(LANDMARK_HEADER + "\n")
    with open(d / "trajectory_odom.tum", "w") as f:
        for i in range(n_frames):
            f.write(f"{i * 0.1:.3f} {0.05 * i:.4f} {0.3 * math.sin(i / 10):.4f} 0.3 0 0 0 1\n")
    with open(d / "timings.csv", "w") as f:
        f.write(TIMINGS_HEADER + "\n")
        for i in range(n_frames):
            f.write(f"{i},1.1,1.3,0,2.4,{1000 + i},{2600 + i},0,0\n")


# ------------------------------------------------------------------------------------------- checks

def png_size(path):
    """(width, height) of a PNG file; raises AssertionError when it is not one."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR", f"{path} has no IHDR chunk"
    assert data.rstrip(b"\0")[-8:-4] == b"IEND", f"{path} is truncated"
    return struct.unpack(">II", data[16:24])


class PlotRunTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="twocam_test_plot_run_")
        self.root = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def run_script(self, *args):
        return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True,
                              text=True, timeout=300)

    def assert_ok(self, proc):
        self.assertEqual(proc.returncode, 0, f"stdout:\n{proc.stdout}\nstderr:\n{proc.stderr}")
        self.assertNotIn("Traceback", proc.stderr)

    def assert_pictures(self, outdir, proc, expected):
        pics = outdir / "pictures"
        for name in ALL_PICTURES:
            path = pics / name
            if name in expected:
                self.assertTrue(path.is_file(), f"{name} missing; stdout:\n{proc.stdout}")
                w, h = png_size(path)
                self.assertGreaterEqual(min(w, h), 300, f"{name} is only {w}x{h}")
                self.assertGreater(path.stat().st_size, 15000, f"{name} is suspiciously small")
                self.assertIn(str(path), proc.stdout, f"{name} not printed")
            else:
                self.assertFalse(path.exists(), f"{name} written although its inputs are absent")
                self.assertRegex(proc.stdout, rf"skipped {name}")
        last = proc.stdout.strip().splitlines()[-1]
        self.assertTrue(last.startswith("plot_run: "), f"no summary line: {last!r}")

    def assert_clean_failure(self, proc, words):
        self.assertNotEqual(proc.returncode, 0)
        self.assertNotIn("Traceback", proc.stderr)
        lines = proc.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, f"expected a one-line message, got:\n{proc.stderr}")
        self.assertTrue(lines[0].startswith("plot_run: "), lines[0])
        for w in words:
            self.assertIn(w, lines[0])

    def test_full_simulated_run(self):
        d = self.root / "out_sim"
        write_full_run(d)
        proc = self.run_script(d)
        self.assert_ok(proc)
        self.assert_pictures(d, proc, ALL_PICTURES)
        self.assertIn("precision 95.2%", proc.stdout)
        # the map has the evaluation panel next to the odometry one
        w, h = png_size(d / "pictures" / "map_topdown.png")
        self.assertGreater(w, 1500)

    def test_sample_only(self):
        d = self.root / "out_sample"
        write_full_run(d, n_frames=40, n_landmarks=50)
        proc = self.run_script(d, "--sample-only")
        self.assert_ok(proc)
        self.assertEqual(sorted(p.name for p in (d / "pictures").iterdir()), ["sample_frame.png"])

    def test_empty_landmarks(self):
        d = self.root / "out_empty"
        write_full_run(d, n_frames=60, n_landmarks=0)
        m = json.loads((d / "metrics.json").read_text())
        for e in m["calibration"]:
            e.update(landmarks=0, correct=0, precision=None)
        m["calibration"][1]["precision"] = float("nan")  # json.dumps writes NaN
        m["landmarks"] = {"precision": None, "confirmed": 0, "correct_confirmed": 0}
        m["octomap"] = {"occupied": 0, "phantom": 0, "phantom_fraction": None, "resolution_m": 0.1}
        (d / "metrics.json").write_text(json.dumps(m))
        (d / "landmarks.csv").write_text(LANDMARK_HEADER + "\n")
        proc = self.run_script(d)
        self.assert_ok(proc)
        self.assert_pictures(d, proc, ["map_topdown.png", "localization.png", "timings.png",
                                       "sample_frame.png"])

    def test_no_ground_truth_minimal(self):
        d = self.root / "out_nogt"
        write_minimal_no_gt(d)
        proc = self.run_script(d)
        self.assert_ok(proc)
        self.assert_pictures(d, proc, ["map_topdown.png", "timings.png"])

    def test_no_ground_truth_with_landmarks(self):
        d = self.root / "out_nogt_lm"
        write_full_run(d, n_frames=60, n_landmarks=300, ground_truth=False)
        m = json.loads((d / "metrics.json").read_text())
        for k in ("calibration", "octomap"):
            m.pop(k)
        m["landmarks"] = {"confirmed": m["landmarks"]["confirmed"]}
        (d / "metrics.json").write_text(json.dumps(m))
        for name in ("trajectory_gt.tum", "map_eval_voxels.csv", "world_outline.csv"):
            (d / name).unlink()
        proc = self.run_script(d)
        self.assert_ok(proc)
        # no verdicts and no calibration: nothing to compute a precision from
        self.assert_pictures(d, proc, ["map_topdown.png", "localization.png", "confidence_histogram.png",
                                       "timings.png", "sample_frame.png"])
        w, h = png_size(d / "pictures" / "map_topdown.png")
        self.assertLess(w, 1300)  # one panel only (two panels are about 1800 px wide)

    def test_zero_byte_and_header_only_csvs(self):
        d = self.root / "out_blank"
        write_full_run(d, n_frames=30, n_landmarks=40)
        for name in ("timings.csv", "map_voxels.csv", "world_outline.csv", "sample_frame/hypotheses.csv"):
            (d / name).write_text("")
        (d / "map_eval_voxels.csv").write_text("x,y,z,size,distance_m,phantom\n")
        (d / "trajectory_gt.tum").write_text("# no poses\n")
        proc = self.run_script(d)
        self.assert_ok(proc)
        self.assert_pictures(d, proc, ["map_topdown.png", "localization.png", "confidence_histogram.png",
                                       "precision_vs_threshold.png", "sample_frame.png"])

    def test_missing_outdir(self):
        proc = self.run_script(self.root / "does_not_exist")
        self.assert_clean_failure(proc, ["not a directory", "does_not_exist"])

    def test_missing_metrics(self):
        d = self.root / "out_nometrics"
        d.mkdir()
        proc = self.run_script(d)
        self.assert_clean_failure(proc, ["metrics.json"])

    def test_corrupt_metrics(self):
        d = self.root / "out_corrupt"
        write_minimal_no_gt(d)
        (d / "metrics.json").write_text('{"policy": "consistency", "frames": 12,')
        proc = self.run_script(d)
        self.assert_clean_failure(proc, ["metrics.json", "not valid JSON"])
        self.assertFalse((d / "pictures").exists())

    def test_malformed_csv_reports_file_and_goes_on(self):
        d = self.root / "out_badcsv"
        write_minimal_no_gt(d)
        with open(d / "timings.csv", "a") as f:
            f.write("80,1.1,fast,0,2.4,1000,2600,0,0\n")
        proc = self.run_script(d)
        self.assertEqual(proc.returncode, 1)
        self.assertNotIn("Traceback", proc.stderr)
        self.assertIn("timings.csv", proc.stderr)
        self.assertTrue((d / "pictures" / "map_topdown.png").is_file())

    def test_usage(self):
        proc = self.run_script()
        self.assertEqual(proc.returncode, 2)
        self.assertIn("Usage", proc.stderr)


if __name__ == "__main__":
    if not SCRIPT.is_file():
        print(f"test_plot_run: {SCRIPT} not found (set TWOCAM_SOURCE_DIR)", file=sys.stderr)
        sys.exit(1)
    unittest.main()
