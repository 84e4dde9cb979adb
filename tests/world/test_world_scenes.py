"""Built-in scenes, mesh files as scenes, export."""
import numpy as np
import pytest
import trimesh

from ramensim.core.errors import InputError
from ramensim.world.camera import MeshRayCaster
from ramensim.world.config import BUILTIN_SCENES
from ramensim.world.scenes import builtin_scene, load_mesh_scene


@pytest.mark.parametrize("name", BUILTIN_SCENES)
def test_builtin_scene_size_and_closed(name):
    s = builtin_scene(name, 0)
    ext = s.bounds[1] - s.bounds[0]
    lo, hi = {"pretrain_room": (4.0, 8.6), "house": (11.0, 14.0), "warehouse": (9.0, 11.5)}.get(name, (5.0, 8.6))
    top = 3.8 if name == "warehouse" else 3.3  # a hall of 3.0-3.3 m, higher than the rooms
    assert lo <= max(ext[:2]) <= hi and 2.5 <= ext[2] <= top
    assert np.all(s.bounds[0] < s.mesh.bounds[0]) and np.all(s.bounds[1] > s.mesh.bounds[1])
    assert s.mesh.visual.kind == "vertex" and len(np.unique(s.mesh.visual.vertex_colors[:, :3], axis=0)) > 50
    # closed room: rays from the middle at 1.4 m in every direction hit something within the bounds
    rng = np.random.default_rng(0)
    d = rng.normal(size=(2000, 3))
    o = np.array([[*(0.5 * (s.bounds[0, :2] + s.bounds[1, :2])), 1.4]])
    dist, tri, _, _ = MeshRayCaster(s.mesh).cast(o, d / np.linalg.norm(d, axis=1, keepdims=True))
    assert np.all(tri >= 0) and np.all(dist < np.linalg.norm(ext))


def test_builtin_scene_is_deterministic():
    a, b, c = builtin_scene("apartment", 3), builtin_scene("apartment", 3), builtin_scene("apartment", 4)
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert np.array_equal(a.mesh.visual.vertex_colors, b.mesh.visual.vertex_colors)
    assert a.mesh.vertices.shape != c.mesh.vertices.shape or not np.allclose(a.mesh.vertices, c.mesh.vertices)


def test_unknown_builtin_name():
    with pytest.raises(InputError, match="kitchen"):
        builtin_scene("kitchen")


def test_export_and_reload_keeps_colours(tmp_path):
    s = builtin_scene("living_room", 1)
    p = s.export(tmp_path / "lr.ply")
    r = load_mesh_scene(p)
    assert len(r.mesh.faces) == len(s.mesh.faces)
    assert np.array_equal(r.mesh.visual.vertex_colors, s.mesh.visual.vertex_colors)
    assert np.allclose(r.bounds, s.bounds)


def test_mesh_without_colours_gets_default(tmp_path):
    m = trimesh.creation.box(extents=[2, 3, 1])
    p = tmp_path / "box.obj"
    m.export(p)
    s = load_mesh_scene(p, default_color=(0.2, 0.4, 0.6), bounds=[[-2, -2, -2], [2, 2, 2]])
    assert np.allclose(s.mesh.visual.vertex_colors[0, :3], [51, 102, 153])
    assert np.allclose(s.bounds, [[-2, -2, -2], [2, 2, 2]])


def test_face_coloured_mesh_renders_face_colour(tmp_path):
    m = trimesh.creation.box(extents=[4, 4, 4])
    m.invert()  # inside-out: seen from the middle
    m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile([10, 200, 30, 255], (len(m.faces), 1)))
    p = tmp_path / "face.ply"
    m.export(p)
    from ramensim.core.frames import Intrinsics
    from ramensim.world.camera import RGBDCamera

    s = load_mesh_scene(p)
    f = RGBDCamera(s.mesh, Intrinsics(10, 10, 4.5, 4.5, 10, 10)).render(np.eye(4))
    assert np.allclose(f.rgb.reshape(-1, 3).mean(0), np.array([10, 200, 30]) / 255, atol=0.01)


def test_bad_mesh_files(tmp_path):
    with pytest.raises(InputError, match="missing.ply"):
        load_mesh_scene(tmp_path / "missing.ply")
    cloud = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).normal(size=(10, 3))).export(cloud)
    with pytest.raises(InputError, match="cloud.ply"):
        load_mesh_scene(cloud)
    junk = tmp_path / "junk.ply"
    junk.write_bytes(b"ply\nformat nonsense\n")
    with pytest.raises(InputError, match="junk.ply"):
        load_mesh_scene(junk)
