#!/usr/bin/env python3
"""Python overhead of hazmap.register on the shared scan pair, against the same C++ call timed in
the same process run (bench_registration's scan pair set-up: 0.25 m voxels, property ICP).

  PYTHONPATH=build/python python3 bench/python_overhead.py [--repeats 30]

The C++ side is hazmap._hazmap._time_register: the same registerClouds call on the same clouds
and config, timed inside C++ around that call only. The ratio Python/C++ is the whole binding
overhead (config through the field table, argument and result conversion, GIL release).
Interleaved rounds and medians, because the machine is shared.
"""
import argparse
import pathlib
import statistics
import subprocess
import time

import hazmap

ap = argparse.ArgumentParser()
ap.add_argument("--data", default=str(pathlib.Path(__file__).resolve().parents[2] / "shared" / "data"))
ap.add_argument("--repeats", type=int, default=30)
args = ap.parse_args()
d = pathlib.Path(args.data) / "scan-pair"
if not d.is_dir():
    d = pathlib.Path("/work/shared/data/scan-pair")
target = hazmap.voxel_downsample(hazmap.read_cloud(d / "251370668.pcd"), 0.25)
source = hazmap.voxel_downsample(hazmap.read_cloud(d / "251371071.pcd"), 0.25)
config = {"max_iterations": 100, "threads": 1}

hazmap.register(source, target, config=config)  # warm-up
py, cpp = [], []
for _ in range(args.repeats):
    t = time.perf_counter()
    r = hazmap.register(source, target, config=config)
    py.append(time.perf_counter() - t)
    cpp.append(hazmap._hazmap._time_register(source, target, config))
py_ms, cpp_ms = 1e3 * statistics.median(py), 1e3 * statistics.median(cpp)
print(f"scan pair ({len(source)} -> {len(target)} points, {r.iterations} iterations, 1 thread), "
      f"median of {args.repeats}:")
print(f"  C++ registerClouds      {cpp_ms:8.3f} ms")
print(f"  Python hazmap.register  {py_ms:8.3f} ms")
print(f"  overhead                {100 * (py_ms / cpp_ms - 1):+8.2f} %  (ratio {py_ms / cpp_ms:.4f})")
