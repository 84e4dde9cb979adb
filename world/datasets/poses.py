"""Pose file readers shared by the dataset layouts, with line-accurate errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ramensim.core.errors import InputError
from ramensim.core.posefile import finite_poses, log_skipped, read_pose_lines
from ramensim.world.trajectories import check_pose_matrix

__all__ = ["read_matrix_lines", "read_matrix_file", "log_skipped"]


def read_matrix_lines(path: Path, skip_invalid: bool = False) -> tuple[list[np.ndarray], list[bool]]:
    """One row-major 4x4 camera-to-world per non-empty line (Replica ``traj.txt``;
    :func:`ramensim.core.posefile.read_pose_lines`). Returns the poses and, per pose, whether
    it is valid (False only for a NaN/inf pose that ``skip_invalid`` lets through, the rule of
    :func:`ramensim.core.posefile.finite_poses`)."""
    poses, lines = read_pose_lines(path)
    ok = finite_poses(poses, path, lines, skip=skip_invalid)
    return ([check_pose_matrix(T, f"{path}, line {no}") if good else T for T, no, good in zip(poses, lines, ok)],
            [bool(v) for v in ok])


def read_matrix_file(path: Path, skip_invalid: bool = False) -> tuple[np.ndarray, bool]:
    """A 4x4 matrix written as 4 lines of 4 numbers (ScanNet ``pose/*.txt``); the same rule for
    a NaN/inf pose (one file of many: it is skipped, not an error, when ``skip_invalid``)."""
    try:
        rows = [ln.split() for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
        M = np.asarray([[float(v) for v in r] for r in rows], np.float64)
    except FileNotFoundError:
        raise InputError(f"{path}: pose file not found; expected a 4x4 camera-to-world matrix.") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{path}: cannot be read as a 4x4 matrix ({exc}); expected 4 lines of 4 numbers.") from None
    if M.shape != (4, 4):
        raise InputError(f"{path}: has shape {M.shape}; expected 4 lines of 4 numbers (a 4x4 matrix).")
    if not finite_poses(M[None], path, skip=skip_invalid, require_some=False)[0]:
        return M, False
    return check_pose_matrix(M, str(path)), True
