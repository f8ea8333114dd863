"""Scan streams from bags and captures (openScanSource), against the recordings' known contents."""
import json

import numpy as np
import pytest

import hazmap


def test_mcap_pointcloud2_scans(data):
    d = data / "sensors" / "mcap"
    expected = json.loads((d / "expected.json").read_text())
    clouds = expected["bags"]["velodyne-zstd-chunked.mcap"]["clouds"]
    scans = list(hazmap.open(d / "velodyne-zstd-chunked.mcap", lidar_topic="/velodyne_points"))
    assert len(scans) == len(clouds) == 3
    for scan, exp in zip(scans, clouds):
        assert len(scan.cloud) == exp["points"]
        np.testing.assert_allclose(scan.cloud.points[:, 0].astype(np.float64).sum(), exp["sum_x"], rtol=1e-6)
        assert scan.odometry is not None and scan.odometry.shape == (4, 4)


def test_ouster_capture_scans(data):
    source = hazmap.open(data / "sensors" / "ouster-os1-128" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap")
    scans = list(source)
    assert len(scans) == 3  # as `hazmap info` reports
    for s in scans:
        assert len(s.cloud) > 100000
        assert s.cloud.timestamps is not None and s.cloud.timestamps.dtype == np.float64
    assert scans[0].stamp < scans[1].stamp < scans[2].stamp


def test_hesai_bag_with_its_model_and_angle_file(data):
    d = data / "sensors" / "hesai-xt32"
    source = hazmap.open(d / "1673400677802009732", sensor="PandarXT32", hesai_calibration=d / "PandarXT32.csv")
    scans = list(source)
    assert len(scans) == 4  # as `hazmap info` reports: the partial rotation at the end dropped
    assert "Hesai PandarXT32" in source.description and "PandarXT32.csv" in source.description
    assert all(len(s.cloud) > 40000 for s in scans)
    with pytest.raises(hazmap.Error, match="no decodable LiDAR packet"):
        list(hazmap.open(data / "sensors" / "hesai-qt128" / "1730273789074637152", sensor="XT32"))


def test_sequence_folder(sim_sequence):
    source = hazmap.open(sim_sequence)
    assert len(source) == 15
    first = next(source)
    assert first.index == 0 and first.ground_truth is not None
    np.testing.assert_array_equal(first.cloud.points, hazmap.read_cloud(sim_sequence / "velodyne" / "000000.bin").points)


def test_bad_recording(tmp_path):
    p = tmp_path / "nothing.mcap"
    p.write_bytes(b"\x89MCAP0\r\n garbage")
    with pytest.raises(hazmap.Error, match="nothing.mcap"):
        list(hazmap.open(p))


def test_imu_rotation_is_parsed_and_a_bad_one_named(data):
    capture = data / "sensors" / "ouster-os1-128" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"
    assert len(list(hazmap.open(capture, imu_rotation="0,0,90"))) == 3  # Ouster packets: the metadata's
    with pytest.raises(hazmap.Error, match="imu_rotation: expected roll,pitch,yaw"):
        hazmap.open(capture, imu_rotation="1,2")
