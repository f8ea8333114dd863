#!/usr/bin/env python3
"""hazmap.run from Python against `hazmap run` (the CLI process) on the same simulated sequence,
same method, same outputs written; interleaved rounds, medians (the machine is shared).

  PYTHONPATH=build/python python3 bench/python_run_vs_cli.py [--cli build/apps/hazmap] [--frames 40]
"""
import argparse
import pathlib
import statistics
import subprocess
import tempfile
import time

import hazmap

ap = argparse.ArgumentParser()
ap.add_argument("--cli", default=str(pathlib.Path(__file__).resolve().parents[1] / "build" / "apps" / "hazmap"))
ap.add_argument("--frames", type=int, default=40)
ap.add_argument("--rounds", type=int, default=3)
ap.add_argument("--method", default="property-icp+pgo")
args = ap.parse_args()
with tempfile.TemporaryDirectory() as tmp:
    seq = pathlib.Path(tmp) / "seq"
    hazmap.simulate(str(seq), {"frames": args.frames, "seed": 1})
    py, cli = [], []
    for i in range(args.rounds):
        t = time.perf_counter()
        r = hazmap.run(seq, args.method, out=pathlib.Path(tmp) / f"py{i}")
        py.append(time.perf_counter() - t)
        t = time.perf_counter()
        subprocess.run([args.cli, "run", str(seq), "--method", args.method, "--out", str(pathlib.Path(tmp) / f"cli{i}"),
                        "--quiet"], check=True)
        cli.append(time.perf_counter() - t)
    p, c = statistics.median(py), statistics.median(cli)
    print(f"{args.method}, {args.frames} frames, median of {args.rounds}: CLI {c:.2f} s, Python {p:.2f} s, "
          f"ratio {p / c:.3f} (map error {r.table2_error:.4f} m)")
