"""ScanNet (exported frames): ``color/<k>.jpg``, ``depth/<k>.png`` (16-bit, 1000 units per
metre), ``pose/<k>.txt`` (4x4 camera-to-world, OpenCV axes),
``intrinsic/intrinsic_depth.txt`` (4x4, depth camera), and the ground-truth mesh
``<scene>_vh_clean_2.ply`` inside the scene folder. Colour images are resized to the depth size.

Two layouts hold these folders: the SensReader export (``<scene>/{color,depth,pose,intrinsic}``)
and NICE-SLAM's (``scans/<scene>/frames/{color,depth,pose,intrinsic}``, the mesh in
``scans/<scene>/``); ``path`` may name the scene folder or its ``frames`` folder in either."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from PIL import Image

from ramensim.core.frames import Intrinsics
from ramensim.core.errors import InputError
from ramensim.world.datasets.common import DatasetFrame, Sequence, require_dir, require_file
from ramensim.world.datasets.poses import log_skipped, read_matrix_file

DEPTH_SCALE = 1000.0


def _number(p: Path) -> int:
    m = re.search(r"(\d+)$", p.stem)
    return int(m.group(1)) if m else -1


def read_intrinsic_file(path: Path, width: int, height: int) -> Intrinsics:
    """ScanNet 4x4 intrinsic matrix file -> Intrinsics for a width x height image."""
    require_file(path, "the ScanNet intrinsic matrix (4 lines of 4 numbers)")
    try:
        rows = [ln.split() for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
        M = np.asarray([[float(v) for v in r] for r in rows], np.float64)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{path}: cannot be read as a matrix ({exc}); expected 4 lines of 4 numbers.") from None
    if M.shape not in ((4, 4), (3, 3)) or not np.all(np.isfinite(M)) or M[0, 0] <= 0 or M[1, 1] <= 0:
        raise InputError(f"{path}: is not a valid intrinsic matrix (shape {M.shape}, fx, fy must be positive "
                         f"and finite); expected 4 lines of 4 numbers.")
    return Intrinsics(float(M[0, 0]), float(M[1, 1]), float(M[0, 2]), float(M[1, 2]), width, height)


def read_scannet(root: Path, fps: float, skip_invalid: bool = False) -> Sequence:
    """Read an exported ScanNet scene folder; frame k gets time k / fps (s)."""
    require_dir(root, "a ScanNet scene folder with color/, depth/, pose/ and intrinsic/ "
                      "(or frames/ holding them, NICE-SLAM's layout)")
    scene = root
    if not (root / "color").is_dir() and (root / "frames" / "color").is_dir():
        root = root / "frames"  # NICE-SLAM: scans/<scene>/frames/{color,depth,pose,intrinsic}
    elif root.name == "frames" and (root / "color").is_dir():
        scene = root.parent
    cdir = require_dir(root / "color", "ScanNet colour images color/<k>.jpg")
    ddir = require_dir(root / "depth", "ScanNet depth images depth/<k>.png")
    pdir = require_dir(root / "pose", "ScanNet poses pose/<k>.txt")
    colors = sorted(cdir.glob("*.jpg"), key=_number) or sorted(cdir.glob("*.png"), key=_number)
    if not colors:
        raise InputError(f"{cdir}: no colour images (*.jpg) found; expected color/<k>.jpg per frame.")
    frames = []
    first_depth = None
    for k, c in enumerate(colors):
        d = ddir / f"{c.stem}.png"
        require_file(d, f"the depth image for colour frame {c.name}")
        T, ok = read_matrix_file(pdir / f"{c.stem}.txt", skip_invalid)
        if ok:
            frames.append(DatasetFrame(k / fps, T, c, d))
        first_depth = first_depth or d
    log_skipped(pdir, len(colors) - len(frames), len(colors), "frames")
    try:
        with Image.open(first_depth) as im:
            w, h = im.size
    except OSError as exc:
        raise InputError(f"{first_depth}: cannot be read as an image ({exc}); expected a 16-bit depth PNG.") from None
    K = read_intrinsic_file(root / "intrinsic" / "intrinsic_depth.txt", w, h)
    mesh = scene / f"{scene.name}_vh_clean_2.ply"
    return Sequence(scene.name, frames, K, DEPTH_SCALE, mesh if mesh.is_file() else None)
