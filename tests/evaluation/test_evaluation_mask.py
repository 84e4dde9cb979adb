"""``evaluation.mask_unobserved`` (issue 57: documented and accepted, read nowhere): a map's mesh
keeps only the space the frames that fed it observed (ramensim/scoring.py, Evaluator.observed_fn)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import trimesh

from ramensim.evaluation.config import EvalConfig
from ramensim.scoring import MASK_CELL_M, Evaluator


def _floor_world():
    v = np.array([[-2.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [-2.0, 1.0, 0.0]])
    gt = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)
    return SimpleNamespace(scene=SimpleNamespace(mesh=gt), n_agents=2,
                           bounds=np.array([[-2.0, -0.2, -0.3], [2.0, 1.2, 0.8]]),
                           intrinsics=SimpleNamespace(fx=50, fy=50, cx=49.5, cy=49.5, width=100, height=100))


def _looking_down(x: float, y: float, h: float) -> np.ndarray:
    c2w = np.eye(4)
    c2w[:3, :3] = np.array([[1, 0, 0], [0, -1, 0], [0, 0, -1]], float)
    c2w[:3, 3] = (x, y, h)
    return c2w


class _FlatMap:
    """A map whose surface is the plane z = 0 across the whole bounds (seen or not)."""

    def sdf(self, p):
        return np.asarray(p, dtype=np.float32)[:, 2]

    def sdf_and_color(self, p):
        p = np.asarray(p, dtype=np.float32)
        return p[:, 2], np.full((len(p), 3), 0.5, np.float32)


def test_masked_mesh_keeps_only_what_the_maps_frames_observed():
    """Robot 0's camera above x = -1.4 sees |x + 1.4| < 0.6 of the floor: with the mask its map's
    mesh stops within a grid cell (dilated) of that stretch; without it, it spans the bounds;
    robot 1's frames do not widen robot 0's mask; no frame at all, no face."""
    poses = [_looking_down(-1.4, 0.5, 0.6)[None], _looking_down(1.4, 0.5, 0.6)[None]]
    plain = Evaluator(EvalConfig(voxel_m=0.05, near_m=0.05, far_m=10.0), _floor_world())  # type: ignore[arg-type]
    masked = Evaluator(EvalConfig(voxel_m=0.05, near_m=0.05, far_m=10.0, mask_unobserved=True),
                       _floor_world())  # type: ignore[arg-type]
    whole = plain.mesh_of(_FlatMap(), poses=poses[0])
    assert whole.vertices[:, 0].min() < -1.9 and whole.vertices[:, 0].max() > 1.9  # the flag off: no mask
    cut = masked.mesh_of(_FlatMap(), poses=poses[0])
    margin = 2 * MASK_CELL_M + 0.05  # the cell holding the stretch's edge, its dilation, a voxel
    assert 0 < len(cut.faces) < 0.5 * len(whole.faces)
    assert cut.vertices[:, 0].min() > -2.0 - 1e-9 and cut.vertices[:, 0].max() < -0.8 + margin
    assert cut.vertices[:, 0].max() > -0.8 - margin  # what was seen is kept
    assert len(masked.mesh_of(_FlatMap(), poses=np.zeros((0, 4, 4))).faces) == 0
    # score() masks with the frames of the robots that fed the map: robot 0's only
    out = masked.score(_FlatMap(), poses, fed_by=[0])
    assert out["n_faces_mesh"] == len(cut.faces)
    both = masked.score(_FlatMap(), poses, fed_by=[0, 1])  # a centralised learner: both stretches
    assert both["n_faces_mesh"] > 1.5 * out["n_faces_mesh"]


def test_space_behind_the_observed_surface_is_unobserved():
    """Below the floor (deeper than the depth image plus the tolerance) nothing was observed:
    a surface there is masked away even inside the camera's frustum."""
    ev = Evaluator(EvalConfig(voxel_m=0.05, near_m=0.05, far_m=10.0, mask_unobserved=True),
                   _floor_world())  # type: ignore[arg-type]
    observed = ev.observed_fn(_looking_down(-1.4, 0.5, 0.6)[None])
    pts = np.array([[-1.4, 0.5, 0.0], [-1.4, 0.5, 0.3], [-1.4, 0.5, -0.29], [1.4, 0.5, 0.0]])
    assert observed(pts).tolist() == [True, True, False, False]
