"""Dataset readers (Replica, ScanNet, TUM) built on the fly, splits and bad input."""
import numpy as np
import pytest
from PIL import Image
from scipy.spatial.transform import Rotation

from ramensim.core.errors import InputError
from ramensim.core.seeding import Seeds
from ramensim.world import build_world
from ramensim.world.config import DatasetSceneConfig, SensorConfig, WorldConfig

W, H = 16, 12
N = 6


def _pose(k):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("y", 5 * k, degrees=True).as_matrix()
    T[:3, 3] = [0.5 * k, 0.1, 1.0]
    return T


def _depth(k):
    return 1.0 + 0.1 * k + 0.01 * np.arange(W)[None, :] * np.ones((H, 1))


def _write(rgb_path, depth_path, k, scale, size=(W, H)):
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[..., 0] = 20 * k
    Image.fromarray(rgb).resize(size).save(rgb_path)
    d = np.round(_depth(k) * scale).astype(np.uint16)
    Image.fromarray(d).save(depth_path)


def make_replica(root):
    (root / "results").mkdir(parents=True)
    for k in range(N):
        _write(root / "results" / f"frame{k:06d}.jpg", root / "results" / f"depth{k:06d}.png", k, 6553.5)
    (root / "traj.txt").write_text("\n".join(" ".join(str(float(v)) for v in _pose(k).ravel()) for k in range(N)) + "\n")
    (root / "cam_params.json").write_text(
        '{"camera": {"w": %d, "h": %d, "fx": 10.0, "fy": 10.0, "cx": 7.5, "cy": 5.5, "scale": 6553.5}}' % (W, H))
    return root


def make_scannet(root):
    for d in ("color", "depth", "pose", "intrinsic"):
        (root / d).mkdir(parents=True)
    for k in range(N):
        _write(root / "color" / f"{k}.jpg", root / "depth" / f"{k}.png", k, 1000.0, size=(2 * W, 2 * H))
        (root / "pose" / f"{k}.txt").write_text("\n".join(" ".join(str(float(v)) for v in r) for r in _pose(k)))
    (root / "intrinsic" / "intrinsic_depth.txt").write_text(
        "10 0 7.5 0\n0 10 5.5 0\n0 0 1 0\n0 0 0 1\n")
    return root


def make_tum(root):
    (root / "rgb").mkdir(parents=True)
    (root / "depth").mkdir()
    rgb, dep, gt = ["# rgb"], ["# depth"], ["# gt"]
    for k in range(N):
        t = 100.0 + 0.1 * k
        _write(root / "rgb" / f"{t:.6f}.png", root / "depth" / f"{t + 0.004:.6f}.png", k, 5000.0)
        rgb.append(f"{t:.6f} rgb/{t:.6f}.png")
        dep.append(f"{t + 0.004:.6f} depth/{t + 0.004:.6f}.png")
        q = Rotation.from_matrix(_pose(k)[:3, :3]).as_quat()
        p = _pose(k)[:3, 3]
        gt.append(f"{t:.6f} {p[0]} {p[1]} {p[2]} {q[0]} {q[1]} {q[2]} {q[3]}")
    for name, lines in (("rgb.txt", rgb), ("depth.txt", dep), ("groundtruth.txt", gt)):
        (root / name).write_text("\n".join(lines) + "\n")
    return root


def _cfg(kind, path, **kw):
    extra = {"intrinsics": "camera"} if kind == "tum" else {}
    extra.update(kw)
    camera = {"width": W, "height": H, "fx": 10.0, "fy": 10.0, "cx": 7.5, "cy": 5.5,
              "sensor": SensorConfig(min_range=0.0).model_dump()}
    return WorldConfig.model_validate({"scene": {"kind": kind, "path": str(path), **extra}, "camera": camera})


MAKERS = {"replica": make_replica, "scannet": make_scannet, "tum": make_tum}


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_round_trip_and_chunks(tmp_path, kind):
    root = MAKERS[kind](tmp_path / "seq")
    world = build_world(_cfg(kind, root), 2, 10.0, Seeds(0).numpy)
    assert world.scene is None and world.intrinsics.width == W and world.intrinsics.fx == 10.0
    assert [len(s) for s in world.sources] == [3, 3]
    for a in range(2):
        fr = world.frames_for(a)
        assert fr[0][0] == 0.0  # each agent's stream starts at t = 0
        for j in range(3):
            k = 3 * a + j
            f = world.render(a, j)
            assert np.allclose(f.c2w, _pose(k), atol=1e-6)
            assert np.allclose(f.depth, _depth(k), atol=2e-3)
            assert f.rgb[0, 0, 0] == pytest.approx(20 * k / 255, abs=0.03)
            assert f.rgb.shape == (H, W, 3)
    assert np.allclose(world.position(1, 0.0), _pose(3)[:3, 3])
    assert np.all(world.bounds[0] < [0, 0, 1.0]) and np.all(world.bounds[1] > [2.5, 0.1, 1.5])


def test_region_split_and_scale(tmp_path):
    root = make_replica(tmp_path / "room0")
    world = build_world(_cfg("replica", root, split="regions", image_scale=0.5), 3, 10.0)
    xs = [[p[0, 3] for _, p in world.frames_for(a)] for a in range(3)]
    assert xs == [[0.0, 0.5], [1.0, 1.5], [2.0, 2.5]]
    f = world.render(2, 1)
    assert f.depth.shape == (H // 2, W // 2) and world.intrinsics.fx == 5.0


def test_replica_mesh_is_found(tmp_path):
    import trimesh

    root = make_replica(tmp_path / "room0")
    trimesh.creation.box(extents=[3, 3, 3]).export(tmp_path / "room0_mesh.ply")
    world = build_world(_cfg("replica", root), 1, 5.0)
    assert world.scene is not None and np.allclose(world.bounds, [[-1.6] * 3, [1.6] * 3])


def test_missing_files_name_the_file(tmp_path):
    root = make_replica(tmp_path / "r")
    (root / "traj.txt").unlink()
    with pytest.raises(InputError, match="traj.txt"):
        build_world(_cfg("replica", root), 1, 5.0)
    with pytest.raises(InputError, match="nothere"):
        build_world(_cfg("scannet", tmp_path / "nothere"), 1, 5.0)
    t = make_tum(tmp_path / "t")
    (t / "groundtruth.txt").unlink()
    with pytest.raises(InputError, match="groundtruth.txt"):
        build_world(_cfg("tum", t), 1, 5.0)


def test_wrong_depth_size(tmp_path):
    root = make_replica(tmp_path / "r")
    Image.fromarray(np.zeros((5, 5), np.uint16)).save(root / "results" / "depth000002.png")
    with pytest.raises(InputError, match=r"depth000002\.png.*5x5"):
        build_world(_cfg("replica", root, max_frames=N), 1, 5.0).render(0, 2)  # at build (bounds) or render


def test_bad_poses(tmp_path):
    root = make_replica(tmp_path / "r")
    lines = (root / "traj.txt").read_text().splitlines()
    lines[3] = " ".join(["2"] + lines[3].split()[1:])  # scaled: not a rotation
    (root / "traj.txt").write_text("\n".join(lines))
    with pytest.raises(InputError, match=r"traj\.txt, line 4.*not a rotation"):
        build_world(_cfg("replica", root), 1, 5.0)
    s = make_scannet(tmp_path / "s")
    (s / "pose" / "2.txt").write_text("-inf -inf -inf -inf\n" * 4)
    with pytest.raises(InputError, match=r"2\.txt.*NaN or infinite"):
        build_world(_cfg("scannet", s, skip_invalid_poses=False), 1, 5.0)
    world = build_world(_cfg("scannet", s), 1, 5.0)  # the default skips it
    assert len(world.sources[0]) == N - 1
    t = make_tum(tmp_path / "t")
    g = (t / "groundtruth.txt").read_text().replace("100.200000 1.0", "100.200000 nan", 1)
    (t / "groundtruth.txt").write_text(g)
    with pytest.raises(InputError, match=r"groundtruth\.txt, line 4.*NaN or infinite"):
        build_world(_cfg("tum", t, skip_invalid_poses=False), 1, 5.0)
    build_world(_cfg("tum", t), 1, 5.0)  # the default skips the lost-tracking line, as for every pose file
