"""hazmap.run: the whole SLAM run (as `hazmap run`) over a recording or a Python stream."""
import os
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import _hazmap

METHODS = ("odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo")


@dataclass
class RunResult:
    method: str
    source: str
    frames: int
    poses: np.ndarray          # (N,4,4) final estimate, T_world_sensor
    stamps: list
    tracked: np.ndarray        # before pose-graph optimisation
    odometry_only: np.ndarray  # wheel odometry from the same start pose
    loops: int
    keyframes: int
    loop_candidates: int
    frames_per_second: float
    timings: dict              # tracking_s, loop_s, graph_s, total_s, output_s
    map_error: Optional[dict]  # as run.json's: point.mean is Table 2's number; None without truth
    trajectory: Optional[dict] # ATE/RPE/KITTI as `hazmap eval --json`; None without truth
    hazards: int
    map_cells: int
    extra: dict = field(default_factory=dict)

    @property
    def table2_error(self):
        """Mean map error (m) against the map built from the true poses (the paper's Table 2)."""
        return None if self.map_error is None else self.map_error["point"]["mean"]


def run(sequence, method="property-icp+pgo", out=None, config=None, classes=None, threads=0):
    """Runs SLAM over `sequence` and returns a RunResult.

    sequence: a sequence folder, a bag (.bag, .mcap, rosbag2 folder) or a capture (.pcap) path,
      or any iterable of hazmap.Scan (cloud, stamp, odometry, ground_truth), hazmap.LabeledCloud or
      (N,3)/(N,4) float arrays (x y z [class])
      (fed from Python, e.g. a driver; kept in memory for the map's second pass).
    out: folder for everything `hazmap run --out` writes; None = a temporary folder, no PNGs.
    config: dict (or hazmap.Config('run')) with the YAML's sections over `method`'s defaults.
    """
    if method not in METHODS:
        raise _hazmap.Error(f"method: expected one of {', '.join(METHODS)}, got '{method}'")
    if isinstance(sequence, os.PathLike):
        sequence = os.fspath(sequence)
    if out is not None:
        out = os.fspath(out)
    d = _hazmap._run(sequence, method, out, config, classes, threads)
    return RunResult(**d)
