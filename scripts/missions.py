#!/usr/bin/python3
"""Missions against mission 1 (issue 34; docs/missions.md): for each scene and seed, mission 1 is
simulated and run; missions 2 and 3 are run twice, with a known start (their poses.txt's first
pose, in mission 1's frame) and with --prior (start unknown, localised in mission 1's map).
Prints one row per run and the totals. With --temperature the scans carry the temperature
channel (a hotter source is then observable). Changes (changes.json against changes_truth.json):
a detection is right when its kind matches (moved, removed = gone, new, value_changed) and its
position (after; before for gone) lies within 1.5 m of the truth's; a truth change counts for
recall when the mission's true path passes within 6 m of it (value_changed only with the
temperature channel); the moved crate must give no detection.

  scripts/missions.py BUILD/apps/hazmap WORK_DIR [--scenes naraha,tanks] [--seeds 1-4] [--missions 2,3] [--reuse]

With --reuse, a simulated mission or a run without --prior whose folder is already complete
(run.json / poses.txt there) is kept: only the runs with --prior are made again.
"""
import argparse
import json
import math
import os
import subprocess
import sys


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.exit("failed: " + " ".join(cmd) + "\n" + r.stdout)
    return r.stdout


def done(path, name):
    return os.path.exists(os.path.join(path, name))


def pose(rows):
    m = [[rows[4 * r + c] for c in range(4)] for r in range(3)]
    return m


def read_poses(path):
    with open(path) as f:
        return [pose([float(x) for x in line.split()]) for line in f if line.strip()]


def error(a, b):
    """Translation (m) and rotation (deg) of a^-1 b for 3x4 row-major poses."""
    Ra = [row[:3] for row in a]
    Rb = [row[:3] for row in b]
    dt = [b[i][3] - a[i][3] for i in range(3)]
    t = math.sqrt(sum(x * x for x in dt))
    R = [[sum(Ra[k][i] * Rb[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    c = max(-1.0, min(1.0, (R[0][0] + R[1][1] + R[2][2] - 1) / 2))
    return t, math.degrees(math.acos(c))


KIND = {"moved": "moved", "removed": "gone", "new": "new", "value_changed": "value_changed"}


def near(a, b, d):
    return a is not None and b is not None and math.dist(a, b) <= d


def score_changes(run_dir, seq_dir, truth_poses, temperature):
    """(true positives, false positives, relevant truths missed, detections as text)."""
    with open(os.path.join(run_dir, "changes.json")) as f:
        return score_change_list(json.load(f)["changes"], seq_dir, truth_poses, temperature)


def score_change_list(changes, seq_dir, truth_poses, temperature):
    """score_changes for changes.json's entries `changes`."""
    detected = [c for c in changes
                if not (len(c["kinds"]) == 1 and c["kinds"][0] in ("unchanged", "not_re_observed", "part_of"))]
    with open(os.path.join(seq_dir, "changes_truth.json")) as f:
        truth = [t for t in json.load(f)["changes"] if t["kind"] in KIND]
    path = [(p[0][3], p[1][3], p[2][3]) for p in truth_poses]
    def relevant(t):
        if t["kind"] == "value_changed" and not temperature:
            return False
        where = t["before"] if t["kind"] == "removed" else t["after"]
        return any(math.dist(where[:2], q[:2]) <= 6.0 for q in path)
    used, tp = set(), 0
    for c in detected:
        for i, t in enumerate(truth):
            key = "before" if t["kind"] == "removed" else "after"
            if i not in used and KIND[t["kind"]] in c["kinds"] and near(c[key], t[key], 1.5):
                used.add(i)
                tp += 1
                break
    missed = sum(1 for i, t in enumerate(truth) if i not in used and relevant(t))
    text = ";".join("+".join(c["kinds"]) for c in detected)
    return tp, len(detected) - tp, missed, text


def map_error(run_dir):
    with open(os.path.join(run_dir, "run.json")) as f:
        return json.load(f)["map_error"]["point"]["mean"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("hazmap")
    ap.add_argument("work")
    ap.add_argument("--scenes", default="naraha,tanks")
    ap.add_argument("--seeds", default="1-4")
    ap.add_argument("--missions", default="2,3")
    ap.add_argument("--threads", default="2")
    ap.add_argument("--temperature", action="store_true")
    ap.add_argument("--reuse", action="store_true")
    a = ap.parse_args()
    lo, hi = (int(x) for x in a.seeds.split("-"))
    os.makedirs(a.work, exist_ok=True)
    keep = lambda path, name: a.reuse and done(path, name)
    H, T = a.hazmap, ["--threads", a.threads, "--quiet", "--no-viewer"]
    print("scene seed mission | state frame | loc_err_m loc_err_deg | wrong_answers | s_per_attempt | "
          "map_err_prior map_err_known ratio | map_err_m1 | changes tp fp missed")
    totals = {"runs": 0, "localised": 0, "within": 0, "wrong": 0, "tp": 0, "fp": 0, "missed": 0}
    temp = ["--temperature"] if a.temperature else []
    for scene in a.scenes.split(","):
        for seed in range(lo, hi + 1):
            d = lambda n: os.path.join(a.work, f"{scene}-s{seed}-{n}")
            if not keep(d("m1"), "poses.txt"):
                run([H, "simulate", "--scenario", scene, "--seed", str(seed), "--mission", "1", "--out", d("m1"), "--overwrite"] + temp)
            if not keep(d("r1"), "map.json"):
                run([H, "run", d("m1"), "--out", d("r1")] + T)
            for k in [int(x) for x in a.missions.split(",")]:
                if not keep(d(f"m{k}"), "changes_truth.json"):
                    run([H, "simulate", "--scenario", scene, "--seed", str(seed), "--mission", str(k), "--out", d(f"m{k}"), "--overwrite"] + temp)
                if not keep(d(f"r{k}known"), "map.json"):
                    run([H, "run", d(f"m{k}"), "--out", d(f"r{k}known")] + T)
                run([H, "run", d(f"m{k}"), "--prior", d("r1"), "--out", d(f"r{k}prior")] + T)
                with open(os.path.join(d(f"r{k}prior"), "run.json")) as f:
                    p = json.load(f)["prior"]
                truth = read_poses(os.path.join(d(f"m{k}"), "poses.txt"))
                wrong = sum(1 for x in p["search"] + p["loops_to_prior"]
                            if x["accepted"] and error(pose(x["pose"]), truth[x["frame"]])[0] > 0.3)
                totals["runs"] += 1
                totals["wrong"] += wrong
                row = f"{scene} {seed} {k} | {p['state']} "
                if p["state"] == "localised":
                    f_ = p["localised_at_frame"]
                    et, er = error(pose(p["localised_pose"]), truth[f_])
                    totals["localised"] += 1
                    totals["within"] += et <= 0.10 and er <= 1.0
                    row += f"{f_} | {et:.3f} {er:.2f} "
                else:
                    row += "- | - - "
                mp, mk = map_error(d(f"r{k}prior")), map_error(d(f"r{k}known"))
                row += f"| {wrong} | {p['seconds_per_attempt']:.2f} | {mp:.4f} {mk:.4f} {mp / mk:.2f} | {map_error(d('r1')):.4f}"
                if p["state"] == "localised":
                    tp, fp, missed, text = score_changes(d(f"r{k}prior"), d(f"m{k}"), truth, a.temperature)
                    totals["tp"] += tp
                    totals["fp"] += fp
                    totals["missed"] += missed
                    row += f" | {tp} {fp} {missed} {text}"
                print(row, flush=True)
    print(json.dumps(totals))


if __name__ == "__main__":
    main()
