"""Dataset layouts and keys on small folders generated here: ScanNet's SensReader export and
NICE-SLAM's scans/<scene>/frames layout, NaN/inf poses skipped with a count in the log,
crop_edge, the bounds key, TUM intrinsics from the folder name and their override, and the
example scenario files under scenarios/datasets/ pointed at generated folders."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
import trimesh

from ramensim.config import apply_overrides, load_scenario_dict, validate
from ramensim.core.errors import InputError
from ramensim.world import build_world
from ramensim.world.datasets import read_scannet, read_tum
from test_world_datasets import H, N, W, _cfg, make_replica, make_scannet, make_tum

ROOT = Path(__file__).resolve().parents[2]


def make_niceslam_scannet(scans: Path, scene: str = "scene0000_00") -> Path:
    """NICE-SLAM's layout: scans/<scene>/frames/{color,depth,pose,intrinsic}, mesh in scans/<scene>/."""
    root = scans / scene
    make_scannet(root / "frames")
    trimesh.creation.box(extents=(2, 2, 2)).export(root / f"{scene}_vh_clean_2.ply")
    return root


def test_niceslam_scannet_layout(tmp_path: Path) -> None:
    scene = make_niceslam_scannet(tmp_path / "scans")
    for path in (scene, scene / "frames"):  # the scene folder or its frames folder
        seq = read_scannet(path, fps=30.0)
        assert seq.name == "scene0000_00" and len(seq.frames) == N
        assert seq.mesh_path == scene / "scene0000_00_vh_clean_2.ply"
        assert (seq.K.width, seq.K.height, seq.K.fx) == (W, H, 10.0)
    world = build_world(_cfg("scannet", scene), 2, 5.0)
    assert world.scene is not None and sum(len(s) for s in world.sources) == N


def test_invalid_poses_are_skipped_with_a_count(tmp_path: Path, caplog) -> None:
    s = make_scannet(tmp_path / "s")
    for k in (1, 4):
        (s / "pose" / f"{k}.txt").write_text("-inf -inf -inf -inf\n" * 4)
    with caplog.at_level(logging.WARNING):
        world = build_world(_cfg("scannet", s), 1, 5.0)
    assert len(world.sources[0]) == N - 2
    assert any("skipped 2 of 6 frames" in r.getMessage() for r in caplog.records)
    r = make_replica(tmp_path / "r")
    lines = (r / "traj.txt").read_text().splitlines()
    lines[2] = " ".join(["nan"] * 16)
    (r / "traj.txt").write_text("\n".join(lines) + "\n")
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        world = build_world(_cfg("replica", r), 1, 5.0)
    assert len(world.sources[0]) == N - 1
    assert any("skipped 1 of 6 frames" in rec.getMessage() for rec in caplog.records)


def test_crop_edge_removes_border_depth(tmp_path: Path) -> None:
    s = make_scannet(tmp_path / "s")
    full = build_world(_cfg("scannet", s), 1, 5.0).sources[0].render(0)
    cropped = build_world(_cfg("scannet", s, crop_edge=2), 1, 5.0).sources[0].render(0)
    assert np.all(full.depth > 0)
    d = cropped.depth
    assert np.all(d[:2] == 0) and np.all(d[-2:] == 0) and np.all(d[:, :2] == 0) and np.all(d[:, -2:] == 0)
    np.testing.assert_array_equal(d[2:-2, 2:-2], full.depth[2:-2, 2:-2])
    assert cropped.K == full.K  # same image size and intrinsics: the border reads no depth
    half = build_world(_cfg("scannet", s, crop_edge=2, image_scale=0.5), 1, 5.0).sources[0].render(0)
    assert half.depth.shape == (H // 2, W // 2) and np.all(half.depth[0] == 0) and half.depth[3, 4] > 0
    with pytest.raises(InputError, match="crop_edge is 6 pixels"):
        build_world(_cfg("scannet", s, crop_edge=6), 1, 5.0)


def test_bounds_key(tmp_path: Path) -> None:
    s = make_scannet(tmp_path / "s")
    b = [[-1.0, -2.0, -0.5], [4.0, 3.0, 2.5]]
    world = build_world(_cfg("scannet", s, bounds=b), 1, 5.0)
    np.testing.assert_array_equal(world.bounds, np.asarray(b))
    with pytest.raises(Exception, match="every min must be below its max"):
        _cfg("scannet", s, bounds=[[0, 0, 0], [1, -1, 1]])


def test_tum_intrinsics_from_folder_name_and_override(tmp_path: Path, caplog) -> None:
    t = make_tum(tmp_path / "rgbd_dataset_freiburg1_desk")
    with caplog.at_level(logging.INFO):
        seq = read_tum(t, max_dt=0.02)
    assert (seq.K.fx, seq.K.fy, seq.K.cx, seq.K.cy) == (517.3, 516.5, 318.6, 255.3)
    assert any("freiburg1 (from the folder name)" in r.getMessage() for r in caplog.records)
    world = build_world(_cfg("tum", t, intrinsics="camera"), 1, 5.0)  # the override: world.camera
    assert world.intrinsics.fx == 10.0 and world.intrinsics.width == W


@pytest.mark.parametrize("name,layout", [("replica_room0", "replica"), ("scannet_scene0000", "scannet"),
                                         ("scannet_niceslam_scene0000", "niceslam"), ("tum_fr1_desk", "tum")])
def test_example_scenarios_build_on_generated_folders(tmp_path: Path, name: str, layout: str) -> None:
    path = ROOT / "scenarios" / "datasets" / f"{name}.yaml"
    data = load_scenario_dict(path)
    validate(data, str(path))  # the file as shipped
    make = {"replica": make_replica, "scannet": make_scannet, "tum": make_tum,
            "niceslam": lambda p: make_niceslam_scannet(p.parent / "scans", p.name)}[layout]
    folder = make(tmp_path / "data" / ("scene0000_00" if layout == "niceslam" else "seq"))
    over = {"world.scene.path": str(folder), "world.scene.crop_edge": 1, "world.scene.image_scale": 1.0,
            "world.scene.bounds": [[-1.0, -1.0, -1.0], [4.0, 2.0, 3.0]], "world.scene.stride": 1,
            "world.camera.width": W, "world.camera.height": H, "world.camera.fx": 10.0, "world.camera.fy": 10.0,
            "world.camera.cx": 7.5, "world.camera.cy": 5.5}
    if layout == "tum":
        over["world.scene.intrinsics"] = "camera"
    sc = validate(apply_overrides(data, over), str(path))
    world = build_world(sc.world, sc.agents.count, sc.duration)
    assert len(world.sources) == sc.agents.count and sum(len(s) for s in world.sources) == N
    assert world.sources[0].render(0).depth[0].max() == 0  # crop_edge applied
