"""Culling to what the cameras saw: frustum and occlusion (NICE-SLAM protocol)."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from ramensim.evaluation.cull import (PinholeCamera, cull_mesh, cull_to_views, load_poses, render_depth,
                             visible_points)

CAM = PinholeCamera(fx=100.0, fy=100.0, cx=50.0, cy=50.0, width=100, height=100)
EYE = np.eye(4)  # at the origin, looking down +z (OpenCV axes); sees |x|, |y| < z / 2


def grid_plane(z: float, half: float, n: int = 20, x0: float = 0.0) -> trimesh.Trimesh:
    """An n x n quad grid (2 triangles per quad) in the plane z, |x - x0|, |y| <= half (m)."""
    g = np.linspace(-half, half, n + 1)
    xx, yy = np.meshgrid(g + x0, g, indexing="ij")
    verts = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, z)], axis=1)
    idx = np.arange(xx.size).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return trimesh.Trimesh(verts, faces, process=False)


def test_frustum_keeps_what_is_seen_and_drops_what_is_behind():
    pts = np.array([[0, 0, 2.0], [0.9, 0.9, 2.0], [0, 0, -2.0], [1.5, 0, 2.0], [0, -1.2, 2.0]])
    assert visible_points(pts, EYE[None], CAM).tolist() == [True, True, False, False, False]


def test_near_far_planes():
    cam = PinholeCamera(100, 100, 50, 50, 100, 100, near_m=1.0, far_m=3.0)
    pts = np.array([[0, 0, 0.5], [0, 0, 2.0], [0, 0, 4.0]])
    assert visible_points(pts, EYE, cam).tolist() == [False, True, False]


def test_union_over_poses():
    turned = np.eye(4)
    turned[:3, :3] = np.diag([-1.0, 1.0, -1.0])  # rotated 180 deg about y: looks down -z
    pts = np.array([[0, 0, 2.0], [0, 0, -2.0]])
    assert visible_points(pts, EYE[None], CAM).tolist() == [True, False]
    assert visible_points(pts, np.stack([EYE, turned]), CAM).tolist() == [True, True]


def test_cull_mesh_drops_faces_whose_vertices_are_all_unseen():
    wide = grid_plane(z=2.0, half=3.0, n=30)  # 0.2 m cells, camera sees |x|, |y| < 1
    out = cull_to_views(wide, EYE[None], CAM)
    assert 0 < len(out.faces) < len(wide.faces)
    assert out.vertices[:, 0].max() <= 1.0 + 0.2 + 1e-9 and out.vertices[:, 0].min() >= -1.2 - 1e-9
    assert len(out.vertices) == len(np.unique(out.faces))  # unreferenced vertices removed
    behind = grid_plane(z=-2.0, half=1.0)
    assert len(cull_to_views(behind, EYE[None], CAM).faces) == 0
    assert len(wide.faces) == 1800  # the input is untouched


def test_cull_mesh_rule_any_vertex_seen_keeps_the_face():
    tri = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)
    assert len(cull_mesh(tri, np.array([False, True, False])).faces) == 1
    assert len(cull_mesh(tri, np.array([False, False, False])).faces) == 0


def test_render_depth_of_a_wall():
    wall = grid_plane(z=1.5, half=2.0, n=4)
    d = render_depth(wall, EYE, CAM, stride=10)
    assert d.shape == (10, 10)
    assert np.allclose(d, 1.5)  # z-depth, not ray length
    d = render_depth(grid_plane(z=1.5, half=0.1, n=2), EYE, CAM, stride=10)
    assert np.isinf(d[0, 0]) and np.isclose(d[5, 5], 1.5)


def test_occlusion_drops_what_a_wall_hides():
    wall = grid_plane(z=1.0, half=0.3, n=6)  # hides |x|, |y| < 0.6 at z = 2
    hidden = grid_plane(z=2.0, half=0.3, n=6)
    side = grid_plane(z=2.0, half=0.2, n=4, x0=0.8)  # visible past the wall's edge
    gt = trimesh.util.concatenate([wall, hidden, side])
    assert len(cull_to_views(hidden, EYE[None], CAM).faces) == len(hidden.faces)  # frustum only
    assert len(cull_to_views(hidden, EYE[None], CAM, occluder=gt, stride=2).faces) == 0
    assert len(cull_to_views(side, EYE[None], CAM, occluder=gt, stride=2).faces) == len(side.faces)
    assert len(cull_to_views(wall, EYE[None], CAM, occluder=gt, stride=2).faces) == len(wall.faces)


def test_occlusion_from_given_depth_maps():
    pts = np.array([[0, 0, 0.5], [0, 0, 1.02], [0, 0, 2.0]])
    depth = np.full((1, 100, 100), 1.0)
    assert visible_points(pts, EYE[None], CAM, depth_maps=depth, eps_m=0.03).tolist() == [True, True, False]
    depth[:] = 0.0  # no measurement: does not occlude
    assert visible_points(pts, EYE[None], CAM, depth_maps=depth).tolist() == [True, True, True]
    with pytest.raises(ValueError, match="one per pose"):
        visible_points(pts, np.stack([EYE, EYE]), CAM, depth_maps=depth)


def test_load_poses_text_and_npy(tmp_path):
    a = np.eye(4)
    b = np.eye(4)
    b[:3, 3] = (1.0, 2.0, 3.0)
    txt = tmp_path / "poses.txt"
    txt.write_text("# c2w\n" + " ".join(map(str, a.ravel())) + "\n\n"
                   + ", ".join(map(str, b.ravel())) + "\n" + " ".join(["inf"] * 16) + "\n")
    poses = load_poses(txt)
    assert poses.shape == (2, 4, 4) and np.allclose(poses[1], b)
    npy = tmp_path / "poses.npy"
    np.save(npy, np.stack([a, b]))
    assert np.allclose(load_poses(npy), np.stack([a, b]))


def test_load_poses_errors_name_file_and_line(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        load_poses(tmp_path / "missing.txt")
    bad = tmp_path / "bad.txt"
    bad.write_text(" ".join(["1"] * 16) + "\n1 2 3\n")
    with pytest.raises(ValueError, match=r"bad.txt, line 2: found 3 values"):
        load_poses(bad)
    bad.write_text("1 2 x\n")
    with pytest.raises(ValueError, match="line 1"):
        load_poses(bad)
    npy = tmp_path / "bad.npy"
    np.save(npy, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"\(3, 3\)"):
        load_poses(npy)


def test_camera_validation():
    with pytest.raises(ValueError, match="fx"):
        PinholeCamera(fx=0.0, fy=1.0, cx=0.0, cy=0.0, width=10, height=10)
    with pytest.raises(ValueError, match="near_m"):
        PinholeCamera(1.0, 1.0, 0.0, 0.0, 10, 10, near_m=2.0, far_m=1.0)


@pytest.mark.parametrize("colours", ["vertex", "face", "none"])
def test_cull_mesh_gives_trimeshs_own_result(colours):
    """cull_mesh builds the culled mesh from arrays: the same vertices (in order), faces and
    colours as trimesh's copy + update_faces + remove_unreferenced_vertices."""
    rng = np.random.default_rng(2)
    base = grid_plane(z=1.0, half=0.5, n=30)
    kw = {}
    if colours == "vertex":
        kw["vertex_colors"] = rng.integers(0, 255, (len(base.vertices), 4), dtype=np.uint8)
    elif colours == "face":
        kw["face_colors"] = rng.integers(0, 255, (len(base.faces), 4), dtype=np.uint8)
    mesh = trimesh.Trimesh(base.vertices, base.faces, process=False, **kw)
    seen = rng.random(len(mesh.vertices)) < 0.2
    got = cull_mesh(mesh, seen)
    want = mesh.copy()
    want.update_faces(seen[want.faces].any(axis=1))
    want.remove_unreferenced_vertices()
    assert 0 < len(got.faces) < len(mesh.faces)
    np.testing.assert_array_equal(got.vertices, want.vertices)
    np.testing.assert_array_equal(got.faces, want.faces)
    if colours != "none":
        attr = f"{colours}_colors"
        np.testing.assert_array_equal(getattr(got.visual, attr), getattr(want.visual, attr))
