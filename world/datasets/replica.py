"""Replica in the NICE-SLAM layout: ``results/frame%06d.jpg``, ``results/depth%06d.png``
(16-bit, 6553.5 units per metre), ``traj.txt`` (one row-major 4x4 camera-to-world per line,
OpenCV axes), the ground-truth mesh ``<seq>_mesh.ply`` beside the sequence folder, and
optionally ``cam_params.json`` (Replica's camera file) in or beside it."""
from __future__ import annotations

import json
import re
from pathlib import Path

from ramensim.core.frames import Intrinsics
from ramensim.core.errors import InputError
from ramensim.world.datasets.common import DatasetFrame, Sequence, require_dir, require_file
from ramensim.world.datasets.poses import log_skipped, read_matrix_lines

DEPTH_SCALE = 6553.5
# NICE-SLAM's Replica camera (1200 x 680)
DEFAULT_K = Intrinsics(600.0, 600.0, 599.5, 339.5, 1200, 680)


def _number(p: Path) -> int:
    m = re.search(r"(\d+)$", p.stem)
    return int(m.group(1)) if m else -1


def _intrinsics(root: Path) -> Intrinsics:
    for p in (root / "cam_params.json", root.parent / "cam_params.json"):
        if p.is_file():
            try:
                cam = json.loads(p.read_text(encoding="utf-8"))["camera"]
                return Intrinsics(float(cam["fx"]), float(cam["fy"]), float(cam["cx"]), float(cam["cy"]),
                                  int(cam["w"]), int(cam["h"]))
            except (OSError, ValueError, KeyError, TypeError) as exc:
                raise InputError(f"{p}: cannot read the camera ({type(exc).__name__}: {exc}); expected JSON "
                                 f"{{'camera': {{'w', 'h', 'fx', 'fy', 'cx', 'cy'}}}}.") from None
    return DEFAULT_K


def read_replica(root: Path, fps: float, skip_invalid: bool = False) -> Sequence:
    """Read a Replica sequence folder (NICE-SLAM layout); frame k gets time k / fps (s)."""
    require_dir(root, "a Replica sequence folder (NICE-SLAM layout, with results/ and traj.txt)")
    res = require_dir(root / "results", "the Replica 'results' folder with frame*.jpg and depth*.png")
    colors = sorted(res.glob("frame*.jpg"), key=_number) or sorted(res.glob("frame*.png"), key=_number)
    depths = sorted(res.glob("depth*.png"), key=_number)
    if not colors:
        raise InputError(f"{res}: no frame*.jpg colour images found; expected the NICE-SLAM Replica layout.")
    if len(depths) != len(colors):
        raise InputError(f"{res}: {len(colors)} colour images but {len(depths)} depth images; expected one "
                         f"depth*.png per frame*.jpg.")
    traj = require_file(root / "traj.txt", "traj.txt with one 4x4 camera-to-world pose per line")
    poses, ok = read_matrix_lines(traj, skip_invalid)
    if len(poses) < len(colors):
        raise InputError(f"{traj}: has {len(poses)} poses but there are {len(colors)} frames; expected one "
                         f"pose per frame.")
    frames = [DatasetFrame(k / fps, poses[k], colors[k], depths[k]) for k in range(len(colors)) if ok[k]]
    log_skipped(traj, len(colors) - len(frames), len(colors), "frames")
    mesh = root.parent / f"{root.name}_mesh.ply"
    return Sequence(root.name, frames, _intrinsics(root), DEPTH_SCALE, mesh if mesh.is_file() else None)
