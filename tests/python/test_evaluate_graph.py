"""evaluate() = `hazmap eval --json`; PoseGraph load/optimise/save on the shared g2o graphs."""
import numpy as np
import pytest

import hazmap

from conftest import cli_json


@pytest.mark.parametrize("align", ["se3", "sim3", "none"])
def test_evaluate_equals_cli(data, align):
    gt = data / "trajectories" / "KITTI_00_gt.txt"
    est = data / "trajectories" / "KITTI_00_ORB.txt"
    py = hazmap.evaluate(gt, est, align=align)
    cli = cli_json("eval", "--gt", gt, "--est", est, "--align", align, "--json")
    for key in ("ape", "rpe", "kitti", "poses", "gt_length_m"):
        assert py[key] == cli[key], key


def test_evaluate_arrays(data):
    gt = np.loadtxt(data / "trajectories" / "KITTI_00_gt.txt").reshape(-1, 3, 4)[:500]
    est = np.loadtxt(data / "trajectories" / "KITTI_00_ORB.txt").reshape(-1, 3, 4)[:500]
    pad = np.tile([0, 0, 0, 1.0], (500, 1, 1))
    r = hazmap.evaluate(np.concatenate([gt, pad], 1), np.concatenate([est, pad], 1), align="sim3")
    assert r["poses"] == 500 and 0 < r["ape"]["rmse"] < 50
    with pytest.raises(hazmap.Error, match="poses"):
        hazmap.evaluate(np.eye(4)[None].repeat(3, 0), np.eye(4)[None].repeat(4, 0))
    with pytest.raises(hazmap.Error, match="align"):
        hazmap.evaluate(data / "trajectories" / "KITTI_00_gt.txt", data / "trajectories" / "KITTI_00_gt.txt", align="xyz")


@pytest.mark.parametrize("name", ["tinyGrid3D.g2o", "smallGrid3D.g2o"])
def test_pose_graph_optimise_and_save(data, tmp_path, name):
    g = hazmap.PoseGraph.load(data / "pose-graphs" / name)
    assert len(g) > 0 and g.edges >= len(g) - 1 and g.dimension == 3
    before = g.poses.copy()
    report = g.optimise()
    assert report["converged"], report["message"]
    assert report["final_chordal"] < report["initial_chordal"]
    assert not np.allclose(before, g.poses)
    g.save(tmp_path / "out.g2o")
    back = hazmap.PoseGraph.load(tmp_path / "out.g2o")
    np.testing.assert_allclose(back.poses, g.poses, atol=1e-9)
    assert back.ids == g.ids and back.edges == g.edges


def test_pose_graph_errors(tmp_path):
    with pytest.raises(hazmap.Error, match="missing.g2o"):
        hazmap.PoseGraph.load(tmp_path / "missing.g2o")
    bad = tmp_path / "bad.g2o"
    bad.write_text("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE_SE3:QUAT 0 7 1 0 0 0 0 0 1\n")
    with pytest.raises(hazmap.Error, match="bad.g2o:2"):
        hazmap.PoseGraph.load(bad)
