"""Shared fixtures: the real data (../shared/data), the CLI to compare against, a small
simulated sequence. Run with PYTHONPATH=build/python (CTest sets it: `ctest -R python`)."""
import json
import os
import pathlib
import subprocess

import pytest

import hazmap

REPO = pathlib.Path(__file__).resolve().parents[2]

def _find_data():
    """HAZMAP_SHARED_DATA_DIR (CTest sets the configured folder: a missing one fails the tests that
    need it, naming it), else the first shared/data above the checkout (../shared/data)."""
    if os.environ.get("HAZMAP_SHARED_DATA_DIR"):
        return pathlib.Path(os.environ["HAZMAP_SHARED_DATA_DIR"])
    for c in [p / "shared" / "data" for p in REPO.parents]:
        if c.is_dir():
            return c.resolve()
    return REPO.parent / "shared" / "data"


DATA = _find_data()
CLI = os.environ.get("HAZMAP_CLI", str(REPO / "build" / "apps" / "hazmap"))


@pytest.fixture(scope="session")
def data():
    if not DATA.is_dir():
        pytest.fail(f"shared data not found at {DATA} (set HAZMAP_SHARED_DATA_DIR)")
    return DATA


def run_cli(*args):
    """Runs the hazmap CLI; returns (exit code, stdout+stderr)."""
    p = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def cli_json(*args):
    code, out = run_cli(*args)
    assert code == 0, out
    return json.loads(out[out.index("{"):])


@pytest.fixture(scope="session")
def sim_sequence(tmp_path_factory):
    """15 frames of the paper's facility (seed 3): ground truth, odometry, labels."""
    out = tmp_path_factory.mktemp("sim") / "seq"
    hazmap.simulate(str(out), {"frames": 15, "seed": 3})
    return out
