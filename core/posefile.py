"""Pose files, read once for everyone: one row-major 4x4 camera-to-world matrix per line
(trajectory files, Replica's ``traj.txt``, ``ramensim eval --cull-poses``), and the one rule
for poses with non-finite values.

The rule (:func:`finite_poses`): a pose with a NaN or infinite entry marks lost tracking
(ScanNet writes ``-inf``). It is skipped, and the reader's caller says once how many it
skipped of how many (:func:`log_skipped`); a file whose every pose is non-finite is an error.
Where skipping is turned off (a dataset's ``skip_invalid_poses: false``), the first such pose
is an error naming its line.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

POSE_LINE = "one row-major 4x4 camera-to-world matrix per line (16 numbers)"
"""What a pose file holds, in the words of its error messages."""


def content_lines(path: Path, what: str) -> Iterator[tuple[int, str]]:
    """``(1-based line number, stripped text)`` of every line that is neither blank nor a
    ``#`` comment; an unreadable file is an InputError saying it should hold ``what``."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot be read ({exc}); expected {what}.") from None
    for no, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if s and not s.startswith("#"):
            yield no, s


def number_rows(path: Path, ncols: int, what: str) -> tuple[np.ndarray, list[int]]:
    """The numeric rows of a text file, ``ncols`` numbers each (separated by spaces or commas;
    ``#`` comments and blank lines skipped), as float64 (N, ncols), with their 1-based line
    numbers. Non-finite numbers are read as they are (see :func:`finite_poses`). A missing
    file, a bad line or no rows at all is an InputError naming the file (and line)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found; expected a text file with {what}.")
    rows, lines = [], []
    for no, s in content_lines(path, f"a text file with {what}"):
        parts = s.replace(",", " ").split()
        if len(parts) != ncols:
            raise InputError(f"{path}, line {no}: found {len(parts)} values ({s[:60]!r}); expected {what}.")
        try:
            rows.append([float(v) for v in parts])
        except ValueError:
            raise InputError(f"{path}, line {no}: {s[:60]!r} is not all numbers; expected {what}.") from None
        lines.append(no)
    if not rows:
        raise InputError(f"{path}: holds no poses; expected {what}.")
    return np.asarray(rows, dtype=np.float64), lines


def read_pose_lines(path: Path) -> tuple[np.ndarray, list[int]]:
    """Poses (N, 4, 4) float64, m, of a file with :data:`POSE_LINE`, and their line numbers."""
    rows, lines = number_rows(path, 16, POSE_LINE)
    return rows.reshape(-1, 4, 4), lines


def finite_poses(poses: np.ndarray, where: str | Path, lines: Sequence[int] | None = None,
                 skip: bool = True, require_some: bool = True) -> np.ndarray:
    """The rule for non-finite poses: a boolean (N,) mask of the poses (N, 4, 4) whose entries
    are all finite. With ``skip`` the others are to be skipped (the caller reports the count
    with :func:`log_skipped`), unless every pose is non-finite and ``require_some`` (an
    InputError; a file of one pose among many, ScanNet's, passes False); without ``skip`` the
    first non-finite pose is an InputError naming ``where`` and its line (``lines[i]``)."""
    ok = np.isfinite(np.asarray(poses, dtype=np.float64)).reshape(len(poses), -1).all(axis=1)
    if ok.all():
        return ok
    first = int(np.flatnonzero(~ok)[0])
    at = f"{where}, line {lines[first]}" if lines is not None else f"{where}"
    if not skip:
        raise InputError(f"{at}: the pose contains NaN or infinite values; expected a finite 4x4 camera-to-world "
                         f"matrix (world.scene.skip_invalid_poses: true, the default, skips such poses as lost "
                         f"tracking).")
    if require_some and not ok.any():
        raise InputError(f"{where}: every pose has NaN or infinite values; expected finite 4x4 camera-to-world "
                         f"matrices (non-finite ones mark lost tracking and are skipped).")
    return ok


def skip_non_finite(values: np.ndarray, where: str | Path, lines: Sequence[int] | None = None,
                    skip: bool = True) -> np.ndarray:
    """:func:`finite_poses` of a file's poses (or rows), and the one warning counting those
    skipped (:func:`log_skipped`): the mask of the ones to keep."""
    ok = finite_poses(values, where, lines, skip=skip)
    log_skipped(where, int((~ok).sum()), len(ok))
    return ok


def log_skipped(where: str | Path, skipped: int, total: int, what: str = "poses") -> None:
    """One warning with the count of poses (or the frames they belong to: ``what``) skipped for
    NaN/inf pose values (none skipped: silent)."""
    if skipped:
        log.warning("%s: skipped %d of %d %s: NaN/inf in the pose (lost tracking)", where, skipped, total, what)
