"""Coverage and transfer metrics (ramensim.evaluation.coverage, mesh_metrics' gt_parts):
known answers on meshes and cameras whose visibility is obvious."""
from __future__ import annotations

import math

import numpy as np
import trimesh

from ramensim.evaluation.coverage import own_coverage_pct, seen_by_agent, unseen_part
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
