"""What an evaluation computes once and reuses (issue 71, exact savings): the culled ground truth's
metric samples and KD-tree (``GroundTruthSamples``) shared by every map scored against it, and the
culled ground truth kept while new poses see nothing new. Cached and uncached give the same
metrics, bit for bit; and every evaluation's cost per stage is recorded (names only here: no test
asserts a wall time). Tiny meshes, bounded by size."""
from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from ramensim.evaluation.config import EvalConfig
from ramensim.evaluation.metrics import GroundTruthSamples, mesh_metrics
from ramensim.scoring import STAGES, Evaluator


def _plane(x0: float, x1: float, y0: float = 0.0, y1: float = 1.0, z: float = 0.0) -> trimesh.Trimesh:
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], float)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _looking_down(x: float, y: float, h: float) -> np.ndarray:
    """Camera at (x, y, h) looking straight down (-z), OpenCV axes."""
    c2w = np.eye(4)
    c2w[:3, :3] = np.array([[1, 0, 0], [0, -1, 0], [0, 0, -1]], float)
    c2w[:3, 3] = (x, y, h)
    return c2w


def _same(a: dict, b: dict) -> bool:
    """Equal dicts, NaN equal to NaN (as metrics.json writes both as null)."""
    return json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)


def _parts(p: np.ndarray) -> dict[str, np.ndarray]:
    return {"left": p[:, 0] < 0.0, "none": np.zeros(len(p), bool)}


@pytest.mark.parametrize("seed", [0, 7, np.random.SeedSequence([3, 1])])
def test_prepared_ground_truth_gives_the_same_metrics(seed):
    gt = trimesh.util.concatenate([_plane(-1, 0), _plane(0, 1, z=0.01)])
    ref = GroundTruthSamples(gt, 5000, seed)
    for recon in (_plane(-1, 0), _plane(-0.5, 1.0, z=0.02), trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int))):
        plain = mesh_metrics(recon, gt, n_samples=5000, seed=seed, gt_parts=_parts)
        reused = mesh_metrics(recon, gt, n_samples=5000, seed=seed, gt_parts=_parts, reference=ref)
        assert _same(plain, reused)
    assert ref.points is not None and len(ref.points) == 5000


def test_prepared_ground_truth_with_a_problem_gives_the_same_reason():
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int))
    ref = GroundTruthSamples(empty, 1000, 0)
    plain = mesh_metrics(_plane(0, 1), empty, n_samples=1000, seed=0)
    assert ref.points is None and _same(plain, mesh_metrics(_plane(0, 1), empty, n_samples=1000, seed=0,
                                                             reference=ref))
    assert math.isnan(plain["completion_ratio_pct"])


def test_a_reference_for_other_arguments_is_refused():
    gt = _plane(0, 1)
    ref = GroundTruthSamples(gt, 1000, 0)
    for kwargs in ({"n_samples": 2000, "seed": 0}, {"n_samples": 1000, "seed": 1}):
        with pytest.raises(ValueError, match="reference was prepared for another"):
            mesh_metrics(_plane(0, 1), gt, reference=ref, **kwargs)
    with pytest.raises(ValueError, match="reference was prepared for another"):
        mesh_metrics(_plane(0, 1), _plane(0, 1), n_samples=1000, seed=0, reference=ref)  # an equal, other mesh
    with pytest.raises(ValueError, match="SeedSequence"):
        GroundTruthSamples(gt, 1000, np.random.default_rng(0))


def _world(n: int) -> SimpleNamespace:
    return SimpleNamespace(scene=SimpleNamespace(mesh=_plane(-2.0, 2.0)), n_agents=n,
                           bounds=np.array([[-2.1, -0.1, -0.3], [2.1, 1.1, 0.3]]),
                           intrinsics=SimpleNamespace(fx=50, fy=50, cx=49.5, cy=49.5, width=100, height=100))


CFG = EvalConfig(cull="frustum_occlusion", near_m=0.05, far_m=10.0, n_samples=4000, voxel_m=0.05)


def _evaluator() -> Evaluator:
    return Evaluator(CFG, _world(3), seed=2, neighbours=[[1], [0, 2], [1]])  # type: ignore[arg-type]


def _uncached() -> Evaluator:
    """A fresh evaluator that samples the ground truth inside mesh_metrics, as before the reuse."""
    ev = _evaluator()
    ev._reference = lambda gt: None  # type: ignore[method-assign]
    return ev


# three robots over three stretches of a floor; the second evaluation adds a pose over the first
# stretch (nothing new seen) and one over x = 1.8 (more of the floor)
STEP1 = [_looking_down(x, 0.5, 0.6)[None] for x in (-1.4, 0.0, 1.4)]
STEP2 = [np.concatenate([STEP1[0], _looking_down(-1.4, 0.5, 0.6)[None]]), STEP1[1],
         np.concatenate([STEP1[2], _looking_down(1.8, 0.5, 0.6)[None]])]
MESHES = [_plane(-2.0, -0.8, z=0.01), _plane(-0.5, 2.0, z=0.03), _plane(-2.0, 2.0, z=-0.02)]


def test_a_team_evaluation_reuses_the_ground_truth_and_matches_fresh_evaluators():
    """One evaluator scoring three maps at two evaluations (the ground truth culled
    incrementally, its samples shared) gives what a fresh evaluator per map and evaluation,
    sampling the ground truth each time, gives."""
    ev = _evaluator()
    for poses in (STEP1, STEP1, STEP2):
        refs = []
        for k, mesh in enumerate(MESHES):
            cached = ev.score_mesh(mesh, poses, fed_by=[k])
            refs.append(ev._gt_reference)
            assert _same(cached, _uncached().score_mesh(mesh, poses, fed_by=[k]))
        assert refs[0] is refs[1] is refs[2]  # sampled once for the three maps
    # the same poses again: the same culled mesh, the same samples
    culled = ev._culled_gt(np.concatenate(STEP2))
    assert ev._culled_gt(np.concatenate(STEP2)) is culled


class _SphereMap:
    """An analytic map: a ball of radius 0.25 m at the floor's centre (SDF m, colours by position)."""

    def sdf(self, p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p - (0.0, 0.5, 0.0), axis=1) - 0.25

    def sdf_and_color(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.sdf(p), np.clip(np.abs(p), 0.0, 1.0)


def test_score_all_records_each_stage_and_equals_scoring_each_map_alone():
    ev = _evaluator()
    times: dict[str, float] = {}
    team = ev.team_coverage_pct(np.concatenate(STEP1), times=times)
    out = ev.score_all([(_SphereMap(), [k], None) for k in range(3)], STEP1, times=times)
    alone = [_uncached().score(_SphereMap(), STEP1, [k]) for k in range(3)]
    assert all(_same(a, b) for a, b in zip(out, alone)) and 0.0 < team <= 100.0
    record = ev.record_evaluation(30.0, times, wall_s=1.0, maps=3)
    assert ev.stage_records == [record] and record["maps"] == 3 and not record["final"]
    assert set(record["stage_s"]) <= set(STAGES)
    assert {"sdf_grid", "marching_cubes", "mesh_cull", "gt_cull", "sampling", "distances",
            "coverage", "unseen_part"} <= set(record["stage_s"])
    assert all(isinstance(v, float) for v in record["stage_s"].values())
    # vertex colours only for meshes handed on (or saved): no metric reads them
    assert "colours" not in record["stage_s"]
    kept: dict[int, object] = {}
    coloured_times: dict[str, float] = {}
    again = ev.score_all([(_SphereMap(), [k], None) for k in range(3)], STEP1, times=coloured_times,
                         on_mesh=kept.__setitem__)
    assert all(_same(a, b) for a, b in zip(again, out)) and "colours" in coloured_times
    assert all(m.visual.kind == "vertex" and len(m.visual.vertex_colors) == len(m.vertices) for m in kept.values())


def test_score_all_overlapping_extraction_with_scoring_gives_the_same_results():
    """``overlap``: the next maps are extracted on ``run``'s workers while this thread scores the
    previous ones; the results, their order and the meshes handed on are those of scoring in turn,
    and no more than two chunks of maps are extracted before they are scored."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    items = [(_SphereMap(), [k % 3], None) for k in range(5)]
    plain = _evaluator().score_all(items, STEP1, at_once=2)
    lock, extracted, scored, ahead = threading.Lock(), [0], [0], []

    ev = _evaluator()
    score, extract = ev.score, ev.extract

    def counting_extract(*args, **kwargs):
        mesh = extract(*args, **kwargs)
        with lock:
            extracted[0] += 1
        return mesh

    def counting_score(*args, **kwargs):
        with lock:
            ahead.append(extracted[0] - scored[0])  # maps extracted but not yet scored
            scored[0] += 1
        return score(*args, **kwargs)

    ev.score, ev.extract = counting_score, counting_extract
    kept: dict[int, object] = {}
    with ThreadPoolExecutor(2) as pool:
        out = ev.score_all(items, STEP1, at_once=2, overlap=True,
                           run=lambda fn, xs: list(pool.map(fn, xs)), on_mesh=kept.__setitem__)
    assert all(_same(a, b) for a, b in zip(out, plain)) and len(out) == 5
    assert sorted(kept) == list(range(5))
    assert extracted[0] == 5 and max(ahead) <= 4  # the chunk being scored and the next one at most
