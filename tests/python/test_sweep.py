"""A tiny Table 2 sweep on a 2-worker LocalCluster equals the same runs made directly."""
import json

import numpy as np
import pytest

import hazmap
from hazmap import sweep

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def spec_for(tmp_path, **extra):
    spec = tmp_path / "spec.yaml"
    body = {"out": "out", "scenes": ["naraha"], "seeds": [1, 2], "frames": 6, "methods": ["odometry", "icp"],
            "setups": {"default": {}, "broken": {"odometry": {"voxel_size": -1.0}}}, "retries": 1}
    body.update(extra)
    spec.write_text(json.dumps(body))  # JSON is YAML
    return sweep.load_spec(spec)


def test_sweep_equals_direct_runs(client, tmp_path):
    spec = spec_for(tmp_path)
    rows, failures, skipped = sweep.execute(spec, client)
    table = sweep.write_results(spec, rows, failures)
    assert skipped == 0 and len(rows) == 4
    # The broken set-up fails on every run: retried, then reported with the config's message.
    assert len(failures) == 4
    assert all("odometry.voxel_size" in f["error"] for f in failures)
    assert {f["setup"] for f in failures} == {"broken"}

    direct = {}
    for seed in (1, 2):
        seq = tmp_path / f"direct-{seed}"
        hazmap.simulate(str(seq), {"scenario": "naraha", "seed": seed, "frames": 6})
        for method in ("odometry", "icp"):
            r = hazmap.run(seq, method, threads=1)
            direct.setdefault(method, []).append((r.table2_error, r.trajectory["ape"]["rmse"]))
    assert [e["method"] for e in table] == ["odometry", "icp"]
    for e in table:
        values = np.array(direct[e["method"]])
        assert e["n"] == 2 and e["seeds"] == [1, 2]
        assert e["map_error_mean"] == pytest.approx(values[:, 0].mean(), rel=1e-12)
        assert e["map_error_std"] == pytest.approx(values[:, 0].std(ddof=1), rel=1e-9)
        assert e["ate_rmse_mean"] == pytest.approx(values[:, 1].mean(), rel=1e-12)
    text = sweep.table2_text(table)
    assert "Odometry" in text and "ICP" in text and "±" in text

    written = json.loads((tmp_path / "out" / "table.json").read_text())
    assert written["table"] == table and len(written["failed"]) == 4
    assert (tmp_path / "out" / "table.csv").read_text().count("\n") == 3

    # A second pass skips every finished run (outputs keyed by inputs + parameters).
    rows2, failures2, skipped2 = sweep.execute(spec, client)
    assert skipped2 == 4 and len(rows2) == 4 and len(failures2) == 4
    assert sweep.summarise(rows2) == table


def test_grid_keys_change_the_run_key(tmp_path):
    spec = spec_for(tmp_path, setups={"default": {}}, grid={"odometry.voxel_size": [0.5, 0.75]})
    _, runs = sweep.plan(spec)
    assert len(runs) == 2 * 2 * 2  # seeds x methods x grid
    assert len({r["key"] for r in runs}) == len(runs)
    assert {r["config"]["odometry"]["voxel_size"] for r in runs} == {0.5, 0.75}


def test_bad_spec(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("scenes: [naraha]\nmethods: [magic]\n")
    with pytest.raises(ValueError, match="magic"):
        sweep.load_spec(p)
    p.write_text("scenes: [naraha]\nseed: [1]\n")
    with pytest.raises(ValueError, match="seed"):
        sweep.load_spec(p)
