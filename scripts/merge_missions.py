#!/usr/bin/python3
"""Merging missions (issue 34 part 3; docs/missions.md): for each scene and seed, missions 1-3 are
simulated; mission 1 is run with its known start, missions 2 and 3 with --start-unknown (each in
its own frame), and `hazmap merge` places 2 and 3 in mission 1's map. Per seed: which maps were
placed, the map error over the keyframes (mission 1 alone, the merge, and mission 1 inside the
merge; merge.json), the inter-session loops (accepted, and wrong = more than 0.3 m from the truth,
as scripts/missions.py counts wrong answers), and the changes (changes.json against each
mission's changes_truth.json, scored as in scripts/missions.py).

  scripts/merge_missions.py BUILD/apps/hazmap WORK_DIR [--scenes naraha] [--seeds 1-8] [--reuse]

With --reuse, simulated missions and runs already complete in WORK_DIR are kept (as
scripts/missions.py --reuse; the same WORK_DIR serves both): only the merges are made again.
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from missions import done, error, pose, read_poses, run, score_change_list  # noqa: E402


def wrong_answers(placement, truth):
    """Accepted searches and loops of one placed map more than 0.3 m from the truth."""
    return sum(1 for x in placement["search"] + placement["loops"]
               if x["accepted"] and error(pose(x["pose"]), truth[x["frame"]])[0] > 0.3)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("hazmap")
    ap.add_argument("work")
    ap.add_argument("--scenes", default="naraha")
    ap.add_argument("--seeds", default="1-8")
    ap.add_argument("--threads", default="2")
    ap.add_argument("--temperature", action="store_true")
    ap.add_argument("--reuse", action="store_true")
    a = ap.parse_args()
    keep = lambda path, name: a.reuse and done(path, name)
    lo, hi = (int(x) for x in a.seeds.split("-"))
    work = os.path.abspath(a.work)
    os.makedirs(work, exist_ok=True)
    H, T = a.hazmap, ["--threads", a.threads, "--quiet", "--no-viewer"]
    temp = ["--temperature"] if a.temperature else []
    print("scene seed | placed | map_err m1_alone merged m1_in_merge delta_mm | loops accepted wrong disagreeing | "
          "changes tp fp missed | seconds")
    totals = {"seeds": 0, "all_placed": 0, "within_5mm": 0, "loops": 0, "wrong": 0, "tp": 0, "fp": 0, "missed": 0}
    for scene in a.scenes.split(","):
        for seed in range(lo, hi + 1):
            d = lambda n: os.path.join(work, f"{scene}-s{seed}-{n}")
            for k in (1, 2, 3):
                if not keep(d(f"m{k}"), "poses.txt"):
                    run([H, "simulate", "--scenario", scene, "--seed", str(seed), "--mission", str(k), "--out",
                         d(f"m{k}"), "--overwrite"] + temp)
                if not keep(d(f"r{k}"), "map.json"):
                    run([H, "run", d(f"m{k}"), "--out", d(f"r{k}")] + T + ([] if k == 1 else ["--start-unknown"]))
            run([H, "merge", d("r1"), d("r2"), d("r3"), "--out", d("merged"), "--overwrite"] + T)
            with open(os.path.join(d("merged"), "merge.json")) as f:
                m = json.load(f)
            with open(os.path.join(d("merged"), "changes.json")) as f:
                changes = json.load(f)["changes"]
            err = {e["what"]: e["mean"] for e in m["map_error"]}
            placed = sum(p["placed"] for p in m["maps"])
            wrong = tp = fp = missed = 0
            for k, p in ((2, m["maps"][1]), (3, m["maps"][2])):
                if not p["placed"]:
                    continue
                truth = read_poses(os.path.join(d(f"m{k}"), "poses.txt"))
                wrong += wrong_answers(p, truth)
                t, f_, mi, _ = score_change_list([c for c in changes if c["mission"] == k], d(f"m{k}"), truth,
                                                 a.temperature)
                tp, fp, missed = tp + t, fp + f_, missed + mi
            delta = (err["merged"] - err["first map alone"]) * 1000
            loops = m["pose_graph"]["inter_session_loops"]
            totals["seeds"] += 1
            totals["all_placed"] += placed == 3
            totals["within_5mm"] += delta <= 5.0
            totals["loops"] += loops
            totals["wrong"] += wrong
            totals["tp"] += tp
            totals["fp"] += fp
            totals["missed"] += missed
            print(f"{scene} {seed} | {placed}/3 | {err['first map alone']:.4f} {err['merged']:.4f} "
                  f"{err['map 1 in the merge']:.4f} {delta:+.1f} | {loops} {wrong} "
                  f"{m['pose_graph']['loops_disagreeing_after_solve']} | {tp} {fp} {missed} | {m['seconds']:.1f}",
                  flush=True)
    print(json.dumps(totals))


if __name__ == "__main__":
    main()
