"""Pose file readers shared by the dataset layouts, with line-accurate errors."""
from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from ramensim.core.errors import InputError
from ramensim.world.textfile import content_lines
from ramensim.world.trajectories import check_pose_matrix

log = logging.getLogger(__name__)


def read_matrix_lines(path: Path, skip_invalid: bool = False) -> tuple[list[np.ndarray], list[bool]]:
    """One row-major 4x4 camera-to-world per non-empty line (Replica ``traj.txt``).
    Returns the poses and, per pose, whether it is valid (only False when ``skip_invalid``
    lets a NaN/inf pose through)."""
    poses, ok = [], []
    for no, s in content_lines(path, "one 4x4 pose per line"):
        try:
            vals = [float(v) for v in s.split()]
        except ValueError:
            raise InputError(f"{path}, line {no}: {s[:60]!r} is not all numbers; expected 16 numbers "
                             f"(a row-major 4x4 camera-to-world matrix).") from None
        if len(vals) != 16:
            raise InputError(f"{path}, line {no}: found {len(vals)} numbers; expected 16 (a row-major 4x4 "
                             f"camera-to-world matrix).")
        T, good = _validated(np.asarray(vals).reshape(4, 4), f"{path}, line {no}", skip_invalid)
        poses.append(T)
        ok.append(good)
    return poses, ok


def read_matrix_file(path: Path, skip_invalid: bool = False) -> tuple[np.ndarray, bool]:
    """A 4x4 matrix written as 4 lines of 4 numbers (ScanNet ``pose/*.txt``)."""
    try:
        rows = [ln.split() for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
        M = np.asarray([[float(v) for v in r] for r in rows], np.float64)
    except FileNotFoundError:
        raise InputError(f"{path}: pose file not found; expected a 4x4 camera-to-world matrix.") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{path}: cannot be read as a 4x4 matrix ({exc}); expected 4 lines of 4 numbers.") from None
    if M.shape != (4, 4):
        raise InputError(f"{path}: has shape {M.shape}; expected 4 lines of 4 numbers (a 4x4 matrix).")
    return _validated(M, str(path), skip_invalid)


def _validated(M: np.ndarray, where: str, skip_invalid: bool) -> tuple[np.ndarray, bool]:
    if not np.all(np.isfinite(M)):
        if skip_invalid:
            log.debug("%s: pose has NaN/inf values; the frame is skipped", where)
            return M, False
        raise InputError(f"{where}: the pose contains NaN or infinite values; expected a finite 4x4 "
                         f"camera-to-world matrix (world.scene.skip_invalid_poses: true, the default, drops such frames).")
    return check_pose_matrix(M, where), True


def finite(vals: list[float]) -> bool:
    return all(math.isfinite(v) for v in vals)


def log_skipped(where: Path, skipped: int, total: int) -> None:
    """One warning with the count of frames dropped for a NaN/inf pose (none: silent)."""
    if skipped:
        log.warning("%s: skipped %d of %d frames whose pose has NaN/inf values (lost tracking)",
                    where, skipped, total)
