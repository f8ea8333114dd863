"""LabeledCloud <-> numpy and the cloud readers/writers, on the shared scans."""
import numpy as np
import pytest

import hazmap


def test_pcd_reads_as_numpy_views(data):
    cloud = hazmap.read_cloud(data / "scan-pair" / "251370668.pcd")
    assert len(cloud) == 69088  # the data README's count
    pts = cloud.points
    assert pts.shape == (69088, 3) and pts.dtype == np.float32
    assert cloud.classes.dtype == np.uint16 and cloud.classes.shape == (69088,)
    assert cloud.intensity is not None and cloud.intensity.dtype == np.float32
    assert cloud.timestamps is None
    # A view, not a copy: two reads share memory and writes reach the C++ cloud.
    assert np.shares_memory(cloud.points, cloud.points)
    assert not pts.flags.owndata
    pts[0] = (1.0, 2.0, 3.0)
    assert tuple(cloud.points[0]) == (1.0, 2.0, 3.0)


def test_view_outlives_python_reference(data):
    pts = hazmap.read_cloud(data / "scan-pair" / "251371071.pcd").points  # cloud kept alive by the view
    assert pts.shape == (69792, 3)
    assert np.isfinite(pts).all()


def test_kitti_semantic_scan_with_labels(data):
    d = data / "kitti-semantic-sample"
    cloud = hazmap.read_cloud(d / "velodyne" / "000000.bin", classes="semantic-kitti")
    raw = np.fromfile(d / "velodyne" / "000000.bin", dtype=np.float32).reshape(-1, 4)
    np.testing.assert_array_equal(cloud.points, raw[:, :3])
    np.testing.assert_array_equal(cloud.intensity, raw[:, 3])
    assert cloud.classes.max() > 0  # trunks/poles become property classes


def test_roundtrip_from_numpy(tmp_path):
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(1000, 3)).astype(np.float32)
    cls = rng.integers(0, 4, size=1000).astype(np.uint16)
    prop = rng.normal(20, 5, size=1000).astype(np.float32)
    cloud = hazmap.LabeledCloud(pts, classes=cls, intensity=np.ones(1000), property=prop)
    np.testing.assert_array_equal(cloud.points, pts)
    np.testing.assert_array_equal(cloud.classes, cls)
    for ext in ("pcd", "ply", "bin"):
        path = tmp_path / f"c.{ext}"
        hazmap.write_cloud(path, cloud)
        back = hazmap.read_cloud(path)
        np.testing.assert_allclose(back.points, pts, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(back.classes, cls)
    back = hazmap.read_cloud(tmp_path / "c.pcd")
    np.testing.assert_allclose(back.property, prop)


def test_transformed_and_downsample(data):
    cloud = hazmap.read_cloud(data / "scan-pair" / "251370668.pcd")
    T = np.eye(4)
    T[:3, 3] = (1, 2, 3)
    np.testing.assert_allclose(cloud.transformed(T).points, cloud.points + np.float32([1, 2, 3]), atol=1e-4)
    small = hazmap.voxel_downsample(cloud, 0.25)
    assert 1000 < len(small) < len(cloud)


def test_bad_input_raises_hazmap_error(tmp_path, data):
    with pytest.raises(hazmap.Error, match="missing.pcd"):
        hazmap.read_cloud(tmp_path / "missing.pcd")
    bad = tmp_path / "truncated.pcd"
    bad.write_bytes((data / "scan-pair" / "251370668.pcd").read_bytes()[:5000])
    with pytest.raises(hazmap.Error, match="truncated.pcd"):
        hazmap.read_cloud(bad)
    assert issubclass(hazmap.Error, RuntimeError)
    with pytest.raises(hazmap.Error, match="points"):
        hazmap.LabeledCloud(np.zeros((5, 2)))
    with pytest.raises(hazmap.Error, match="classes"):
        hazmap.LabeledCloud(np.zeros((5, 3)), classes=np.zeros(4))


def test_assigning_points_of_another_count_resets_channels(data):
    cloud = hazmap.read_cloud(data / "scan-pair" / "251370668.pcd")
    assert cloud.intensity is not None
    cloud.points = np.zeros((10, 3), np.float32)
    assert len(cloud) == 10 and cloud.classes.shape == (10,) and cloud.intensity is None
    cloud.classes = np.arange(10, dtype=np.uint16)
    cloud.points = np.ones((10, 3))  # same count: channels kept, float64 converted
    np.testing.assert_array_equal(cloud.classes, np.arange(10))
    assert cloud.points.dtype == np.float32 and cloud.points.sum() == 30
