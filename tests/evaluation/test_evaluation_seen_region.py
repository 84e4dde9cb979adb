"""The periodic evaluations refine their narrow band only where some camera may have seen
(issue 71): the block bound never rules out a point the culling's test finds seen, it is the
same when poses come a batch at a time, and a map's mesh extracted with the region, once culled
to the cameras' views, has exactly the faces it has without it, while the surface nobody could
see (a sphere behind the room's wall) is never extracted."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from ramensim.core.native import compiler
from ramensim.evaluation.cull import (OccluderDepths, SeenBlocks, cull_to_views, point_clusters,
                                      spheres_may_be_seen, visible_points)
from ramensim.evaluation.mesh import NarrowBand, extract_mesh

from tests.evaluation.test_evaluation_visibility import CAM, poses, room

pytestmark = pytest.mark.skipif(shutil.which(compiler()[0]) is None, reason="no C compiler")


def test_a_sphere_ruled_out_holds_no_seen_point():
    rng = np.random.default_rng(21)
    mesh = room()
    points = np.concatenate([mesh.sample(6000, seed=4), rng.uniform(-4.0, 4.0, size=(6000, 3))])
    P = poses(rng, 20)
    depths = OccluderDepths(mesh, CAM, stride=4)
    seen = visible_points(points, P, CAM, occluder=depths)
    for size in (0.1, 0.4):
        order, (start, spheres) = point_clusters(points, size)
        may = spheres_may_be_seen(spheres, P, CAM, depths)
        cluster_of = np.repeat(np.arange(len(spheres)), np.diff(start))
        seen_sorted = seen[order]
        assert not seen_sorted[~may[cluster_of]].any()  # never rules out a seen point
        assert (~may).sum() > 0.2 * len(may)            # and rules out something (behind walls, outside frusta)
        in_parts = spheres_may_be_seen(spheres, P[:7], CAM, depths)
        in_parts = spheres_may_be_seen(spheres, P[7:], CAM, depths, may=in_parts)
        np.testing.assert_array_equal(in_parts, may)


def test_seen_blocks_are_kept_and_grow_with_new_poses():
    rng = np.random.default_rng(2)
    mesh = room()
    P = poses(rng, 24)
    origin, cell, shape = np.array([-3.3, -2.8, -1.8]), 0.1, (90, 60, 40)
    fresh = SeenBlocks(CAM, OccluderDepths(mesh, CAM, 4)).cells(origin, cell, shape, P)
    blocks = SeenBlocks(CAM, OccluderDepths(mesh, CAM, 4))
    first = blocks.cells(origin, cell, shape, P[:10])
    later = blocks.cells(origin, cell, shape, P)
    assert first.shape == shape and (later >= first).all() and later.sum() > first.sum()
    np.testing.assert_array_equal(later, fresh)
    np.testing.assert_array_equal(blocks.cells(origin, cell, shape, P[:5]),  # fewer poses: from scratch
                                  SeenBlocks(CAM, OccluderDepths(mesh, CAM, 4)).cells(origin, cell, shape, P[:5]))


BOUNDS = np.array([[-3.2, -2.7, -1.7], [5.3, 2.7, 1.7]])
VOXEL = 0.05


def _two_spheres(p: np.ndarray) -> np.ndarray:
    """A ball inside the room and one behind its +x wall (x = 3), where no camera in it can see."""
    inside = np.linalg.norm(p - np.array([0.5, 0.3, 0.0]), axis=1) - 0.5
    behind = np.linalg.norm(p - np.array([4.5, 0.0, 0.0]), axis=1) - 0.6
    return np.minimum(inside, behind).astype(np.float32)


def _face_set(mesh) -> set:
    tri = np.round(np.asarray(mesh.vertices)[np.asarray(mesh.faces)], 9)
    return {tuple(sorted(map(tuple, t))) for t in tri}


def test_the_region_changes_no_culled_face_and_skips_what_no_one_saw():
    rng = np.random.default_rng(9)
    mesh = room()
    P = poses(rng, 40)
    depths = OccluderDepths(mesh, CAM, 4)
    blocks = SeenBlocks(CAM, depths)
    region = lambda origin, cell_m, shape: blocks.cells(origin, cell_m, shape, P)  # noqa: E731
    band = NarrowBand(2, 0.03, 0)
    asked: dict[str, list] = {"plain": [], "skipped": []}

    def query(name):
        def sdf(p):
            asked[name].append(np.asarray(p)[:, 0])
            return _two_spheres(p)
        return sdf

    def coarse(origin, voxel, shape):  # the coarse grid, not counted: the band's queries are
        ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
        return _two_spheres((origin + ijk * voxel).astype(np.float32)).reshape(shape)

    plain = extract_mesh(query("plain"), BOUNDS, VOXEL, band=band, grid_fn=coarse)
    skipped = extract_mesh(query("skipped"), BOUNDS, VOXEL, band=band, region=region, grid_fn=coarse)
    hidden_plain = int((np.concatenate(asked["plain"]) > 3.5).sum())
    hidden_skipped = int((np.concatenate(asked["skipped"]) > 3.5).sum())
    assert hidden_plain > 5000                                    # the band around the hidden ball is queried without ...
    assert hidden_skipped < 0.5 * hidden_plain                    # ... and mostly not with the region
    cut_plain = cull_to_views(plain, P, CAM, occluder=depths)
    cut_skipped = cull_to_views(skipped, P, CAM, occluder=depths)
    assert len(cut_plain.faces) > 500                             # the visible ball was seen
    assert _face_set(cut_plain) == _face_set(cut_skipped)


def test_the_region_is_used_only_by_a_culled_narrow_band_with_poses():
    from types import SimpleNamespace

    from ramensim.evaluation.config import EvalConfig
    from ramensim.scoring import Evaluator

    world = SimpleNamespace(scene=None, n_agents=1, bounds=BOUNDS,
                            intrinsics=SimpleNamespace(fx=CAM.fx, fy=CAM.fy, cx=CAM.cx, cy=CAM.cy,
                                                       width=CAM.width, height=CAM.height))
    P = poses(np.random.default_rng(1), 5)
    for cfg in (EvalConfig(cull="none"), EvalConfig(cull="frustum", periodic={"extraction": "dense"}),
                EvalConfig(cull="frustum", periodic={"skip_unseen": False})):
        assert Evaluator(cfg, world).periodic_region(P) is None  # type: ignore[arg-type]
    ev = Evaluator(EvalConfig(cull="frustum"), world)  # type: ignore[arg-type]
    assert ev.periodic_region(np.zeros((0, 4, 4))) is None  # no poses: the mesh is not culled either
    cells = ev.periodic_region(P)(BOUNDS[0], 0.1, (85, 54, 34))
    assert cells.shape == (85, 54, 34) and cells.dtype == bool and 0 < cells.sum() < cells.size


def test_periodic_evaluations_extract_on_their_own_grid_spacing():
    from types import SimpleNamespace

    from ramensim.evaluation.config import EvalConfig
    from ramensim.scoring import Evaluator

    world = SimpleNamespace(scene=None, n_agents=1, bounds=BOUNDS, intrinsics=CAM)

    class Ball:
        def sdf(self, p):
            return (np.linalg.norm(p - np.array([0.5, 0.3, 0.0]), axis=1) - 0.5).astype(np.float32)

        def sdf_and_color(self, p):
            return self.sdf(p), np.full((len(p), 3), 0.5, np.float32)

    ev = Evaluator(EvalConfig(voxel_m=0.05, periodic={"voxel_m": 0.1}), world)  # type: ignore[arg-type]
    none = [np.zeros((0, 4, 4))]
    final, periodic = ev.extract(Ball(), none, [0]), ev.extract(Ball(), none, [0], periodic=True)
    assert len(periodic.vertices) < 0.4 * len(final.vertices)  # about a quarter: twice the spacing
    assert EvalConfig().periodic.voxel_m is None  # the default: the final's spacing
