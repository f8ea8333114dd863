"""register() on the shared scan pair against its published alignment; configs via the field tables."""
import threading
import time

import numpy as np
import pytest

import hazmap


def load_matrix(path):
    return np.loadtxt(path).reshape(4, 4)


@pytest.fixture(scope="module")
def pair(data):
    d = data / "scan-pair"
    target = hazmap.voxel_downsample(hazmap.read_cloud(d / "251370668.pcd"), 0.25)
    source = hazmap.voxel_downsample(hazmap.read_cloud(d / "251371071.pcd"), 0.25)
    return source, target, load_matrix(d / "relative.txt"), load_matrix(d / "small_gicp_T_target_source.txt")


def errors(T, ref):
    e = np.linalg.inv(ref) @ T
    angle = np.degrees(np.arccos(np.clip((np.trace(e[:3, :3]) - 1) / 2, -1, 1)))
    return np.linalg.norm(e[:3, 3]), angle


@pytest.mark.parametrize("use_classes", [True, False])
@pytest.mark.parametrize("metric", ["point", "plane"])
def test_lands_on_the_reference(pair, use_classes, metric):
    source, target, reference, small_gicp = pair
    r = hazmap.register(source, target, config={"use_classes": use_classes, "metric": metric, "max_iterations": 100})
    assert r.converged, r.reason
    for ref in (reference, small_gicp):  # as tests/test_registration_real.cpp
        t_err, r_err = errors(r.transform, ref)
        assert t_err < 0.05 and r_err < 0.5
    assert r.fitness > 0.8
    assert r.covariance.shape == (6, 6) and np.allclose(r.covariance, r.covariance.T)
    assert np.all(np.linalg.eigvalsh(r.covariance) > 0)
    assert r.iterations >= 1 and r.rmse > 0
    assert isinstance(r.labels_used, bool)


def test_init_and_config_object(pair):
    source, target, reference, _ = pair
    cfg = hazmap.Config("registration", max_iterations=1)
    assert cfg.metric == "plane" and cfg.max_iterations == 1
    one = hazmap.register(source, target, init=reference, config=cfg)
    assert one.iterations == 1
    t_err, _ = errors(one.transform, reference)
    assert t_err < 0.05  # started on the answer, one step stays there


def test_config_defaults_are_the_yaml_tables():
    d = hazmap.defaults("registration")
    assert d["max_iterations"] == 50 and d["metric"] == "plane" and d["robust_kernel"] == "geman-mcclure"
    names = [f["name"] for f in hazmap.fields("odometry")]
    assert "registration" in names and "map" in names
    run = hazmap.defaults("run", method="icp")
    assert run["odometry"]["registration"]["use_classes"] is False
    assert hazmap.defaults("run")["odometry"]["registration"]["use_classes"] is True


def test_config_errors_have_the_yaml_messages(pair):
    source, target, _, _ = pair
    with pytest.raises(hazmap.Error, match="unknown key 'max_iteration' \\(did you mean 'max_iterations'\\?\\)"):
        hazmap.register(source, target, config={"max_iteration": 3})
    with pytest.raises(hazmap.Error, match="max_iterations: must be >= 1, got 0"):
        hazmap.Config("registration", max_iterations=0)
    with pytest.raises(hazmap.Error, match="metric"):
        hazmap.register(source, target, config={"metric": "sideways"})
    with pytest.raises(hazmap.Error, match="init"):
        hazmap.register(source, target, init=np.full((4, 4), np.nan))


def test_gil_is_released(pair):
    """A Python thread keeps running while register() works in C++."""
    source, target, _, _ = pair
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=tick)
    t.start()
    start = time.perf_counter()
    for _ in range(5):
        hazmap.register(source, target, config={"max_iterations": 100, "translation_tolerance": 1e-9,
                                                "rotation_tolerance": 1e-9})
    end = time.perf_counter()
    stop.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    assert len(during) >= 10, f"{len(during)} ticks in {end - start:.3f} s"
