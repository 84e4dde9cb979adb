"""Trajectories as timed camera-to-world poses (slerp between them) and their files: TUM
(:func:`load_tum`) and one 4x4 matrix per line (:func:`load_matrix`), checked pose by pose.

Poses are 4x4 camera-to-world matrices in OpenCV camera axes (x right, y down, z forward),
metres; times in seconds.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ramensim.core.errors import InputError
from ramensim.core.posefile import number_rows, read_pose_lines, skip_non_finite


class Trajectory:
    """Poses ``poses`` (N, 4, 4) at strictly increasing ``times`` (N,) in seconds.

    ``pose(t)`` interpolates position linearly and rotation by slerp between the two
    neighbouring samples. Outside [times[0], times[-1]] the pose is held (``loop=False``)
    or the path runs back and forth (``loop=True``, ping-pong).
    """

    def __init__(self, times, poses, loop: bool = False, source: str = "<trajectory>") -> None:
        t = np.asarray(times, np.float64)
        P = np.asarray(poses, np.float64)
        if t.ndim != 1 or P.shape != (len(t), 4, 4) or len(t) == 0:
            raise ValueError(f"{source}: expected times (N,) and poses (N, 4, 4), got {t.shape} and {P.shape}")
        if len(t) > 1 and np.any(np.diff(t) <= 0):
            i = int(np.argmax(np.diff(t) <= 0))
            raise InputError(f"{source}: timestamps must strictly increase, but pose {i + 2} has time "
                             f"{t[i + 1]!r} after {t[i]!r}.")
        self.times, self.poses, self.loop, self.source = t, P, loop, source
        self._rot = Rotation.from_matrix(P[:, :3, :3])
        self._slerp = Slerp(t, self._rot) if len(t) > 1 else None

    @property
    def duration(self) -> float:
        """Time spanned by the samples (s)."""
        return float(self.times[-1] - self.times[0])

    def _wrap(self, t: np.ndarray) -> np.ndarray:
        t0, t1 = self.times[0], self.times[-1]
        if self.loop and t1 > t0:
            span = t1 - t0
            ph = np.mod(t - t0, 2 * span)
            t = t0 + np.where(ph > span, 2 * span - ph, ph)
        return np.clip(t, t0, t1)

    def poses_at(self, ts) -> np.ndarray:
        """Interpolated poses (M, 4, 4) at times ``ts`` (M,) in seconds."""
        ts = self._wrap(np.atleast_1d(np.asarray(ts, np.float64)))
        out = np.tile(np.eye(4), (len(ts), 1, 1))
        out[:, :3, 3] = self.positions_at(ts)
        out[:, :3, :3] = self._slerp(ts).as_matrix() if self._slerp is not None else self.poses[0, :3, :3]
        return out

    def positions_at(self, ts) -> np.ndarray:
        """Interpolated camera centres (M, 3) in metres at times ``ts`` (s)."""
        ts = self._wrap(np.atleast_1d(np.asarray(ts, np.float64)))
        return np.stack([np.interp(ts, self.times, self.poses[:, k, 3]) for k in range(3)], axis=1)

    def pose(self, t: float) -> np.ndarray:
        """Camera-to-world pose (4, 4) at time ``t`` (s)."""
        return self.poses_at([t])[0]

    def position(self, t: float) -> np.ndarray:
        """Camera centre (3,) in metres at time ``t`` (s)."""
        return self.positions_at([t])[0]


# ----------------------------------------------------------------------------- file readers
def _read_rows(path: Path, ncols: int, what: str, skip: bool = True) -> tuple[np.ndarray, list[int]]:
    """Numeric rows of a trajectory file (:func:`ramensim.core.posefile.number_rows`), those
    with a non-finite value skipped by the one rule for lost tracking
    (:func:`ramensim.core.posefile.finite_poses`, one warning with the count; ``skip`` False:
    an error naming the line). Returns (rows, 1-based line numbers)."""
    rows, lines = number_rows(path, ncols, what)
    ok = skip_non_finite(rows, path, lines, skip=skip)
    return rows[ok], [no for no, good in zip(lines, ok) if good]


def quat_pose(txyz: np.ndarray, qxyzw: np.ndarray, where: str) -> np.ndarray:
    """4x4 pose from a translation (m) and a quaternion (x, y, z, w); the quaternion must
    have unit norm (within 1e-2, then renormalised)."""
    n = float(np.linalg.norm(qxyzw))
    if abs(n - 1.0) > 1e-2:
        raise InputError(f"{where}: quaternion {qxyzw.tolist()} has norm {n:.4g}; expected a unit "
                         f"quaternion (qx qy qz qw) describing a rotation.")
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(qxyzw / n).as_matrix()
    T[:3, 3] = txyz
    return T


def check_pose_matrix(T: np.ndarray, where: str, tol: float = 1e-3) -> np.ndarray:
    """Validate a 4x4 camera-to-world matrix: finite, last row [0 0 0 1], rotation block
    orthonormal (|R^T R - I| <= tol) with determinant +1. Returns it with R re-orthonormalised."""
    T = np.asarray(T, np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"{where}: the pose contains NaN or infinite values or is not 4x4; expected a "
                         f"finite 4x4 camera-to-world matrix.")
    if not np.allclose(T[3], [0, 0, 0, 1], atol=1e-6):
        raise InputError(f"{where}: the last row of the pose is {T[3].tolist()}; expected [0, 0, 0, 1].")
    R = T[:3, :3]
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if err > tol or det <= 0:
        raise InputError(f"{where}: the 3x3 block of the pose is not a rotation (|R^T R - I| = {err:.3g}, "
                         f"det = {det:.3g}); expected an orthonormal matrix with determinant +1.")
    U, _, Vt = np.linalg.svd(R)
    out = T.copy()
    out[:3, :3] = U @ Vt
    return out


def load_tum(path: str | Path, loop: bool = True, skip_invalid: bool = True) -> Trajectory:
    """TUM trajectory: lines 'timestamp tx ty tz qx qy qz qw' (s, m, unit quaternion); lines
    with NaN/inf values are skipped as lost tracking (``skip_invalid`` False: an error)."""
    p = Path(path)
    what = "TUM lines 'timestamp tx ty tz qx qy qz qw'"
    rows, lines = _read_rows(p, 8, what, skip_invalid)
    poses = np.stack([quat_pose(r[1:4], r[4:8], f"{p}, line {no}") for r, no in zip(rows, lines)])
    t = rows[:, 0]
    _check_increasing(t, lines, p)
    return Trajectory(t - t[0], poses, loop=loop, source=str(p))


def load_matrix(path: str | Path, fps: float, loop: bool = True) -> Trajectory:
    """One row-major 4x4 camera-to-world matrix per line (16 numbers, m), at ``fps`` poses/s:
    the pose of the k-th line at k / fps s; non-finite poses (lost tracking) are skipped."""
    p = Path(path)
    poses, lines = read_pose_lines(p)
    ok = skip_non_finite(poses, p, lines)  # lost tracking: skipped, the others keep their times
    kept = np.stack([check_pose_matrix(T, f"{p}, line {no}") for T, no, good in zip(poses, lines, ok) if good])
    return Trajectory(np.flatnonzero(ok) / fps, kept, loop=loop, source=str(p))


def _check_increasing(t: np.ndarray, lines: list[int], p: Path) -> None:
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if len(bad):
        i = int(bad[0])
        raise InputError(f"{p}, line {lines[i + 1]}: timestamp {t[i + 1]!r} does not increase after "
                         f"{t[i]!r} (line {lines[i]}); expected strictly increasing timestamps.")


# ----------------------------------------------------------------------------- camera orientation
def look_rotation(forward: np.ndarray, pitch: float = 0.0) -> np.ndarray:
    """Camera-to-world rotation (3, 3) of an OpenCV camera whose optical axis has the
    horizontal heading of ``forward`` (world, z up) and the given ``pitch`` (rad, negative
    looks down); the image x axis stays horizontal."""
    yaw = math.atan2(forward[1], forward[0])
    z = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)])
    x = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


# ----------------------------------------------------------------------------- free space
