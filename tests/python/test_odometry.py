"""Odometry.add_frame on the KITTI semantic sample and on a simulated sequence with wheel odometry."""
import numpy as np
import pytest

import hazmap


def kitti_scans(data):
    d = data / "kitti-semantic-sample" / "velodyne"
    return [hazmap.read_cloud(p, classes="semantic-kitti") for p in sorted(d.glob("*.bin"))]


def test_kitti_sample_moves_forward(data):
    scans = kitti_scans(data)
    odo = hazmap.Odometry(classes="semantic-kitti")
    frames = [odo.add_frame(s) for s in scans]
    assert frames[0]["status"] == "first"
    assert all(f["status"] in ("tracked", "degenerate") for f in frames[1:]), [f["reason"] for f in frames]
    poses = odo.poses
    assert poses.shape == (len(scans), 4, 4)
    steps = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    # KITTI 00 drives ~0.5-1 m per frame at the start; the car does not jump.
    assert np.all(steps > 0.2) and np.all(steps < 2.0), steps
    # Frame 1's increment equals a direct registration of the same preprocessed scans (same code).
    np.testing.assert_allclose(frames[1]["pose"], poses[1])


def test_wheel_increment_guides_tracking(sim_sequence):
    source = hazmap.open(sim_sequence)
    odo = hazmap.Odometry()
    prev = None
    truth = []
    for scan in source:
        inc = None if prev is None else np.linalg.inv(prev.odometry) @ scan.odometry
        f = odo.add_frame(scan.cloud, wheel_increment=inc, stamp=scan.stamp)
        if inc is not None:
            assert f["wheel_guess"]
        prev = scan
        truth.append(scan.ground_truth)
    truth = np.array(truth)
    drift = np.linalg.norm(odo.poses[-1, :3, 3] - truth[-1, :3, 3])
    assert drift < 0.1  # tracking beats the simulated encoders (0.2 m off at the end)


def test_odometry_errors():
    with pytest.raises(hazmap.Error, match="voxel_size"):
        hazmap.Odometry(config={"voxel_size": -1})
    odo = hazmap.Odometry()
    with pytest.raises(hazmap.Error):
        odo.add_frame(hazmap.LabeledCloud(np.zeros((10, 3), np.float32)), wheel_increment=np.full((4, 4), np.inf))
