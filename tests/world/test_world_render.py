"""RGB-D rendering: Embree backend, depth = camera z on the mesh, colours, sensor model."""
import numpy as np
import pytest
import trimesh
from trimesh.ray.ray_pyembree import RayMeshIntersector

from ramensim.core.frames import Intrinsics
from ramensim.world.camera import RGBDCamera, pixel_rays
from ramensim.world.config import SensorConfig
from ramensim.world.scenes import builtin_scene
from ramensim.world.trajectories import look_rotation

K = Intrinsics(60.0, 60.0, 39.5, 29.5, 80, 60)


def _plane(z=2.0, color=None, vertex_colors=None):
    v = np.array([[-10, -10, z], [10, -10, z], [10, 10, z], [-10, 10, z]], float)
    m = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)
    if color is not None:
        m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(color, (2, 1)))
    if vertex_colors is not None:
        m.visual = trimesh.visual.ColorVisuals(m, vertex_colors=vertex_colors)
    return m


def test_embree_backend_is_used():
    assert trimesh.ray.has_embree
    cam = RGBDCamera(_plane(), K)
    assert isinstance(cam.caster.intersector, RayMeshIntersector)
    assert cam.backend == "embree"


def test_depth_is_camera_z_not_ray_length():
    cam = RGBDCamera(_plane(2.0, color=[255, 0, 0, 255]), K)
    f = cam.render(np.eye(4))
    assert np.allclose(f.depth, 2.0, atol=1e-5)  # corners too: z, not range
    assert np.allclose(f.rgb, [1.0, 0.0, 0.0], atol=1e-6)
    assert f.rgb.dtype == np.float32 and f.depth.dtype == np.float32 and f.rgb.shape == (60, 80, 3)


def test_vertex_colours_are_interpolated():
    vc = np.array([[0, 0, 0, 255], [255, 0, 0, 255], [255, 0, 0, 255], [0, 0, 0, 255]], np.uint8)
    cam = RGBDCamera(_plane(1.0, vertex_colors=vc), Intrinsics(1.0, 1.0, 0.0, 0.0, 1, 1))
    # the one pixel looks straight down +z at x = 0: halfway between x = -10 (black) and 10 (red)
    f = cam.render(np.eye(4))
    assert f.rgb[0, 0, 0] == pytest.approx(0.5, abs=0.01)


def test_backprojected_depth_lies_on_the_mesh():
    scene = builtin_scene("office", 0)
    cam = RGBDCamera(scene.mesh, K)
    c2w = np.eye(4)
    c2w[:3, :3] = look_rotation(np.array([1.0, 0.3, 0.0]), np.deg2rad(-15))
    c2w[:3, 3] = [1.5, 2.5, 1.4]
    f = cam.render(c2w)
    rng = np.random.default_rng(3)
    valid = np.argwhere(f.depth > 0)
    assert len(valid) == K.width * K.height  # closed room: every ray hits
    pick = valid[rng.choice(len(valid), 60, replace=False)]
    rays = pixel_rays(K).reshape(K.height, K.width, 3)[pick[:, 0], pick[:, 1]]
    pts = (rays * f.depth[pick[:, 0], pick[:, 1], None]) @ c2w[:3, :3].T + c2w[:3, 3]
    tris = scene.mesh.triangles
    for p in pts:
        closest = trimesh.triangles.closest_point(tris, np.repeat(p[None], len(tris), 0))
        assert np.linalg.norm(closest - p, axis=1).min() < 1e-3


def test_sensor_model_is_seeded_and_applies_range():
    s = SensorConfig(depth_noise_a=0.01, depth_noise_b=0.002, missing_fraction=0.2, max_range=3.0)
    cam = RGBDCamera(_plane(2.0, color=[0, 255, 0, 255]), K, s)
    a = cam.render(np.eye(4), rng=np.random.default_rng(5))
    b = cam.render(np.eye(4), rng=np.random.default_rng(5))
    c = cam.render(np.eye(4), rng=np.random.default_rng(6))
    assert np.array_equal(a.depth, b.depth) and not np.array_equal(a.depth, c.depth)
    assert 0.15 < np.mean(a.depth == 0) < 0.25
    ok = a.depth[a.depth > 0]
    assert abs(ok.std() - (0.01 + 0.002 * 4)) < 0.003
    far = RGBDCamera(_plane(4.0, color=[0, 255, 0, 255]), K, SensorConfig(max_range=3.0)).render(
        np.eye(4), rng=np.random.default_rng(0))
    assert np.all(far.depth == 0)
    with pytest.raises(ValueError):
        cam.render(np.eye(4))  # a sensor model needs a generator
