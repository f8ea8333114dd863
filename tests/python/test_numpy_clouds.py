"""Every entry point that takes a cloud takes a numpy array too (docs/python.md): (N,3) x y z or
(N,4) x y z class, float32 or float64, with the same answer as the LabeledCloud of those values;
a wrong shape, dtype, a NaN or a bad class is a one-line hazmap.Error naming the argument."""
import numpy as np
import pytest

import hazmap


@pytest.fixture(scope="module")
def pair(data):
    d = data / "scan-pair"
    target = hazmap.voxel_downsample(hazmap.read_cloud(d / "251370668.pcd"), 0.25)
    source = hazmap.voxel_downsample(hazmap.read_cloud(d / "251371071.pcd"), 0.25)
    return source, target


def labelled(cloud):
    """(N,4) float64: x y z class, with a few points relabelled so the class column matters."""
    classes = np.array(cloud.classes, dtype=np.float64)
    classes[::97] = 1.0
    return np.column_stack([np.asarray(cloud.points, dtype=np.float64), classes])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_register_takes_xyz_arrays(pair, dtype):
    source, target = pair
    want = hazmap.register(source, target)
    got = hazmap.register(np.array(source.points, dtype=dtype), np.array(target.points, dtype=dtype))
    assert want.converged, want.reason
    # The same float32 points as the LabeledClouds (the clouds were unlabelled): the same answer.
    np.testing.assert_array_equal(got.transform, want.transform)
    assert got.iterations == want.iterations


def test_register_takes_a_class_column(pair):
    source, target = pair
    src, tgt = labelled(source), labelled(target)
    want = hazmap.register(hazmap.LabeledCloud(src[:, :3], src[:, 3].astype(np.uint16)),
                           hazmap.LabeledCloud(tgt[:, :3], tgt[:, 3].astype(np.uint16)))
    got = hazmap.register(src, tgt)
    np.testing.assert_array_equal(got.transform, want.transform)
    assert got.labels_used == want.labels_used


def test_every_cloud_entry_point_takes_an_array(pair, tmp_path):
    source, _ = pair
    xyz = np.array(source.points, dtype=np.float64)
    down = hazmap.voxel_downsample(xyz, 1.0)
    assert 0 < len(down) < len(xyz)
    assert len(down) == len(hazmap.voxel_downsample(source, 1.0))
    hazmap.write_cloud(tmp_path / "a.pcd", labelled(source))
    back = hazmap.read_cloud(tmp_path / "a.pcd")
    assert len(back) == len(xyz) and back.classes[0] == 1
    scan = hazmap.Scan(xyz, stamp=2.0)
    assert len(scan.cloud) == len(xyz)
    odo = hazmap.Odometry()
    assert odo.add_frame(xyz)["status"] == "first"
    assert odo.add_frame(xyz.astype(np.float32))["status"] in ("tracked", "degenerate")


def test_run_takes_a_stream_of_arrays(sim_sequence):
    scans = [s for _, s in zip(range(5), hazmap.open(sim_sequence))]
    clouds = [s.cloud for s in scans]
    arrays = [np.column_stack([np.asarray(c.points), np.asarray(c.classes)]).astype(np.float32) for c in clouds]
    want = hazmap.run(clouds, "icp")
    got = hazmap.run(arrays, "icp")
    np.testing.assert_array_equal(got.poses, want.poses)


@pytest.mark.parametrize("bad, says", [
    (np.zeros((5, 2)), "shape (5, 2)"),
    (np.zeros(6), "shape (6,)"),
    (np.zeros((2, 5, 3)), "shape (2, 5, 3)"),
    (np.zeros((5, 3), dtype=np.int64), "float array"),
    (np.array([[0, 0, 0], [1, np.nan, 0]]), "point 1 has a non-finite coordinate"),
    (np.array([[0, 0, 0, 1.5]]), "point 0 has class 1.5"),
    (np.array([[0, 0, 0, -1.0]]), "point 0 has class -1"),
    ([[0.0, 0.0, 0.0]], "got list"),
    ("cloud.pcd", "got str"),
])
def test_a_bad_cloud_is_one_line_naming_the_argument(pair, bad, says):
    _, target = pair
    with pytest.raises(hazmap.Error) as e:
        hazmap.register(bad, target)
    message = str(e.value)
    assert message.startswith("source:") and says in message, message
    assert "\n" not in message
    with pytest.raises(hazmap.Error, match="^target:"):
        hazmap.register(target, bad)
    with pytest.raises(hazmap.Error, match="^cloud:"):
        hazmap.Odometry().add_frame(bad)
