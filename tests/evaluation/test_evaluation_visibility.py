"""Every path of the visibility test (compiled kernel, numpy blocks) gives the mask of the plain
per-pose definition, on a room with furniture seen from random poses; the evaluator's shared
depth images and incremental ground-truth culling change no result."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import trimesh

from ramensim.core.native import compiler
from ramensim.evaluation import _native
from ramensim.evaluation.cull import (OccluderDepths, PinholeCamera, cull_to_views, max_edge_length,
                                      render_depth, visible_points)

CAM = PinholeCamera(fx=60.0, fy=60.0, cx=39.5, cy=29.5, width=80, height=60, near_m=0.05, far_m=6.0)
HAVE_CC = shutil.which(compiler()[0]) is not None


def room() -> trimesh.Trimesh:
    """A 6 x 5 x 3 m room seen from inside (walls, floor, ceiling) with two boxes in it."""
    walls = trimesh.creation.box(extents=(6.0, 5.0, 3.0))
    walls.invert()
    boxes = [trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c))
             for e, c in (((1.0, 0.8, 1.2), (1.0, 0.5, -0.9)), ((0.6, 1.5, 2.0), (-1.5, -1.0, -0.5)))]
    return trimesh.util.concatenate([walls, *boxes])


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Camera-to-world pose (OpenCV axes: x right, y down, z forward) at ``eye`` looking at ``target``."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c2w = np.eye(4)
    c2w[:3, :3] = np.stack([x, y, z], axis=1)
    c2w[:3, 3] = eye
    return c2w


def poses(rng: np.random.Generator, n: int) -> np.ndarray:
    eyes = rng.uniform([-2.5, -2.0, -1.0], [2.5, 2.0, 1.0], size=(n, 3))
    targets = rng.uniform([-3.0, -2.5, -1.5], [3.0, 2.5, 1.5], size=(n, 3))
    return np.stack([look_at(e, t) for e, t in zip(eyes, targets)])


def reference(points: np.ndarray, P: np.ndarray, depth_of) -> np.ndarray:
    """The definition, pose by pose: in the frustum and not behind the depth image (eps 0.03 m)."""
    seen = np.zeros(len(points), dtype=bool)
    for k, c2w in enumerate(P):
        w2c = np.linalg.inv(c2w)
        xyz = points @ w2c[:3, :3].T + w2c[:3, 3]
        z = xyz[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = CAM.fx * xyz[:, 0] / z + CAM.cx
            v = CAM.fy * xyz[:, 1] / z + CAM.cy
        ok = (z >= CAM.near_m) & (z <= CAM.far_m) & (u >= 0) & (u < CAM.width) & (v >= 0) & (v < CAM.height)
        if depth_of is not None:
            img, s = depth_of(k, c2w)
            r = np.clip(np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0).astype(np.int64) // s, 0, img.shape[0] - 1)
            c = np.clip(np.nan_to_num(u, nan=0.0, posinf=0.0, neginf=0.0).astype(np.int64) // s, 0, img.shape[1] - 1)
            d = img[r, c]
            d = np.where(np.isfinite(d) & (d > 0), d, np.inf)
            ok &= z <= d + 0.03
        seen |= ok
    return seen


PATHS = [pytest.param(False, id="numpy"),
         pytest.param(True, id="native", marks=pytest.mark.skipif(not HAVE_CC, reason="no C compiler"))]


@pytest.mark.parametrize("native", PATHS)
@pytest.mark.parametrize("mode", ["frustum", "occluder", "depth_maps"])
def test_every_path_gives_the_definitions_mask(native, mode):
    rng = np.random.default_rng(7)
    mesh = room()
    points = np.concatenate([mesh.sample(4000, seed=1), rng.uniform(-3.5, 3.5, size=(2000, 3))])
    P = poses(rng, 12)
    kw: dict = {}
    depth_of = None
    if mode == "occluder":
        kw = {"occluder": mesh, "stride": 3}
        depth_of = lambda k, c2w: (render_depth(mesh, c2w, CAM, 3), 3)  # noqa: E731
    elif mode == "depth_maps":
        maps = [render_depth(mesh, c2w, CAM, 1) for c2w in P]
        for dm in maps[::3]:
            dm[rng.random(dm.shape) < 0.2] = 0.0  # holes: no measurement, which does not occlude
        kw = {"depth_maps": maps}
        depth_of = lambda k, c2w: (maps[k], 1)  # noqa: E731
    want = reference(points, P, depth_of)
    got = visible_points(points, P, CAM, eps_m=0.03, native=native, **kw)
    assert want.sum() > 500 and (~want).sum() > 500  # the case tests something: many seen, many not
    np.testing.assert_array_equal(got, want)


@pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
def test_native_kernel_gives_the_same_mask_on_any_thread_count(monkeypatch):
    rng = np.random.default_rng(3)
    mesh = room()
    points, P = mesh.sample(20000, seed=2), poses(rng, 30)
    masks = []
    for n in (1, 2, 3):
        monkeypatch.setattr(_native, "nthreads", lambda n=n: n)
        masks.append(visible_points(points, P, CAM, occluder=mesh, native=True))
    assert masks[0].any() and not masks[0].all()
    for m in masks[1:]:
        np.testing.assert_array_equal(m, masks[0])


def test_shared_depth_images_are_rendered_once_and_bounded():
    rng = np.random.default_rng(5)
    mesh = room()
    P = poses(rng, 6)
    depths = OccluderDepths(mesh, CAM, stride=2)
    first = [depths(c2w) for c2w in P]
    assert all(depths(c2w) is img for c2w, img in zip(P, first))  # kept, not re-rendered
    np.testing.assert_array_equal(first[0], render_depth(mesh, P[0], CAM, 2))
    small = OccluderDepths(mesh, CAM, stride=2, max_bytes=first[0].nbytes)
    a, b = small(P[0]), small(P[1])
    assert small(P[0]) is a and small(P[1]) is not b  # the second image did not fit
    np.testing.assert_array_equal(small(P[1]), b)


def test_max_edge_length_is_the_longest_edge():
    mesh = room()
    assert max_edge_length(mesh) == pytest.approx(float(mesh.edges_unique_length.max()), rel=1e-12)
    assert max_edge_length(trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))) == 0.0


def test_evaluator_culls_the_ground_truth_incrementally_as_from_scratch():
    """Evaluations at growing times (poses added, and in a different order) give the ground truth
    culled with all poses at once; fewer poses than before start again."""
    from types import SimpleNamespace

    from ramensim.scoring import Evaluator
    from ramensim.evaluation.config import EvalConfig

    rng = np.random.default_rng(11)
    mesh = room()
    world = SimpleNamespace(scene=SimpleNamespace(mesh=mesh), n_agents=2,
                            intrinsics=SimpleNamespace(fx=CAM.fx, fy=CAM.fy, cx=CAM.cx, cy=CAM.cy,
                                                       width=CAM.width, height=CAM.height))
    cfg = EvalConfig(cull="frustum_occlusion", near_m=CAM.near_m, far_m=CAM.far_m, cull_max_edge_m=0.5)
    ev = Evaluator(cfg, world)  # type: ignore[arg-type]
    a, b = poses(rng, 12), poses(rng, 12)

    def scratch(P):
        return cull_to_views(mesh, P, ev.camera, occluder=mesh, eps_m=cfg.occlusion_eps_m,
                             stride=cfg.occlusion_stride_px, max_edge_m=cfg.cull_max_edge_m)

    for P in (np.concatenate([a[:4], b[:4]]), np.concatenate([a[:8], b[:8]]), np.concatenate([a, b]), a[:3]):
        got, want = ev._culled_gt(P), scratch(P)
        np.testing.assert_array_equal(got.faces, want.faces)
        np.testing.assert_array_equal(got.vertices, want.vertices)


def test_kernel_source_is_package_data():
    """pyproject.toml ships csrc/*.c with ramensim.evaluation (a non-editable install has it)."""
    import fnmatch
    import tomllib
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    cfg = tomllib.loads((repo / "pyproject.toml").read_text())["tool"]["setuptools"]
    rel = _native.SOURCE.relative_to((repo / cfg["package-dir"]["ramensim.evaluation"]).resolve()).as_posix()
    assert any(fnmatch.fnmatch(rel, p) for p in cfg["package-data"]["ramensim.evaluation"])


@pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
def test_kernel_compiles_without_warnings(tmp_path):
    import subprocess

    from ramensim.core.native import BASE_FLAGS

    flags = [f for f in BASE_FLAGS if f not in ("-shared", "-fPIC", "-g")]
    res = subprocess.run([*compiler(), *flags, "-Werror", "-c", str(_native.SOURCE), "-o", str(tmp_path / "x.o")],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr


def test_without_the_kernel_the_numpy_path_is_used(monkeypatch):
    monkeypatch.setattr(_native, "get_lib", lambda: None)
    mesh = room()
    P = poses(np.random.default_rng(1), 5)
    pts = mesh.sample(3000, seed=4)
    want = reference(pts, P, lambda k, c2w: (render_depth(mesh, c2w, CAM, 4), 4))
    np.testing.assert_array_equal(visible_points(pts, P, CAM, occluder=mesh), want)
    with pytest.raises(RuntimeError, match="native visibility kernel is unavailable"):
        visible_points(pts, P, CAM, native=True)


@pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
@pytest.mark.parametrize("size_m", [0.05, 0.25, 2.0])
def test_clustered_kernel_gives_the_per_point_kernels_mask_at_the_frustum_edges(size_m):
    """The kernel skips a pose for a whole cluster of points only when the cluster lies outside
    its frustum: points placed on the rays through the image's border pixels (u or v within
    1e-12 .. 1e-2 px of 0 or of the width/height, on both sides), non-finite points and
    points behind the camera get the per-point kernel's mask, whatever the cluster size."""
    rng = np.random.default_rng(11)
    mesh = room()
    P = poses(rng, 16)
    pts = [mesh.sample(3000, seed=3), rng.uniform(-3.5, 3.5, size=(1000, 3)),
           np.array([[np.nan, 0.0, 0.0], [np.inf, 1.0, 1.0], [0.0, -np.inf, 0.0]])]
    for c2w in P[:6]:
        n = 400
        offs = rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-12, -2, n)
        edge = rng.integers(0, 4, n)
        t = rng.uniform(0, 1, n)
        u = np.where(edge == 0, offs, np.where(edge == 1, CAM.width + offs, t * CAM.width))
        v = np.where(edge == 2, offs, np.where(edge == 3, CAM.height + offs, t * CAM.height))
        z = rng.uniform(-1.0, 5.0, n)  # some behind the camera
        cam_pts = np.stack([(u - CAM.cx) / CAM.fx * z, (v - CAM.cy) / CAM.fy * z, z], axis=1)
        pts.append(cam_pts @ c2w[:3, :3].T + c2w[:3, 3])
    points = np.concatenate(pts)
    got = visible_points(points, P, CAM, occluder=mesh, native=True, cluster_m=size_m)
    per_point = visible_points(points, P, CAM, occluder=mesh, native=True, cluster_m=0)
    assert 0 < got.sum() < len(points) - 1000
    np.testing.assert_array_equal(got, per_point)
    np.testing.assert_array_equal(got, reference(points, P, lambda k, c2w: (render_depth(mesh, c2w, CAM, 4), 4)))

