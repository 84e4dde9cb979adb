"""Coverage and transfer metrics (ramensim.evaluation.coverage, mesh_metrics' gt_parts):
known answers on meshes and cameras whose visibility is obvious."""
from __future__ import annotations

import math

import numpy as np
import trimesh

import pytest

from ramensim.evaluation.coverage import far_part, own_and_near, own_coverage_pct, seen_by_agent, unseen_part
from ramensim.evaluation.cull import PinholeCamera
from ramensim.evaluation.metrics import mesh_metrics


def _plane(x0: float, x1: float, y0: float = 0.0, y1: float = 1.0, z: float = 0.0) -> trimesh.Trimesh:
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], float)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _looking_down(x: float, y: float, h: float) -> np.ndarray:
    """Camera at (x, y, h) looking straight down (-z), OpenCV axes."""
    c2w = np.eye(4)
    c2w[:3, :3] = np.array([[1, 0, 0], [0, -1, 0], [0, 0, -1]], float)
    c2w[:3, 3] = (x, y, h)
    return c2w


def test_gt_parts_restrict_completion_and_holes():
    gt = trimesh.util.concatenate([_plane(-1, 0), _plane(0, 1)])
    recon = _plane(-1, 0)  # only the left half reconstructed
    r = mesh_metrics(recon, gt, n_samples=20000, seed=0,
                     gt_parts=lambda p: {"left": p[:, 0] < 0, "right": p[:, 0] > 0})
    assert r["share_pct_left"] == np.float64(r["share_pct_left"]) and 45 < r["share_pct_left"] < 55
    assert r["completion_ratio_pct_left"] > 99.0 and r["holes_cm_left"] < 1.0
    assert r["completion_ratio_pct_right"] < 6.0 and r["holes_cm_right"] > 40.0
    # the whole is the area-weighted mix of the parts
    whole = (r["share_pct_left"] * r["completion_ratio_pct_left"]
             + r["share_pct_right"] * r["completion_ratio_pct_right"]) / 100.0
    assert math.isclose(whole, r["completion_ratio_pct"], rel_tol=1e-9)
    empty = mesh_metrics(recon, gt, n_samples=1000, seed=0, gt_parts=lambda p: {"none": np.zeros(len(p), bool)})
    assert empty["share_pct_none"] == 0.0 and math.isnan(empty["completion_ratio_pct_none"])


def test_two_cameras_over_two_halves():
    cam = PinholeCamera(50, 50, 49.5, 49.5, 100, 100, 0.05, 10.0)  # 90 degree field of view
    pts = np.stack([np.linspace(-1.95, 1.95, 40), np.zeros(40), np.zeros(40)], axis=1)  # none on a frustum edge
    left, right = _looking_down(-1.0, 0.0, 0.8), _looking_down(1.0, 0.0, 0.8)  # each sees |x -/+ 1| < 0.8
    seen = seen_by_agent(pts, [left[None], right[None]], cam)
    assert np.array_equal(seen[0], np.abs(pts[:, 0] + 1.0) < 0.8)
    assert np.array_equal(seen[1], np.abs(pts[:, 0] - 1.0) < 0.8)
    cov = own_coverage_pct(seen)
    assert np.allclose(cov, 100.0 * seen.mean(axis=1))
    # agent 0's unseen part: what agent 1 saw and agent 0 did not
    assert np.array_equal(unseen_part(seen, 0), seen[1] & ~seen[0])
    # an occluder between camera 0 and the floor hides everything from it
    roof = _plane(-3, 3, -3, 3, z=0.4)
    seen_occ = seen_by_agent(pts, [left[None], right[None]], cam, occluder=roof, eps_m=0.01)
    assert not seen_occ.any()


def test_far_part_is_what_only_robots_beyond_the_neighbours_saw():
    # robots 0-1-2-3 on a path; each column a point, seen by the robots marked
    seen = np.array([[1, 0, 0, 0, 0, 1],
                     [0, 1, 0, 0, 0, 0],
                     [0, 0, 1, 0, 1, 1],
                     [0, 0, 0, 1, 1, 0]], dtype=bool)
    near0 = np.array([True, True, False, False])  # robot 0 and its neighbour 1
    assert far_part(seen, near0).tolist() == [False, False, True, True, True, False]
    near1 = np.array([True, True, True, False])
    assert far_part(seen, near1).tolist() == [False, False, False, True, False, False]
    assert not far_part(seen, np.ones(4, bool)).any()  # a complete graph has no far part
    # the far part lies inside the unseen part
    assert not (far_part(seen, near0) & ~unseen_part(seen, 0)).any()
    with pytest.raises(ValueError, match="one flag per robot"):
        far_part(seen, np.ones(3, bool))


def _floor_world(n: int):
    from types import SimpleNamespace

    gt = _plane(-2.0, 2.0)
    return SimpleNamespace(scene=SimpleNamespace(mesh=gt), n_agents=n,
                           intrinsics=SimpleNamespace(fx=50, fy=50, cx=49.5, cy=49.5, width=100, height=100))


@pytest.mark.parametrize("neighbours, far", [([[1], [0, 2], [1]], True), ([[1, 2], [0, 2], [0, 1]], False),
                                             (None, False)])
def test_evaluator_scores_the_far_part_on_a_fixed_graph(neighbours, far):
    """Three robots over three stretches of a floor, robot 0 mapping only its own: on a path
    0-1-2 its far part is robot 2's stretch (about a third) and nothing of it is complete; on a
    complete graph, or without fixed neighbours, the far part is left out with a reason."""
    from ramensim.evaluation.config import EvalConfig
    from ramensim.scoring import Evaluator

    cfg = EvalConfig(cull="frustum", near_m=0.05, far_m=10.0, n_samples=20000)
    ev = Evaluator(cfg, _floor_world(3), neighbours=neighbours)  # type: ignore[arg-type]
    poses = [_looking_down(x, 0.5, 0.6)[None] for x in (-1.4, 0.0, 1.4)]  # each sees |x - x_k| < 0.6
    out = ev.score_mesh(_plane(-2.0, -0.8), poses, fed_by=[0])
    if far:
        assert 25.0 < out["far_share_pct"] < 40.0 and out["completion_far_pct"] < 1.0
        assert out["holes_far_cm"] > 100.0 and "far_reason" not in out
        assert out["completion_unseen_pct"] < out["completion_own_pct"]
    else:
        assert out.get("completion_far_pct") is None or math.isnan(out["completion_far_pct"])
        assert "far_reason" in out


def test_own_and_near_on_a_path_and_without_a_graph():
    path = [[1], [0, 2], [1, 3], [2]]
    own, near = own_and_near(4, [0], path)
    assert own.tolist() == [True, False, False, False] and near.tolist() == [True, True, False, False]
    own, near = own_and_near(4, [1, 2], path)
    assert own.tolist() == [False, True, True, False] and near.tolist() == [True] * 4
    own, near = own_and_near(4, [3], None)
    assert own.tolist() == [False, False, False, True] and near is None
