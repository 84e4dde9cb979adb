"""The built-in six-room house and the trajectory split 'chunks': layout, walls and doorways,
determinism, one tour cut into contiguous chunks, errors, and the coverage report."""
import numpy as np
import pytest

from ramensim.core.errors import InputError
from ramensim.core.seeding import Seeds
from ramensim.world import build_world
from ramensim.world.camera import MeshRayCaster
from ramensim.world.config import ProceduralTrajectoryConfig, WorldConfig
from ramensim.coverage_report import coverage_report
from ramensim.world.scenes import HOUSE_DOOR_H, HOUSE_DOOR_W, WALL_T, builtin_scene, house_layout
from ramensim.world.trajectories import FreeSpace, chunk_tour, procedural_trajectories

CHUNKS = ProceduralTrajectoryConfig(split="chunks")


@pytest.fixture(scope="module")
def house():
    scene = builtin_scene("house", 0)
    return scene, MeshRayCaster(scene.mesh), house_layout(0)


@pytest.fixture(scope="module")
def chunked(house):
    scene, caster, _ = house
    tour = chunk_tour(caster, scene.bounds, CHUNKS, np.random.default_rng(5))
    trajs = procedural_trajectories(caster, scene.bounds, 3, 40.0, CHUNKS, np.random.default_rng(5))
    return tour, trajs


def _room_of(lay, xy):
    for r in lay.rooms:
        x0, y0, x1, y1 = r.interior
        if x0 - 0.1 <= xy[0] <= x1 + 0.1 and y0 - 0.1 <= xy[1] <= y1 + 0.1:
            return r.chain
    return -1


# ----------------------------------------------------------------------------- the scene
def test_house_is_deterministic():
    a, b, c = builtin_scene("house", 3), builtin_scene("house", 3), builtin_scene("house", 4)
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.mesh.visual.vertex_colors, b.mesh.visual.vertex_colors)
    assert a.mesh.vertices.shape != c.mesh.vertices.shape or not np.allclose(a.mesh.vertices, c.mesh.vertices)
    assert house_layout(3) == house_layout(3) != house_layout(4)


def test_house_layout_is_a_serpentine_chain(house):
    _, _, lay = house
    assert [(r.row, r.col) for r in lay.rooms] == [(0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (1, 0)]
    assert len({r.kind for r in lay.rooms}) == 6  # every room furnished differently
    for r in lay.rooms:
        x0, y0, x1, y1 = r.interior
        assert 3.4 <= x1 - x0 <= 4.5 and 3.4 <= y1 - y0 <= 4.5
    assert [d.rooms for d in lay.doors] == [(k, k + 1) for k in range(5)]
    for d in lay.doors:
        assert d.span[1] - d.span[0] == pytest.approx(HOUSE_DOOR_W)
        assert d.wall[1] - d.wall[0] == pytest.approx(WALL_T)
    assert 2.6 <= lay.height <= 2.8


def test_house_rooms_are_closed(house):
    scene, caster, lay = house
    rng = np.random.default_rng(0)
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    diag = float(np.linalg.norm(scene.bounds[1] - scene.bounds[0]))
    for r in lay.rooms:
        cx, cy = r.centre
        x0, y0, x1, y1 = r.interior
        # every ray from the room hits something inside the house
        dist, tri, _, _ = caster.cast(np.array([[cx, cy, 1.4]]), d)
        assert np.all(tri >= 0) and np.all(dist < diag)
        # above the doorways the room is a box of walls: horizontal rays meet them at its edges
        o = np.array([[cx, cy, HOUSE_DOOR_H + 0.3]])
        axes = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
        dist, tri, _, _ = caster.cast(np.repeat(o, 4, 0), axes)
        assert np.allclose(dist, [x1 - cx, cx - x0, y1 - cy, cy - y0], atol=0.02)


def test_house_walls_open_only_at_the_doors(house):
    """Rays through every interior wall (every 5 cm along it, at 0.5, 1.2 and 1.9 m) pass only
    within a doorway, and every doorway lets rays through: rooms see each other only there."""
    scene, caster, lay = house
    grid = {(r.row, r.col): r for r in lay.rooms}
    walls = []  # (normal axis, wall start, along range, chain rooms)
    for (row, col), r in grid.items():
        if (row, col + 1) in grid:
            walls.append((0, r.interior[2], (r.interior[1], r.interior[3]), {r.chain, grid[(row, col + 1)].chain}))
        if (row + 1, col) in grid:
            walls.append((1, r.interior[3], (r.interior[0], r.interior[2]), {r.chain, grid[(row + 1, col)].chain}))
    for axis, at, (lo, hi), pair in walls:
        spans = [d.span for d in lay.doors if set(d.rooms) == pair]
        along = np.arange(lo + 0.05, hi - 0.05, 0.05)
        for z in (0.5, 1.2, 1.9):
            o = np.zeros((len(along), 3))
            o[:, axis], o[:, 1 - axis], o[:, 2] = at - 0.01, along, z
            dirn = np.zeros_like(o)
            dirn[:, axis] = 1.0
            dist, _, _, _ = caster.cast(o, dirn)
            through = dist > WALL_T + 0.1
            in_door = np.zeros(len(along), bool)
            near_door = np.zeros(len(along), bool)
            for s0, s1 in spans:
                in_door |= (along > s0 + 0.02) & (along < s1 - 0.02)
                near_door |= (along >= s0 - 0.02) & (along <= s1 + 0.02)
            assert not np.any(through & ~near_door), (axis, at, z)  # no opening but the doorways
            assert np.all(through[in_door]), (axis, at, z)  # doorways are open (below HOUSE_DOOR_H)
        assert len(spans) == (1 if max(pair) - min(pair) == 1 else 0)


def test_house_free_space_joins_all_rooms(house):
    scene, caster, lay = house
    fs = FreeSpace(caster, scene.bounds, 1.4)
    from scipy import ndimage

    lab, _ = ndimage.label(fs.free, structure=np.ones((3, 3)))
    labels = set()
    for r in lay.rooms:
        x0, y0, x1, y1 = r.interior
        J, I = np.indices(fs.shape)
        xy = fs.centre(J, I)
        inside = fs.free & (xy[..., 0] > x0) & (xy[..., 0] < x1) & (xy[..., 1] > y0) & (xy[..., 1] < y1)
        assert inside.sum() * fs.res ** 2 > 5.0  # plenty of floor to walk in every room
        labels.add(int(np.bincount(lab[inside]).argmax()))
    assert len(labels) == 1


# ----------------------------------------------------------------------------- split 'chunks'
def test_tour_visits_the_rooms_in_chain_order(house, chunked):
    _, _, lay = house
    tour, _ = chunked
    rooms = [_room_of(lay, tour.centres[r]) for r in tour.order]
    assert rooms == [0, 1, 2, 3, 4, 5]
    seq = [_room_of(lay, p) for p in tour.path[::5]]
    visits = [r for k, r in enumerate(seq) if r >= 0 and (k == 0 or r != seq[k - 1])]
    assert visits == [0, 1, 2, 3, 4, 5]  # through the doorways, each room once
    assert 20.0 < tour.length < 80.0
    assert np.all(np.diff(tour.arc) > 0)


def test_chunks_are_contiguous_equal_and_disjoint(chunked):
    tour, _ = chunked
    for n in (1, 2, 3, 6):
        for snap in (0.0, CHUNKS.chunk_snap):
            e = tour.edges(n, snap)
            assert e[0] == 0.0 and e[-1] == pytest.approx(tour.length) and len(e) == n + 1
            assert np.all(np.diff(e) >= 0.5 * tour.length / n - 1e-9)  # disjoint, none too short
            if snap == 0.0:
                assert np.allclose(np.diff(e), tour.length / n)
    e = tour.edges(6, CHUNKS.chunk_snap)
    assert any(np.min(np.abs(tour.doorways - c)) < 1e-9 for c in e[1:-1])  # cuts move onto doorways


def _dist_to_polyline(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(np.einsum("pkd,kd->pk", p[:, None] - a[None], ab) / np.maximum((ab ** 2).sum(1), 1e-12), 0, 1)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None] - closest, axis=2).min(axis=1)


def test_agents_walk_back_and_forth_in_their_own_chunk(house, chunked):
    scene, caster, _ = house
    tour, trajs = chunked
    e = tour.edges(3, CHUNKS.chunk_snap)
    fs = FreeSpace(caster, scene.bounds, CHUNKS.height)
    assert len(trajs) == 3
    for a, tr in enumerate(trajs):
        xy = tr.poses[:, :2, 3]
        inside = (tour.arc >= e[a] - 1e-9) & (tour.arc <= e[a + 1] + 1e-9)
        line = np.vstack([tour.at([e[a]]), tour.path[inside], tour.at([e[a + 1]])])
        assert _dist_to_polyline(xy, line).max() < 0.01  # on chunk a of the tour
        assert np.allclose(xy[0], tour.at([e[a]])[0], atol=1e-6)  # starts at the chunk's start
        # ping-pong: reaches the chunk's end (40 s at 0.4 m/s covers more than a chunk) and stays in
        assert np.linalg.norm(xy - tour.at([e[a + 1]])[0], axis=1).min() < 0.05
        step = np.linalg.norm(np.diff(xy, axis=0), axis=1) / 0.1
        assert np.median(step) == pytest.approx(CHUNKS.speed, rel=0.05)
        j, i = fs.cell(xy)
        assert np.all(fs.clearance[j, i] >= 0.25)
        assert np.all(np.abs(tr.poses[:, 2, 3] - fs.floor_z - CHUNKS.height) <= CHUNKS.height_variation + 1e-6)
        R = tr.poses[:, :3, :3]
        assert np.allclose(np.einsum("kij,kil->kjl", R, R), np.eye(3), atol=1e-6)


def test_chunk_passes_walk_each_chunk_that_many_times_over_the_run(house):
    """world.trajectory.chunk_passes (the authors' split, labicon/RAMEN main.py: robot i gets
    frames i*F/n .. (i+1)*F/n - 1 of one sequence, each once): with 1, every agent goes from
    its chunk's start to its end exactly once in the run, each at its own speed (chunk length /
    duration), never turning back; with 2, there and back."""
    scene, caster, _ = house
    cfg = ProceduralTrajectoryConfig(split="chunks", chunk_passes=1.0, chunk_snap=0.5)
    tour = chunk_tour(caster, scene.bounds, cfg, np.random.default_rng(5))
    e = tour.edges(3, cfg.chunk_snap)
    assert np.ptp(np.diff(e)) > 0.1  # snapped chunks differ in length, so the agents' speeds differ
    duration = 60.0
    once = procedural_trajectories(caster, scene.bounds, 3, duration, cfg, np.random.default_rng(5))
    twice = procedural_trajectories(caster, scene.bounds, 3, duration,
                                    cfg.model_copy(update={"chunk_passes": 2.0}), np.random.default_rng(5))
    for a, (tr, tr2) in enumerate(zip(once, twice)):
        start, end = tour.at([e[a]])[0], tour.at([e[a + 1]])[0]
        xy, xy2 = tr.positions_at([0.0, duration])[:, :2], tr2.positions_at([0.0, duration / 2, duration])[:, :2]
        assert np.allclose(xy[0], start, atol=1e-6) and np.linalg.norm(xy[1] - end) < 0.02
        assert np.linalg.norm(xy2[1] - end) < 0.02 and np.linalg.norm(xy2[2] - start) < 0.02
        # the arc length walked is the chunk's length, once: no turning back
        ts = np.arange(0.0, duration + 1e-9, 0.1)
        walked = np.linalg.norm(np.diff(tr.positions_at(ts)[:, :2], axis=0), axis=1).sum()
        assert walked == pytest.approx(e[a + 1] - e[a], rel=0.05)
        step = np.linalg.norm(np.diff(tr.positions_at(ts)[:, :2], axis=0), axis=1) / 0.1
        assert np.median(step) == pytest.approx((e[a + 1] - e[a]) / duration, rel=0.05)


def test_chunks_are_deterministic(house):
    scene, caster, _ = house
    a = procedural_trajectories(caster, scene.bounds, 2, 10.0, CHUNKS, np.random.default_rng(7))
    b = procedural_trajectories(caster, scene.bounds, 2, 10.0, CHUNKS, np.random.default_rng(7))
    c = procedural_trajectories(caster, scene.bounds, 2, 10.0, CHUNKS, np.random.default_rng(8))
    assert all(np.array_equal(x.poses, y.poses) for x, y in zip(a, b))
    assert not np.array_equal(a[0].poses, c[0].poses)


def test_chunks_in_a_single_room_make_one_long_path():
    scene = builtin_scene("office", 0)
    caster = MeshRayCaster(scene.mesh)
    tour = chunk_tour(caster, scene.bounds, CHUNKS, np.random.default_rng(1))
    assert len(tour.centres) == 1 and tour.length > 8.0
    trajs = procedural_trajectories(caster, scene.bounds, 2, 5.0, CHUNKS, np.random.default_rng(1))
    assert len(trajs) == 2 and not np.allclose(trajs[0].poses[0], trajs[1].poses[0])


def test_too_many_agents_for_the_tour(house):
    scene, caster, _ = house
    with pytest.raises(InputError, match=r"world\.trajectory\.split.*fewer agents"):
        procedural_trajectories(caster, scene.bounds, 200, 5.0, CHUNKS, np.random.default_rng(0))


def test_no_frames_is_an_input_error():
    cfg = WorldConfig.model_validate({"scene": {"name": "pretrain_room"}})
    with pytest.raises(InputError, match="world.camera.fps"):
        build_world(cfg, 1, 0.0)


# ----------------------------------------------------------------------------- coverage report
def test_coverage_report_of_a_house_world():
    cfg = WorldConfig.model_validate({"scene": {"name": "house"}, "trajectory": {"split": "chunks"},
                                      "camera": {"fps": 1.0}})
    world = build_world(cfg, 2, 30.0, Seeds(0).numpy)
    try:
        rep = coverage_report(world, n_points=8000)
    finally:
        world.close()
    assert len(rep.own_pct) == 2 and rep.n_frames == (30, 30) and rep.n_points == 8000
    assert all(20.0 < p < 90.0 for p in rep.own_pct)  # each robot sees its own half, not all
    assert 100.0 <= sum(rep.own_pct) and 10.0 < rep.team_pct < 80.0
    assert "own %" in rep.table() and len(rep.table().splitlines()) == 6
