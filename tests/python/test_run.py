"""hazmap.run: the same numbers as `hazmap run`, from a folder, a bag and a Python-fed stream."""
import json

import numpy as np
import pytest

import hazmap

from conftest import run_cli


@pytest.mark.parametrize("method", ["odometry", "property-icp+pgo"])
def test_run_equals_cli(sim_sequence, tmp_path, method):
    r = hazmap.run(sim_sequence, method, out=tmp_path / "py")
    code, out = run_cli("run", sim_sequence, "--method", method, "--out", tmp_path / "cli", "--quiet")
    assert code == 0, out
    cli = json.loads((tmp_path / "cli" / "run.json").read_text())
    assert r.frames == cli["frames"] == 15
    assert r.table2_error == pytest.approx(cli["map_error"]["point"]["mean"], rel=0, abs=0)
    py_traj = np.loadtxt(tmp_path / "py" / "trajectory.kitti")
    cli_traj = np.loadtxt(tmp_path / "cli" / "trajectory.kitti")
    np.testing.assert_array_equal(py_traj, cli_traj)
    np.testing.assert_allclose(r.poses[:, :3, :].reshape(15, 12), cli_traj, atol=1e-8)
    assert set(r.timings) >= {"tracking_s", "loop_s", "graph_s", "total_s"}


def test_property_icp_beats_odometry(sim_sequence):
    odo = hazmap.run(sim_sequence, "odometry")
    picp = hazmap.run(sim_sequence, "property-icp", config={"odometry": {"voxel_size": 0.5}})
    assert picp.table2_error < 0.5 * odo.table2_error
    assert picp.trajectory["ape"]["rmse"] < odo.trajectory["ape"]["rmse"]


def test_python_stream_equals_folder(sim_sequence):
    folder = hazmap.run(sim_sequence, "property-icp+pgo")
    fed = hazmap.run((s for s in hazmap.open(sim_sequence)), "property-icp+pgo")
    assert fed.source == "Python stream"
    np.testing.assert_array_equal(fed.poses, folder.poses)
    assert fed.table2_error == folder.table2_error


def test_stream_of_bare_clouds(data):
    d = data / "kitti-semantic-sample" / "velodyne"
    clouds = [hazmap.read_cloud(p, classes="semantic-kitti") for p in sorted(d.glob("*.bin"))]
    r = hazmap.run(iter(clouds), "icp", classes="semantic-kitti")
    assert r.frames == len(clouds) and r.map_error is None  # no ground truth, no map error
    assert np.linalg.norm(r.poses[-1, :3, 3]) > 1.0


def test_run_bag(data):
    bag = data / "sensors" / "ouster-os0-128-ros1" / "512x10_raw.bag"
    r = hazmap.run(bag, "icp")
    assert r.frames >= 1 and "bag" in r.source.lower()


def test_run_errors(sim_sequence, tmp_path):
    with pytest.raises(hazmap.Error, match="method"):
        hazmap.run(sim_sequence, "magic")
    with pytest.raises(hazmap.Error, match="does-not-exist"):
        hazmap.run(tmp_path / "does-not-exist", "icp")
    with pytest.raises(hazmap.Error, match="keyframe_distanse"):
        hazmap.run(sim_sequence, "icp", config={"slam": {"keyframe_distanse": 1}})
    with pytest.raises(hazmap.Error, match="item 1"):
        hazmap.run(iter([hazmap.LabeledCloud(np.zeros((3, 3))), "not a scan"]), "icp")
    with pytest.raises(ZeroDivisionError):  # a Python error inside the stream comes back as itself
        hazmap.run((1 / 0 for _ in range(3)), "icp")


def test_simulate(tmp_path):
    s = hazmap.simulate(str(tmp_path / "a"), {"frames": 5, "seed": 9})
    assert s["frames"] == 5 and s["points"] > 10000
    with pytest.raises(hazmap.Error, match="seeed"):
        hazmap.simulate(str(tmp_path / "b"), {"seeed": 1})
    b = hazmap.simulate(str(tmp_path / "c"), {"frames": 5, "seed": 9})
    assert (tmp_path / "a" / "velodyne" / "000004.bin").read_bytes() == (tmp_path / "c" / "velodyne" / "000004.bin").read_bytes()
    assert b == s | {"total_seconds": b["total_seconds"]}
