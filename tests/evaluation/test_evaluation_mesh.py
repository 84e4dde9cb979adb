"""Mesh extraction from analytic SDFs (marching cubes on a uniform grid, paper section V)."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from ramensim.evaluation.mesh import export_ply, extract_mesh, grid_shape, load_mesh

R = 0.3
C = np.array([0.05, -0.02, 0.01])
BOUNDS = np.array([[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]])
VOXEL = 0.05


def sphere_sdf(p):
    return np.linalg.norm(p - C, axis=1) - R


def box_sdf(p, half=np.array([0.2, 0.15, 0.1])):
    q = np.abs(p) - half
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def rgb_of(p):
    return np.clip(p + 0.5, 0.0, 1.0)  # x, y, z in [-0.5, 0.5] -> rgb


def test_grid_shape_covers_bounds():
    assert grid_shape(BOUNDS, 0.05) == (21, 21, 21)
    assert grid_shape(np.array([[0, 0, 0], [6.0, 5.0, 3.0]]), 0.02) == (301, 251, 151)


def test_sphere_vertices_lie_on_surface_and_colours_follow_color_fn():
    m = extract_mesh(sphere_sdf, BOUNDS, VOXEL, color_fn=rgb_of, chunk=1000)
    assert len(m.faces) > 100
    err = np.abs(np.linalg.norm(m.vertices - C, axis=1) - R)
    assert err.max() <= VOXEL / 2
    assert m.is_watertight
    assert m.volume > 0  # outward normals
    assert m.volume == pytest.approx(4 / 3 * np.pi * R**3, rel=0.05)
    expected = np.rint(rgb_of(m.vertices) * 255).astype(np.uint8)
    assert np.abs(m.visual.vertex_colors[:, :3].astype(int) - expected).max() <= 1


def test_box_vertices_lie_on_surface():
    m = extract_mesh(box_sdf, BOUNDS, 0.02)
    assert np.abs(box_sdf(m.vertices)).max() <= 0.02 / 2
    lo, hi = m.bounds
    assert np.allclose(hi, [0.2, 0.15, 0.1], atol=0.01) and np.allclose(lo, [-0.2, -0.15, -0.1], atol=0.01)


def test_chunk_size_does_not_change_the_mesh():
    a = extract_mesh(sphere_sdf, BOUNDS, VOXEL, chunk=997)
    b = extract_mesh(sphere_sdf, BOUNDS, VOXEL, chunk=1_000_000)
    assert np.array_equal(a.faces, b.faces) and np.allclose(a.vertices, b.vertices)


def test_grid_fn_gives_the_same_mesh_and_a_wrong_shape_is_named():
    def grid(origin, voxel, shape):
        ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
        return sphere_sdf((origin + ijk * voxel).astype(np.float32)).reshape(shape)

    a = extract_mesh(sphere_sdf, BOUNDS, VOXEL, color_fn=rgb_of, grid_fn=grid)
    b = extract_mesh(sphere_sdf, BOUNDS, VOXEL, color_fn=rgb_of)
    assert len(a.faces) and np.array_equal(a.faces, b.faces) and np.array_equal(a.vertices, b.vertices)
    with pytest.raises(ValueError, match=r"grid_fn returned shape \(2, 2\); expected the grid's"):
        extract_mesh(sphere_sdf, BOUNDS, VOXEL, grid_fn=lambda o, v, s: np.zeros((2, 2)))


def test_torch_like_outputs_are_accepted():
    torch = pytest.importorskip("torch")
    m = extract_mesh(lambda p: torch.from_numpy(sphere_sdf(p)).requires_grad_(), BOUNDS, VOXEL)
    assert len(m.faces) > 100


def test_no_zero_crossing_gives_empty_mesh():
    m = extract_mesh(lambda p: np.ones(len(p)), BOUNDS, VOXEL)
    assert len(m.faces) == 0 and len(m.vertices) == 0
    m = extract_mesh(lambda p: -np.ones(len(p)), BOUNDS, VOXEL, color_fn=rgb_of)
    assert len(m.faces) == 0


def test_mask_removes_faces_of_unobserved_cells():
    full = extract_mesh(sphere_sdf, BOUNDS, VOXEL)
    half = extract_mesh(sphere_sdf, BOUNDS, VOXEL, mask_fn=lambda p: p[:, 0] >= 0.0)
    assert 0 < len(half.faces) < len(full.faces)
    assert half.vertices[:, 0].min() >= -1e-9  # no face in a cell with an unobserved corner
    assert half.vertices[:, 0].max() == pytest.approx(full.vertices[:, 0].max())
    none = extract_mesh(sphere_sdf, BOUNDS, VOXEL, mask_fn=lambda p: np.zeros(len(p), bool))
    assert len(none.faces) == 0


def test_non_finite_sdf_values_are_masked_not_fatal():
    def sdf(p):
        d = sphere_sdf(p)
        d[p[:, 0] < -0.1] = np.nan
        return d
    m = extract_mesh(sdf, BOUNDS, VOXEL)
    assert len(m.faces) > 0 and np.isfinite(m.vertices).all()
    assert m.vertices[:, 0].min() >= -0.1 - 1e-9


def test_bad_bounds_and_voxel_raise_clear_errors():
    with pytest.raises(ValueError, match="bounds"):
        extract_mesh(sphere_sdf, [[0, 0, 0], [0, 1, 1]], VOXEL)
    with pytest.raises(ValueError, match="voxel_m"):
        extract_mesh(sphere_sdf, BOUNDS, 0.0)
    with pytest.raises(ValueError, match="one value per point"):
        extract_mesh(lambda p: np.zeros(3), BOUNDS, VOXEL)


def test_ply_round_trip_keeps_geometry_and_colours(tmp_path):
    m = extract_mesh(sphere_sdf, BOUNDS, VOXEL, color_fn=rgb_of)
    path = export_ply(m, tmp_path / "sub" / "sphere.ply")
    back = load_mesh(path)
    assert np.allclose(back.vertices, m.vertices) and np.array_equal(back.faces, m.faces)
    assert np.array_equal(back.visual.vertex_colors, m.visual.vertex_colors)


def test_load_mesh_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        load_mesh(tmp_path / "nope.ply")
    junk = tmp_path / "junk.ply"
    junk.write_bytes(b"this is not a ply file\n")
    with pytest.raises(ValueError, match="junk.ply"):
        load_mesh(junk)
    cloud = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).random((10, 3))).export(cloud)
    with pytest.raises(ValueError, match="cloud.ply"):
        load_mesh(cloud)
