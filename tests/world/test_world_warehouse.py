"""The built-in warehouse (world/scenes/warehouse.py), a scene family of another kind than the
house: layouts that vary with the seed and repeat with it, a closed hall, every seed 0-7 built
and toured, the tour of split 'chunks' clear of the racks and through every aisle, the scenario
file, and one tiny run end to end."""
import math

import numpy as np
import pytest

from ramensim.config import load_scenario
from ramensim.core.frames import Intrinsics
from ramensim.core.seeding import Seeds
from ramensim.world import build_world
from ramensim.world.camera import MeshRayCaster, RGBDCamera
from ramensim.world.config import BUILTIN_SCENES, ProceduralTrajectoryConfig
from ramensim.world.scenes import builtin_scene, get_scene, scene_names, warehouse_layout
from ramensim.world.scenes.warehouse import PALLET, WAREHOUSE_AISLE_W, WAREHOUSE_LENGTH
from ramensim.world.trajectories import FreeSpace, chunk_tour, procedural_trajectories
from ramensim.world.trajectories.tour import TOUR_ROOMS

CHUNKS = ProceduralTrajectoryConfig(split="chunks")
SCENARIO = "scenarios/warehouse_3agents.yaml"
SEEDS = range(8)


@pytest.fixture(scope="module")
def warehouse():
    scene = builtin_scene("warehouse", 0)
    caster = MeshRayCaster(scene.mesh)
    return scene, caster, warehouse_layout(0), FreeSpace(caster, scene.bounds, CHUNKS.height)


def _overlap(a, b) -> bool:
    return a[0] < b[2] - 1e-9 and b[0] < a[2] - 1e-9 and a[1] < b[3] - 1e-9 and b[1] < a[3] - 1e-9


def _rect_distance(xy: np.ndarray, rect) -> np.ndarray:
    """Distance (m) from points (N, 2) to the rectangle (x0, y0, x1, y1); 0 inside."""
    dx = np.maximum(np.maximum(rect[0] - xy[:, 0], xy[:, 0] - rect[2]), 0.0)
    dy = np.maximum(np.maximum(rect[1] - xy[:, 1], xy[:, 1] - rect[3]), 0.0)
    return np.hypot(dx, dy)


def _in_rect(xy: np.ndarray, rect) -> np.ndarray:
    return (xy[:, 0] > rect[0]) & (xy[:, 0] < rect[2]) & (xy[:, 1] > rect[1]) & (xy[:, 1] < rect[3])


# ----------------------------------------------------------------------------- the scene
def test_warehouse_is_registered_like_the_house():
    assert "warehouse" in scene_names() and "warehouse" in BUILTIN_SCENES
    assert get_scene("warehouse").evaluation
    sc = load_scenario(SCENARIO, ["duration=2"])
    assert sc.world.scene.name == "warehouse" and sc.agents.count == 3 and sc.world.trajectory.split == "chunks"


def test_warehouse_is_deterministic_and_varies_with_the_seed():
    a, b, c = builtin_scene("warehouse", 3), builtin_scene("warehouse", 3), builtin_scene("warehouse", 4)
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.mesh.visual.vertex_colors, b.mesh.visual.vertex_colors)
    assert a.mesh.vertices.shape != c.mesh.vertices.shape or not np.allclose(a.mesh.vertices, c.mesh.vertices)
    assert warehouse_layout(3) == warehouse_layout(3) != warehouse_layout(4)
    lays = [warehouse_layout(s) for s in SEEDS]
    assert len({lay.size for lay in lays}) == len(lays)  # every seed its own hall
    assert {len(lay.aisles) for lay in lays} == {3, 4}  # the grid itself changes, not only its sizes
    assert len({len(lay.cross) for lay in lays}) >= 2 and len({len(lay.decks) for lay in lays}) == 2


@pytest.mark.parametrize("seed", SEEDS)
def test_every_seed_builds_a_consistent_hall_of_the_houses_size(seed):
    """For seeds 0-7: the layout is consistent (racks and aisles inside the hall, never on each
    other, walkable widths), and the mesh is about the house's size (bounds and triangles within
    1.5x of the house of the same seed), so evaluating it costs about as much."""
    lay = warehouse_layout(seed)
    lx, ly = lay.size
    assert WAREHOUSE_LENGTH[0] <= lx <= WAREHOUSE_LENGTH[1] and 7.0 <= ly <= 11.0 and 3.0 <= lay.height <= 3.3
    free = list(lay.aisles) + list(lay.cross)
    for r in lay.racks:
        assert 0.0 <= r.rect[0] < r.rect[2] <= lx and 0.0 <= r.rect[1] < r.rect[3] <= ly and r.bays >= 1
        assert not any(_overlap(r.rect, a.rect) for a in free)
        assert not any(_overlap(r.rect, q.rect) for q in lay.racks if q is not r)
    n = len(lay.aisles)
    for a in lay.aisles:
        assert WAREHOUSE_AISLE_W[n][0] - 1e-9 <= a.rect[3] - a.rect[1] <= WAREHOUSE_AISLE_W[n][1] + 1e-9
    assert all(c.rect[2] - c.rect[0] >= 1.1 for c in lay.cross[1:])
    staging = lay.cross[0].rect
    assert staging[0] == 0.0 and staging[2] - PALLET[0] - 0.1 >= 1.4  # a walkway beside the pallets
    for p in lay.pallets:
        assert _in_rect(np.array([[0.5 * (p[0] + p[2]), 0.5 * (p[1] + p[3])]]), staging)[0]
        assert p[3] <= lay.door[0] or p[1] >= lay.door[1]  # the dock door stays clear
    assert lay.decks[-1] < lay.height - 0.6
    scene, house = builtin_scene("warehouse", seed), builtin_scene("house", seed)
    vol = float(np.prod(scene.bounds[1] - scene.bounds[0]))
    house_vol = float(np.prod(house.bounds[1] - house.bounds[0]))
    assert house_vol / 1.5 <= vol <= 1.5 * house_vol
    assert len(house.mesh.faces) / 3 <= len(scene.mesh.faces) <= 1.5 * len(house.mesh.faces)
    assert np.all(scene.bounds[0] < scene.mesh.bounds[0]) and np.all(scene.bounds[1] > scene.mesh.bounds[1])
    assert len(np.unique(scene.mesh.visual.vertex_colors[:, :3], axis=0)) > 200  # goods of many colours


def test_warehouse_is_closed_and_its_depths_are_in_range(warehouse):
    """Every ray hits something: random rays from every aisle, and the camera's pixels along the
    robots' trajectories (no pixel without a depth, and all but a few within the default
    sensor's 10 m)."""
    scene, caster, lay, _ = warehouse
    rng = np.random.default_rng(0)
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    diag = float(np.linalg.norm(scene.bounds[1] - scene.bounds[0]))
    for a in list(lay.aisles) + list(lay.cross):
        dist, tri, _, _ = caster.cast(np.array([[*a.centre, 1.4]]), d)
        assert np.all(tri >= 0) and np.all(dist < diag)
    cam = RGBDCamera(scene.mesh, Intrinsics(40, 40, 39.5, 29.5, 80, 60), threads=1)
    trajs = procedural_trajectories(caster, scene.bounds, 3, 40.0, CHUNKS, np.random.default_rng(5))
    far = []
    for tr in trajs:
        for c2w in tr.poses_at(np.arange(0.0, 40.0, 4.0)):
            _, depth = cam.render_arrays(c2w)
            assert np.all(depth > 0)
            far.append(float((depth > 10.0).mean()))
    assert np.mean(far) < 0.01 and np.max(far) < 0.05


def test_racks_are_solid_and_aisles_free(warehouse):
    """At camera height the aisles are free floor and the racks are not: the robots walk in the
    aisles and around the racks, never through them, and every aisle is one walkable space."""
    scene, caster, lay, fs = warehouse
    from scipy import ndimage

    J, I = np.indices(fs.shape)
    xy = fs.centre(J, I).reshape(-1, 2)
    free = fs.free.ravel()
    lab, _ = ndimage.label(fs.free, structure=np.ones((3, 3)))
    labels = set()
    for a in lay.aisles:
        inside = _in_rect(xy, (a.rect[0] + 0.1, a.rect[1] + 0.1, a.rect[2] - 0.1, a.rect[3] - 0.1))
        assert free[inside].mean() > 0.98
        labels.add(int(np.bincount(lab.ravel()[inside & free]).argmax()))
    assert len(labels) == 1
    for r in lay.racks:
        inside = _in_rect(xy, (r.rect[0] + 0.1, r.rect[1] + 0.05, r.rect[2] - 0.1, r.rect[3] - 0.05))
        assert not free[inside].any()


# ----------------------------------------------------------------------------- split 'chunks'
def _aisle_walked(path: np.ndarray, aisle) -> float:
    """Fraction of the aisle's length (along x, in 25 cm bins) that the path walks."""
    x0, _, x1, _ = aisle.rect
    p = path[_in_rect(path, aisle.rect)]
    return len(np.unique(((p[:, 0] - x0) // 0.25).astype(int))) * 0.25 / (x1 - x0)


@pytest.mark.parametrize("seed", SEEDS)
def test_every_seed_has_a_tour_through_every_aisle_clear_of_the_racks(seed):
    """The tour of split 'chunks' takes the aisles the mesh declares as its rooms and walks them
    one after the other (from one side of the hall to the other), most of each one's length
    (a dead-end aisle at least a quarter: it walks in and out), and keeps 0.25 m from every
    rack and pallet (measured on the layout, not on the free-space grid it was planned on)."""
    scene = builtin_scene("warehouse", seed)
    lay = warehouse_layout(seed)
    assert scene.mesh.metadata[TOUR_ROOMS] == [a.rect for a in lay.aisles]
    caster = MeshRayCaster(scene.mesh, threads=1)
    tour = chunk_tour(caster, scene.bounds, CHUNKS, np.random.default_rng(seed))
    assert 25.0 < tour.length < 80.0 and np.all(np.diff(tour.arc) > 0)
    assert len(tour.centres) == len(lay.aisles)
    order_y = tour.centres[tour.order, 1]
    assert np.all(np.diff(order_y) > 0) or np.all(np.diff(order_y) < 0)  # aisle after aisle, across the hall
    lx, ly = lay.size
    path = tour.path
    assert np.all((path > 0.25) & (path < np.array([lx, ly]) - 0.25))
    for rect in [r.rect for r in lay.racks] + list(lay.pallets):
        assert _rect_distance(path, rect).min() >= 0.25
    walked = [_aisle_walked(path, a) for a in lay.aisles]
    assert min(walked) >= 0.25 and np.mean(walked) >= 0.75, walked


def test_robots_walk_their_own_aisles_clear_of_the_racks(warehouse):
    """Three robots: chunks of the tour cut where it leaves an aisle (near the equal cuts), each
    robot on its own chunk from its start, at camera height, never near a rack."""
    scene, caster, lay, fs = warehouse
    tour = chunk_tour(caster, scene.bounds, CHUNKS, np.random.default_rng(5))
    trajs = procedural_trajectories(caster, scene.bounds, 3, 40.0, CHUNKS, np.random.default_rng(5))
    e = tour.edges(3, CHUNKS.chunk_snap)
    assert all(np.min(np.abs(tour.doorways - c)) < 1e-9 for c in e[1:-1])  # cut between two aisles
    assert np.all(np.abs(e - np.linspace(0.0, tour.length, 4)) <= 0.5 * tour.length / 3 + 1e-9)
    for a, tr in enumerate(trajs):
        xy = tr.poses[:, :2, 3]
        assert np.allclose(xy[0], tour.at([e[a]])[0], atol=1e-6)  # starts at its chunk's start
        s = tour.arc[np.argmin(np.linalg.norm(tour.path[None] - xy[::10, None], axis=2), axis=1)]
        assert np.all((s >= e[a] - 0.1) & (s <= e[a + 1] + 0.1))  # and stays in its chunk
        for rect in [r.rect for r in lay.racks]:
            assert _rect_distance(xy, rect).min() >= 0.25
        j, i = fs.cell(xy)
        assert np.all(fs.clearance[j, i] >= 0.25)
        assert np.all(np.abs(tr.poses[:, 2, 3] - fs.floor_z - CHUNKS.height) <= CHUNKS.height_variation + 1e-6)


def test_the_scenario_builds_three_robots_in_their_own_aisles():
    sc = load_scenario(SCENARIO, ["duration=20", "world.camera.fps=1"])
    world = build_world(sc.world, sc.agents.count, sc.duration, Seeds(sc.seed).numpy)
    try:
        assert world.n_agents == 3 and world.scene.name == "warehouse"
        starts = np.array([s.trajectory.poses[0, :2, 3] for s in world.sources])
        assert min(np.linalg.norm(starts[i] - starts[j]) for i in range(3) for j in range(i)) > 1.0
    finally:
        world.close()


# ----------------------------------------------------------------------------- end to end
def test_a_tiny_run_in_the_warehouse(tmp_path):
    """Two robots, 3 simulated seconds, a 40 x 30 camera, the final evaluation only: the run
    ends and every map has a finite completion ratio."""
    import ramensim

    tiny = ["agents.count=2", "duration=3", "world.camera.width=40", "world.camera.height=30",
            "world.camera.fx=30", "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5",
            "evaluation.voxel_m=0.1", "evaluation.n_samples=5000", "evaluation.cull=frustum",
            "evaluation.every_s=null", "map.n_rays=128", "consensus.primal_steps=3", "recording.mode=off"]
    out = ramensim.run(SCENARIO, overrides=tiny, out=tmp_path / "run")
    assert out.status == "ok"
    ratios = out.metric("completion_ratio_pct")
    assert set(ratios) == {"agent_0", "agent_1"} and all(math.isfinite(v) and v > 0 for v in ratios.values())
