"""Trajectories: slerp interpolation, file readers and their errors, procedural paths."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ramensim.core.errors import InputError
from ramensim.world.camera import MeshRayCaster
from ramensim.world.config import ProceduralTrajectoryConfig
from ramensim.world.scenes import builtin_scene
from ramensim.world.trajectories import (FreeSpace, Trajectory, load_matrix, load_tum, look_rotation,
                                         procedural_trajectories)


def _pose(yaw_deg, xyz):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix()
    T[:3, 3] = xyz
    return T


def test_slerp_interpolation():
    tr = Trajectory([0.0, 2.0], [_pose(0, [0, 0, 0]), _pose(90, [2, 4, 0])])
    mid = tr.pose(1.0)
    assert np.allclose(mid[:3, 3], [1, 2, 0])
    assert Rotation.from_matrix(mid[:3, :3]).magnitude() == pytest.approx(math.radians(45))
    assert tr.duration == 2.0
    assert np.allclose(tr.pose(5.0), tr.pose(2.0))  # held
    loop = Trajectory([0.0, 2.0], [_pose(0, [0, 0, 0]), _pose(90, [2, 4, 0])], loop=True)
    assert np.allclose(loop.position(3.0), [1, 2, 0])  # ping-pong


def test_look_rotation_is_opencv():
    R = look_rotation(np.array([1.0, 0, 0]), 0.0)
    assert np.allclose(R[:, 2], [1, 0, 0]) and np.allclose(R[:, 1], [0, 0, -1])  # z forward, y down
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_tum_and_matrix_round_trip(tmp_path):
    p = tmp_path / "a.txt"
    q = Rotation.from_euler("z", 30, degrees=True).as_quat()
    p.write_text(f"# comment\n10.0 0 0 0 0 0 0 1\n11.0 1 2 3 {q[0]} {q[1]} {q[2]} {q[3]}\n")
    tr = load_tum(p)
    assert tr.duration == 1.0 and np.allclose(tr.position(1.0), [1, 2, 3])
    m = tmp_path / "m.txt"
    m.write_text("\n".join(" ".join(map(str, _pose(k * 10, [k, 0, 0]).ravel())) for k in range(3)))
    tm = load_matrix(m, fps=2.0)
    assert tm.duration == 1.0 and np.allclose(tm.pose(1.0), _pose(20, [2, 0, 0]))


@pytest.mark.parametrize("line, fmt", [
    ("0 0 0 0 0 0 0 3", "tum"),
    ("0 0 0 0 0 1", "tum"),
    (" ".join(["2", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1"]), "matrix"),
])
def test_bad_trajectory_lines_name_file_and_line(tmp_path, line, fmt):
    good = "0 0 0 0 0 0 0 1" if fmt == "tum" else " ".join(map(str, np.eye(4).ravel()))
    p = tmp_path / "bad.txt"
    p.write_text(good.replace("0 0 0 0 0 0 0 1", "-1 0 0 0 0 0 0 1") + "\n" + line + "\n")
    with pytest.raises(InputError, match=r"bad\.txt, line 2"):
        load_tum(p) if fmt == "tum" else load_matrix(p, 10.0)


def test_non_finite_poses_are_skipped_by_the_one_rule(tmp_path, caplog):
    """A pose with inf or NaN (lost tracking) is skipped with one warning, whichever file holds
    it (trajectory, TUM, dataset, eval poses: ramensim.core.posefile); the others keep their times."""
    eye = " ".join(map(str, np.eye(4).ravel()))
    bad = " ".join(["1", "0", "0", "inf"] + ["0", "1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1"])
    p = tmp_path / "m.txt"
    p.write_text(f"{eye}\n{bad}\n{eye}\n")
    with caplog.at_level("WARNING"):
        tm = load_matrix(p, fps=2.0)
    assert np.allclose(tm.times, [0.0, 1.0]) and "skipped 1 of 3 poses" in caplog.text
    p.write_text(f"{bad}\n")
    with pytest.raises(InputError, match="every pose has NaN or infinite values"):
        load_matrix(p, fps=2.0)
    tum = tmp_path / "t.txt"
    tum.write_text("0 0 0 0 0 0 0 1\n0.5 nan 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n")
    assert len(load_tum(tum).times) == 2
    with pytest.raises(InputError, match=r"t\.txt, line 2"):
        load_tum(tum, skip_invalid=False)


def test_missing_trajectory_file(tmp_path):
    with pytest.raises(InputError, match="nope.txt"):
        load_tum(tmp_path / "nope.txt")


@pytest.fixture(scope="module")
def office():
    s = builtin_scene("office", 0)
    return s, MeshRayCaster(s.mesh)


def test_procedural_regions_speed_and_free_space(office):
    scene, caster = office
    cfg = ProceduralTrajectoryConfig(speed=0.4, split="regions")
    trajs = procedural_trajectories(caster, scene.bounds, 3, 40.0, cfg, np.random.default_rng(1))
    fs = FreeSpace(caster, scene.bounds, cfg.height)
    jj, ii = np.nonzero(fs.free)
    xs = fs.centre(jj, ii)[:, 0]  # x is the office's longest axis
    edges = np.linspace(xs.min(), xs.max(), 4)
    for a, tr in enumerate(trajs):
        p = tr.positions_at(np.arange(0, 40, 0.1))
        assert np.all(p[:, 0] >= edges[a] - 1e-6) and np.all(p[:, 0] <= edges[a + 1] + 1e-6)
        step = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1) / 0.1
        assert np.median(step) == pytest.approx(0.4, rel=0.05)
        j, i = fs.cell(p[:, :2])
        assert np.all(fs.clearance[j, i] >= 0.25)  # never inside or brushing furniture
        assert np.all(np.abs(p[:, 2] - 1.4) <= 0.16)


def test_procedural_is_deterministic(office):
    scene, caster = office
    cfg = ProceduralTrajectoryConfig(split="none")
    a = procedural_trajectories(caster, scene.bounds, 2, 10.0, cfg, np.random.default_rng(7))
    b = procedural_trajectories(caster, scene.bounds, 2, 10.0, cfg, np.random.default_rng(7))
    c = procedural_trajectories(caster, scene.bounds, 2, 10.0, cfg, np.random.default_rng(8))
    assert all(np.array_equal(x.poses, y.poses) for x, y in zip(a, b))
    assert not np.array_equal(a[0].poses, c[0].poses)


def test_camera_above_the_ceiling_is_named(office):
    scene, caster = office
    with pytest.raises(InputError, match=r"world\.trajectory\.height is 3\.5 m.*ceiling"):
        FreeSpace(caster, scene.bounds, 3.5)


@pytest.mark.parametrize("split", ["none", "chunks"])
def test_a_shorter_path_is_the_longer_ones_beginning_up_to_its_last_seconds(office, split):
    """docs/DESIGN.md "Determinism": a cause run of D s is compared with a longer protocol run
    at its periodic evaluations before its last 3.2 s. The path is built over the duration and
    its heading smoothed with a Gaussian of 0.8 s truncated at 4 sigma, so only the poses within
    that radius of the shorter path's end may differ."""
    scene, caster = office
    cfg = ProceduralTrajectoryConfig(split=split, speed=0.05)
    short = procedural_trajectories(caster, scene.bounds, 2, 12.0, cfg, np.random.default_rng(3))
    long = procedural_trajectories(caster, scene.bounds, 2, 30.0, cfg, np.random.default_rng(3))
    for s, lg in zip(short, long):
        head = np.arange(0.0, 12.0 - 3.3, 0.1)
        assert np.array_equal(s.poses_at(head), lg.poses_at(head))
