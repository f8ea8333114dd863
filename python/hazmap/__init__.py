"""hazmap from Python: property-aware LiDAR SLAM (C++ core in hazmap._hazmap).

Clouds are numpy views: ``cloud.points`` is (N,3) float32, ``cloud.classes`` uint16, and the
optional ``intensity`` (float32), ``timestamps`` (float64 s) and ``property`` (float32) channels
are None when absent. Poses are 4x4 float64 arrays (T_world_sensor; registration returns
target <- source). Configs are dicts with the YAML's keys (docs/configuration.md); see
:mod:`hazmap.config` for their defaults. Errors raise :class:`hazmap.Error` (a RuntimeError) with
the CLI's one-line message. Every long C++ call releases the GIL. ``hazmap.open`` (scan streams) is left out of
``__all__`` so that ``from hazmap import *`` does not hide the builtin open.
"""
from ._hazmap import (  # noqa: F401
    Error,
    LabeledCloud,
    Odometry,
    PoseGraph,
    RegistrationResult,
    Scan,
    ScanSource,
    evaluate,
    open,
    read_cloud,
    register,
    simulate,
    voxel_downsample,
    write_cloud,
)
from .config import Config, defaults, fields  # noqa: F401
from .run import METHODS, RunResult, run  # noqa: F401

__all__ = [
    "Config", "Error", "LabeledCloud", "METHODS", "Odometry", "PoseGraph", "RegistrationResult",
    "RunResult", "Scan", "ScanSource", "defaults", "evaluate", "fields", "read_cloud",
    "register", "run", "simulate", "voxel_downsample", "write_cloud",
]
