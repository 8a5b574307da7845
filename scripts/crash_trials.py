#!/usr/bin/env python3
"""Crash trials of `twocam run --map` (issue 25, docs/store.md "Crash trials"): a run killed with
SIGKILL at seeded random moments must leave a store that opens, passes SQLite's integrity check
and holds every frame the run reported committed; a second run on it must continue.

The log is a short office log (simulated, or --log). Two uninterrupted reference runs come first:
one creating a map (session 1) and one extending a copy of it (session 2, relocalised first);
their wall times set the range of the kill moments and their keyframes are the frames a killed
run may have committed. Trial i then kills, at a uniform random fraction of the reference time
(a run that ends first is drawn again), a run that creates a new map (even i) or extends a copy
of the reference map (odd i). The run
reports its commits with --map-commit-log (a line per committed transaction, written after the
commit). After the kill:
  opened     `twocam map info MAP` exits 0 (a run killed before the map existed leaves none:
             counted apart, and only acceptable when it reported no commit)
  integrity  `twocam map check MAP` (PRAGMA integrity_check) exits 0
  committed  the killed session's keyframes hold every reference frame up to the last reported
             frame, and none beyond the next transaction; an extended map's session 1 is intact
  continued  `twocam run LOG --map MAP --frames K` exits 0, adds a session with keyframes, and the
             map passes the integrity check again
Prints one line per trial and a summary; exit status 1 when any trial fails.

Usage: scripts/crash_trials.py [--seed S] [--trials N] [--log LOG] [--out DIR]
"""

import argparse
import os
import random
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seed", type=int, default=1, help="seed of the kill moments (default 1)")
    p.add_argument("--trials", type=int, default=20, help="number of kills (default 20)")
    p.add_argument("--log", help="log to run (default: simulate worlds/office.yaml)")
    p.add_argument("--frames", type=int, default=120, help="frames of the simulated log (120)")
    p.add_argument("--continue-frames", type=int, default=40,
                   help="frames of the second run on a killed map (40)")
    p.add_argument("--frames-per-commit", type=int, default=10,
                   help="the recorder's frames per transaction (MapRecorderOptions, 10)")
    p.add_argument("--out", default="/tmp/twocam_crash_trials", help="work folder (replaced)")
    p.add_argument("--twocam", default=os.path.join(ROOT, "build/release/tools/twocam"))
    return p.parse_args()


def run(cmd, **kw):
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)


def query(db, sql, params=()):
    """Rows of a read-only query (the file is opened read only, never written)."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return con.execute(sql, params).fetchall()
    finally:
        con.close()


def keyframes(db, session):
    return [r[0] for r in query(db, "SELECT frame FROM keyframes WHERE session=? ORDER BY frame",
                                (session,))]


def sessions(db):
    return [r[0] for r in query(db, "SELECT id FROM sessions ORDER BY id")]


def copy_map(src, dst):
    for suffix in ("", "-wal"):
        if os.path.exists(src + suffix):
            shutil.copyfile(src + suffix, dst + suffix)


def last_commit(path):
    """(session, last frame) of the last line of a commit log, or None."""
    if not os.path.exists(path):
        return None
    last = None
    with open(path) as f:
        for line in f:
            m = re.fullmatch(r"session (\d+) frame (-?\d+) keyframes (\d+)\n", line)
            if m:  # a line cut by the kill does not match and is not counted
                last = (int(m.group(1)), int(m.group(2)))
    return last


def main():
    a = parse_args()
    tw = a.twocam
    shutil.rmtree(a.out, ignore_errors=True)
    os.makedirs(a.out)
    log = a.log
    if log is None:
        log = os.path.join(a.out, "office.rawlog")
        r = run([tw, "simulate", os.path.join(ROOT, "worlds/office.yaml"), "-o", log,
                 "--frames", str(a.frames), "-q"])
        if r.returncode != 0:
            sys.exit("simulate failed:\n" + r.stdout)

    def run_cmd(out, db, extra=()):
        return [tw, "run", log, "-o", out, "-q", "--no-pictures", "--map", db, *extra]

    # References: a new map and an extension of it, uninterrupted.
    ref_db = os.path.join(a.out, "ref.db")
    t0 = time.monotonic()
    r = run(run_cmd(os.path.join(a.out, "ref"), ref_db))
    t_new = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit("reference run failed:\n" + r.stdout)
    ref_frames = {1: keyframes(ref_db, 1)}
    ref_landmarks = query(ref_db, "SELECT COUNT(*) FROM landmarks")[0][0]
    ext_db = os.path.join(a.out, "ref_extended.db")
    copy_map(ref_db, ext_db)
    t0 = time.monotonic()
    r = run(run_cmd(os.path.join(a.out, "ref_extended"), ext_db))
    t_extend = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit("reference extension failed:\n" + r.stdout)
    ref_frames[2] = keyframes(ext_db, 2)
    print(f"log {log}: reference run {t_new:.2f} s ({len(ref_frames[1])} keyframes, "
          f"{ref_landmarks} landmarks); extending it {t_extend:.2f} s ({len(ref_frames[2])} "
          f"keyframes from frame {ref_frames[2][0] if ref_frames[2] else '-'})")

    rng = random.Random(a.seed)
    counts = dict(trials=0, killed=0, redrawn=0, no_store=0, opened=0, integrity=0, committed=0,
                  continued=0, failed=0)
    reported_total = 0
    for i in range(a.trials):
        extend = i % 2 == 1
        d = os.path.join(a.out, f"t{i:02d}")
        db = os.path.join(d, "map.db")
        commits = os.path.join(d, "commits.txt")
        # A run that ends before its kill moment (the machine's load varies) is no trial: the
        # next draw is taken, up to 5 times.
        for attempt in range(5):
            fraction = rng.random()
            delay = fraction * (t_extend if extend else t_new)
            shutil.rmtree(d, ignore_errors=True)
            os.makedirs(d)
            if extend:
                copy_map(ref_db, db)
            p = subprocess.Popen(
                run_cmd(os.path.join(d, "out"), db, ["--map-commit-log", commits]),
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            try:
                p.wait(timeout=delay)
                killed = False
            except subprocess.TimeoutExpired:
                os.kill(p.pid, signal.SIGKILL)
                p.wait()
                killed = True
                break
        counts["trials"] += 1
        counts["killed"] += killed
        counts["redrawn"] += attempt
        reported = last_commit(commits)
        problems = []
        notes = []
        ok_open = ok_integrity = ok_committed = False
        had_map = os.path.exists(db)
        if not had_map:
            counts["no_store"] += 1
            notes.append("no map yet (killed while creating it)")
            if reported is not None:
                problems.append(f"commits reported ({reported}) but no map")
            ok_committed = reported is None
        else:
            info = run([tw, "map", "info", db])
            ok_open = info.returncode == 0
            if not ok_open:
                problems.append("map info: " + info.stdout.strip())
            check = run([tw, "map", "check", db])
            ok_integrity = check.returncode == 0
            if not ok_integrity:
                problems.append("map check: " + check.stdout.strip())
            if ok_open and ok_integrity:
                ok_committed = True
                if extend:
                    if keyframes(db, 1) != ref_frames[1]:
                        ok_committed = False
                        problems.append("session 1's keyframes changed")
                    n1 = query(db, "SELECT COUNT(*) FROM landmarks WHERE session=1")[0][0]
                    if n1 != ref_landmarks:
                        ok_committed = False
                        problems.append(f"session 1 holds {n1} landmarks, not {ref_landmarks}")
                if reported is not None:
                    s, last = reported
                    held = set(keyframes(db, s))
                    expected = [f for f in ref_frames.get(s, []) if f <= last]
                    missing = [f for f in expected if f not in held]
                    beyond = [f for f in held if f > last]
                    if missing:
                        ok_committed = False
                        problems.append(f"session {s}: {len(missing)} reported frames missing "
                                        f"(first {missing[0]})")
                    if len(beyond) > a.frames_per_commit:
                        ok_committed = False
                        problems.append(f"session {s}: {len(beyond)} frames beyond the last "
                                        f"reported one")
                    reported_total += len(expected)
                    notes.append(f"reported session {s} to frame {last}, holds "
                                 f"{len(held)} keyframes ({len(beyond)} unreported)")
                else:
                    ss = sessions(db)
                    notes.append(f"nothing reported; sessions {ss}")
                    # An extension killed before any commit leaves the map as it was.
                    if extend and ss != [1]:
                        held = keyframes(db, ss[-1]) if ss[-1] != 1 else []
                        notes.append(f"session {ss[-1]} holds {len(held)} keyframes")
        counts["opened"] += ok_open
        counts["integrity"] += ok_integrity
        counts["committed"] += ok_committed and had_map
        # The second run continues on what the kill left.
        before = sessions(db) if os.path.exists(db) else []
        second = run(run_cmd(os.path.join(d, "out2"), db,
                             ["--frames", str(a.continue_frames)]))
        ok_continue = second.returncode == 0
        how = ""
        if ok_continue:
            after = sessions(db)
            new = [s for s in after if s not in before]
            if len(new) != 1 or not keyframes(db, new[0]):
                ok_continue = False
                problems.append(f"second run: sessions {before} -> {after}")
            elif run([tw, "map", "check", db]).returncode != 0:
                ok_continue = False
                problems.append("second run: integrity check failed")
            m = re.search(r"^map: .*$", second.stdout, re.M)
            how = m.group(0) if m else ""
            if "session" in how and "added" in how:
                m2 = re.search(r"relocalisation: frame (-?\d+)", second.stdout)
                how = (f"extended (relocalised at frame {m2.group(1) if m2 else '?'}), "
                       f"session {new[0] if new else '?'}")
            else:
                how = f"recorded as a new map's session {new[0] if new else '?'}"
        else:
            problems.append(f"second run exit {second.returncode}: "
                            + second.stdout.strip().splitlines()[-1:][0]
                            if second.stdout.strip() else "")
        counts["continued"] += ok_continue
        failed = not ((ok_open and ok_integrity or not had_map) and ok_committed and ok_continue)
        counts["failed"] += failed
        print(f"trial {i:2d} {'extend' if extend else 'new   '} kill at {delay:5.2f} s "
              f"({fraction:.2f}){'' if killed else ' (finished first)'}: "
              f"{'; '.join(notes)}; then {how or 'not continued'}"
              f"{' FAIL: ' + '; '.join(problems) if failed else ''}")
    c = counts
    maps = c["trials"] - c["no_store"]
    print(f"summary (seed {a.seed}): trials {c['trials']}, killed {c['killed']} "
          f"({c['redrawn']} runs ended before their kill moment and were drawn again), "
          f"left no map (killed while creating, nothing reported) {c['no_store']}; of the "
          f"{maps} maps: opened {c['opened']}/{maps}, integrity ok {c['integrity']}/{maps}, "
          f"held every reported frame {c['committed']}/{maps} ({reported_total} reported frames "
          f"checked); continued {c['continued']}/{c['trials']}; failed {c['failed']}")
    return 1 if c["failed"] or c["killed"] < c["trials"] else 0


if __name__ == "__main__":
    sys.exit(main())
