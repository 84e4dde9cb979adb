"""Camera trajectories: timed camera-to-world poses with slerp interpolation.

Poses are 4x4 camera-to-world matrices in OpenCV camera axes (x right, y down, z forward),
metres; times in seconds. Sources: procedural walking paths through the free space of a
mesh scene (:func:`procedural_trajectories`; split 'chunks' cuts one tour through every
room, :func:`chunk_tour`, into one contiguous piece per agent), or files (:func:`load_tum`,
:func:`load_matrix`).
"""
from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.transform import Rotation, Slerp

from ramensim.core.errors import InputError
from ramensim.core.posefile import number_rows, read_pose_lines, skip_non_finite

log = logging.getLogger(__name__)


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
class FreeSpace:
    """Walkable floor of a mesh on a 2D grid: a cell is free when, from camera height, a
    ray straight down meets an upward-facing surface at floor level and a ray straight up
    meets a downward-facing one (so the cell is neither inside furniture nor inside a wall).

    ``free`` (ny, nx) bool, ``clearance`` (ny, nx) distance to the nearest non-free cell (m),
    ``floor_z`` (m); cell (j, i) has centre (x0 + (i + 0.5) res, y0 + (j + 0.5) res).
    """

    def __init__(self, caster, bounds: np.ndarray, height: float, res: float = 0.05) -> None:
        self.res = res
        self.x0, self.y0 = float(bounds[0, 0]), float(bounds[0, 1])
        nx = max(2, int(math.ceil((bounds[1, 0] - bounds[0, 0]) / res)))
        ny = max(2, int(math.ceil((bounds[1, 1] - bounds[0, 1]) / res)))
        xs = self.x0 + (np.arange(nx) + 0.5) * res
        ys = self.y0 + (np.arange(ny) + 0.5) * res
        X, Y = np.meshgrid(xs, ys)
        n = X.size
        # floor level: the lowest well-populated upward-facing height seen looking down from
        # mid-height of the bounds (inside a closed room this sees floor and furniture tops)
        top = float(0.5 * (bounds[0, 2] + bounds[1, 2]))
        o = np.stack([X.ravel(), Y.ravel(), np.full(n, top)], axis=1)
        down = np.tile([0.0, 0.0, -1.0], (n, 1))
        s, tri, _, _ = caster.cast(o, down)
        mesh = caster.mesh
        nz = np.zeros(n)
        hit = tri >= 0
        nz[hit] = mesh.face_normals[tri[hit], 2]
        zs = top - s
        cand = zs[hit & (nz > 0.9)]
        if len(cand) == 0:
            cand = zs[hit & (np.abs(nz) > 0.9)]
        if len(cand) == 0:
            raise InputError("the scene mesh has no horizontal floor surface; procedural trajectories "
                             "need a floor (or give trajectory files instead).")
        hist, edges = np.histogram(cand, bins=max(10, int((cand.max() - cand.min()) / 0.02) + 1))
        low = cand.min()
        # the floor: the lowest well-populated height bin (>= 5 % of the columns)
        pop = np.nonzero(hist >= 0.05 * len(cand))[0]
        self.floor_z = float(0.5 * (edges[pop[0]] + edges[pop[0] + 1])) if len(pop) else float(low)
        zc = self.floor_z + height
        o[:, 2] = zc
        s_dn, tri_dn, _, _ = caster.cast(o, down)
        s_up, tri_up, _, _ = caster.cast(o, -down)
        ok_dn = tri_dn >= 0
        ok_up = tri_up >= 0
        nz_dn = np.where(ok_dn, mesh.face_normals[np.maximum(tri_dn, 0), 2], 0.0)
        nz_up = np.where(ok_up, mesh.face_normals[np.maximum(tri_up, 0), 2], 0.0)
        floor_hit = ok_dn & (np.abs((zc - s_dn) - self.floor_z) < 0.06)
        free = floor_hit & (nz_dn > 0.5) & ok_up & (nz_up < -0.5)
        if not free.any():  # inconsistent winding: accept either facing
            free = floor_hit & (np.abs(nz_dn) > 0.5) & ok_up & (np.abs(nz_up) > 0.5)
        if not free.any():
            raise InputError(
                f"world.trajectory.height is {height} m: at {zc:.2f} m (the floor at {self.floor_z:.2f} m "
                f"plus the height) no point of the scene has the floor below and a ceiling above "
                f"(the camera would be above the ceiling, scene top at {float(bounds[1, 2]):.2f} m, or "
                f"inside solid geometry); expected a height between the floor and the ceiling.")
        self.free = free.reshape(ny, nx)
        self.clearance = ndimage.distance_transform_edt(self.free) * res
        self.shape = (ny, nx)

    def centre(self, j: np.ndarray, i: np.ndarray) -> np.ndarray:
        return np.stack([self.x0 + (i + 0.5) * self.res, self.y0 + (j + 0.5) * self.res], axis=-1)

    def cell(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        i = np.clip(((xy[..., 0] - self.x0) / self.res).astype(int), 0, self.shape[1] - 1)
        j = np.clip(((xy[..., 1] - self.y0) / self.res).astype(int), 0, self.shape[0] - 1)
        return j, i


def _grid_graph(mask: np.ndarray):
    """8-connected graph of the True cells of ``mask`` (edge weights in cells); returns the
    CSR graph and the (ny, nx) map from cell to node index (-1 off the mask)."""
    ny, nx = mask.shape
    idx = -np.ones(mask.shape, np.int64)
    jj, ii = np.nonzero(mask)
    idx[jj, ii] = np.arange(len(jj))
    rows, cols, w = [], [], []
    for dj, di in ((0, 1), (1, 0), (1, 1), (1, -1)):
        j2, i2 = jj + dj, ii + di
        inside = (j2 >= 0) & (j2 < ny) & (i2 >= 0) & (i2 < nx)
        src = idx[jj[inside], ii[inside]]
        dst = idx[j2[inside], i2[inside]]
        keep = dst >= 0
        rows.append(src[keep])
        cols.append(dst[keep])
        w.append(np.full(int(keep.sum()), math.hypot(dj, di)))
    r, c, ww = np.concatenate(rows), np.concatenate(cols), np.concatenate(w)
    n = len(jj)
    g = coo_matrix((np.concatenate([ww, ww]), (np.concatenate([r, c]), np.concatenate([c, r]))), shape=(n, n))
    return g.tocsr(), idx


def _region_masks(fs: FreeSpace, n: int, split: str) -> list[np.ndarray]:
    """Per agent, the free cells of its region: i-th of n equal slabs along the longest
    horizontal axis of the free space ('regions'), or all of it ('none')."""
    if split == "none" or n == 1:
        return [np.ones(fs.shape, bool)] * n
    jj, ii = np.nonzero(fs.free)
    xy = fs.centre(jj, ii)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    axis = int(np.argmax(hi - lo))
    J, I = np.indices(fs.shape)
    coord = fs.centre(J, I)[..., axis]
    edges = np.linspace(lo[axis], hi[axis] + 1e-9, n + 1)
    return [(coord >= edges[k]) & (coord < edges[k + 1]) for k in range(n)]


def _split_too_fine(fs: FreeSpace, n: int, cfg: Any, agent: int, what: str) -> str:
    """The one-paragraph refusal of a team whose regions leave an agent no room to walk."""
    if cfg.split != "regions" or n == 1:
        return (f"world.trajectory: agent {agent} has no room for a procedural path in the scene's free "
                f"space ({what}); lower world.trajectory.clearance ({cfg.clearance:g} m) or give trajectory files.")
    jj, ii = np.nonzero(fs.free)
    xy = fs.centre(jj, ii)
    width = float((xy.max(axis=0) - xy.min(axis=0)).max()) / n
    return (f"world.trajectory.split: 'regions' cuts the scene's free space into {n} slabs {width:.2f} m wide, "
            f"too narrow for agent {agent}'s loop ({what}); for {n} robots use split: chunks (one tour cut "
            f"into {n} pieces), split: none (every robot anywhere), fewer robots, or a clearance below "
            f"{cfg.clearance:g} m.")


def _loop_path(fs: FreeSpace, region: np.ndarray, clearance: float, n_way: int,
               rng: np.random.Generator) -> np.ndarray:
    """A closed path (M, 2) through ``n_way`` random waypoints in the largest connected
    free area of ``region`` with at least ``clearance`` metres to obstacles, joined by
    shortest grid paths and smoothed."""
    ok = region & (fs.clearance >= clearance)
    c = clearance
    while ok.sum() < 20 and c > 0.1:  # tight spaces: relax the clearance
        c *= 0.8
        ok = region & (fs.clearance >= c)
    lab, nlab = ndimage.label(ok, structure=np.ones((3, 3)))
    if nlab == 0:
        raise InputError("no free floor area was found for a procedural trajectory in an agent's region "
                         "(the scene is too cluttered or too small); lower world.trajectory.clearance, "
                         "use split: none, or give trajectory files.")
    sizes = ndimage.sum(ok, lab, index=np.arange(1, nlab + 1))
    comp = lab == (1 + int(np.argmax(sizes)))
    g, idx = _grid_graph(comp)
    jj, ii = np.nonzero(comp)
    # waypoints: spread out (farthest-point sampling from a random start)
    pts = fs.centre(jj, ii)
    chosen = [int(rng.integers(len(pts)))]
    dmin = np.linalg.norm(pts - pts[chosen[0]], axis=1)
    for _ in range(n_way - 1):
        # random among the farthest 10 % keeps variety between seeds
        far = np.argsort(dmin)[-max(1, len(dmin) // 10):]
        k = int(far[rng.integers(len(far))])
        chosen.append(k)
        dmin = np.minimum(dmin, np.linalg.norm(pts - pts[k], axis=1))
    wp = pts[chosen]
    ctr = wp.mean(axis=0)
    order = np.argsort(np.arctan2(wp[:, 1] - ctr[1], wp[:, 0] - ctr[0]))
    nodes = idx[jj[chosen], ii[chosen]][order]
    _, pred = dijkstra(g, indices=nodes, return_predecessors=True)
    cells = []
    for a in range(len(nodes)):
        src, dst = a, nodes[(a + 1) % len(nodes)]
        seg = []
        v = dst
        while v != nodes[src] and v >= 0:
            seg.append(v)
            v = pred[src, v]
        seg.append(nodes[src])
        cells.extend(reversed(seg[1:]))  # src .. the cell before dst: no duplicate joints
    flat = np.nonzero(comp.ravel())[0][np.asarray(cells)]
    path = fs.centre(*np.unravel_index(flat, fs.shape))
    return _smooth(path, fs, c * 0.6, closed=True)


def _resample_closed(path: np.ndarray, step: float) -> np.ndarray:
    closed = np.vstack([path, path[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total <= 1e-9:
        return path[:1]
    q = np.arange(0.0, total, step)
    return np.stack([np.interp(q, s, closed[:, k]) for k in range(2)], axis=1)


def _smooth(path: np.ndarray, fs: FreeSpace, min_clear: float, closed: bool) -> np.ndarray:
    """Resample to 5 cm and smooth with a Gaussian (periodic for a closed loop; mode 'nearest'
    for an open path, whose ends stay put), as strongly as keeps every point at least
    ``min_clear`` metres from obstacles."""
    resample = _resample_closed if closed else _resample_open
    p = resample(path, 0.05)
    if len(p) < 4:
        return p
    for sigma in (12.0, 8.0, 5.0, 3.0, 1.5, 0.0):
        q = ndimage.gaussian_filter1d(p, sigma, axis=0, mode="wrap" if closed else "nearest") if sigma else p
        j, i = fs.cell(q)
        if np.all(fs.clearance[j, i] >= min_clear) or sigma == 0.0:
            return resample(q, 0.05)
    return p


def procedural_trajectories(caster, bounds: np.ndarray, n_agents: int, duration: float, cfg,
                            rng: np.random.Generator, rate: float = 10.0) -> list[Trajectory]:
    """Walking-speed camera paths for ``n_agents`` agents through the free space of the mesh
    behind ``caster`` (a :class:`ramensim.world.camera.MeshRayCaster`).

    ``cfg`` is a ProceduralTrajectoryConfig (speed m/s, height m, pitch deg, clearance m,
    split), sampled at ``rate`` poses/s over [0, duration] s. Split 'none' / 'regions': each
    path is a smoothed closed loop in the agent's region walked repeatedly at ``cfg.speed``;
    the camera looks along the path blended towards the centre of the agent's region
    (``look_at_center``). Split 'chunks': one tour through every room (:func:`chunk_tour`) is
    cut by arc length into ``n_agents`` equal contiguous chunks; agent i walks chunk i from
    its start at ``cfg.speed`` (or ``cfg.chunk_passes`` times over the run, each agent at its
    own speed, chunk length x passes / duration in m/s) and back (ping-pong), looking along the path blended towards
    the centre of the room it is in. The camera pitches by pitch_deg in both cases. With
    ``chunk_passes`` the speed depends on ``duration``, so a shorter run's path is not the
    beginning of a longer one's (it is otherwise, up to the heading's smoothing radius).
    """
    fs = FreeSpace(caster, bounds, cfg.height)
    times = np.arange(0.0, duration + 1.0 / rate, 1.0 / rate)
    if cfg.split == "chunks":
        return _chunk_trajectories(fs, caster, bounds, n_agents, times, cfg, rng, rate, duration)
    regions = _region_masks(fs, n_agents, cfg.split)
    out = []
    for a in range(n_agents):
        try:
            path = _loop_path(fs, regions[a] & fs.free, cfg.clearance, cfg.waypoints, rng)
        except InputError as exc:
            raise InputError(_split_too_fine(fs, n_agents, cfg, a, str(exc))) from None
        closed = np.vstack([path, path[:1]])
        seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        lap = float(arc[-1])
        if lap < 1e-6:
            raise InputError(_split_too_fine(fs, n_agents, cfg, a, "its loop collapsed to a point"))
        start = float(rng.uniform(0, lap))
        direction = 1.0 if rng.random() < 0.5 else -1.0
        s = np.mod(start + direction * cfg.speed * times, lap)
        xy = np.stack([np.interp(s, arc, closed[:, k]) for k in range(2)], axis=1)
        tangent = np.stack([np.interp(np.mod(s + direction * 0.3, lap), arc, closed[:, k]) for k in range(2)], 1) - xy
        jj, ii = np.nonzero(regions[a] & fs.free)
        centre = fs.centre(jj, ii).mean(axis=0)
        out.append(_poses_along(xy, tangent, centre, times, fs, cfg, rng, rate, f"procedural agent {a}"))
        log.debug("agent %d: lap %.1f m, %d poses", a, lap, len(times))
    return out


def _poses_along(xy: np.ndarray, tangent: np.ndarray, centre: np.ndarray, times: np.ndarray, fs: FreeSpace,
                 cfg, rng: np.random.Generator, rate: float, source: str, look=None) -> Trajectory:
    """Camera poses at positions ``xy`` (T, 2) m: heading along ``tangent`` (T, 2) blended
    towards ``centre`` ((2,) or (T, 2) m) by ``look`` (scalar or (T,); default
    cfg.look_at_center), smoothed over ~1.6 s; height and pitch sway slowly (a random phase
    drawn from ``rng``)."""
    w = np.reshape(cfg.look_at_center if look is None else look, (-1, 1))
    to_c = centre - xy
    tn = tangent / np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
    cn = to_c / np.maximum(np.linalg.norm(to_c, axis=1, keepdims=True), 1e-9)
    fwd = (1 - w) * tn + w * cn
    bad = np.linalg.norm(fwd, axis=1) < 1e-3
    fwd[bad] = tn[bad]
    yaw = np.unwrap(np.arctan2(fwd[:, 1], fwd[:, 0]))
    yaw = ndimage.gaussian_filter1d(yaw, sigma=rate * 0.8, mode="nearest")  # ~1.6 s turn smoothing
    phase = float(rng.uniform(0, 2 * np.pi))
    z = fs.floor_z + cfg.height + cfg.height_variation * np.sin(2 * np.pi * times / 12.0 + phase)
    pitch = math.radians(cfg.pitch_deg) + math.radians(5.0) * np.sin(2 * np.pi * times / 9.0 + 2 * phase)
    poses = np.tile(np.eye(4), (len(times), 1, 1))
    for k in range(len(times)):
        poses[k, :3, :3] = look_rotation(np.array([math.cos(yaw[k]), math.sin(yaw[k]), 0.0]), float(pitch[k]))
    poses[:, 0, 3], poses[:, 1, 3], poses[:, 2, 3] = xy[:, 0], xy[:, 1], z
    return Trajectory(times, poses, loop=False, source=source)


# ----------------------------------------------------------------------------- split 'chunks'
STRUCTURE_HEIGHT = 1.9  # m above the floor: rooms are found in the open space at this height (walls, no furniture)
ROOM_CLEARANCE = 0.55   # m; open cells this far from walls are room cores (doorways < 1.1 m wide separate them)
MIN_ROOM_AREA = 1.0    # m^2; smaller seed areas are not rooms of their own
MIN_CHUNK_M = 0.5      # m; shortest chunk of the tour an agent may be given
END_TURN_M = 1.5       # m; before a cut to a teammate's chunk the camera turns to its room's centre


@dataclass
class Tour:
    """One walk through the whole free space of a scene (split 'chunks').

    ``path`` (M, 2) m, a point every ~5 cm; ``arc`` (M,) m, arc length from the start;
    ``rooms`` (ny, nx) int, the room of every free cell of ``fs`` (-1 elsewhere; rooms =
    free areas separated by walls and doorways); ``centres`` (R, 2)
    m, the centre of each room; ``order``: the rooms in the order the tour visits them;
    ``path_room`` (M,) int, the room of each path point.
    """

    path: np.ndarray
    arc: np.ndarray
    rooms: np.ndarray
    centres: np.ndarray
    order: list[int]
    path_room: np.ndarray
    fs: FreeSpace

    @property
    def length(self) -> float:
        """Arc length of the whole tour (m)."""
        return float(self.arc[-1])

    @property
    def doorways(self) -> np.ndarray:
        """Arc lengths (m) where the tour passes from one room into the next."""
        k = np.nonzero(np.diff(self.path_room) != 0)[0]
        return 0.5 * (self.arc[k] + self.arc[k + 1])

    def edges(self, n: int, snap: float = 0.0) -> np.ndarray:
        """Arc lengths (n + 1,) m cutting the tour into ``n`` contiguous chunks of equal length
        L / n, except that each cut moves onto the nearest doorway within ``snap`` L / n of it
        (so a robot's chunk ends at a door rather than a little way into the next room) where
        every chunk keeps at least half the equal length. Strictly increasing."""
        e = np.linspace(0.0, self.length, n + 1)
        doors = self.doorways
        step = self.length / n
        if n > 1 and len(doors) and snap > 0:
            for k in range(1, n):
                j = int(np.argmin(np.abs(doors - e[k])))
                d = float(doors[j])
                # with snap <= 0.5 the chunk after this cut keeps at least half a chunk too
                if abs(d - e[k]) <= min(snap, 0.5) * step and d - e[k - 1] >= 0.5 * step:
                    e[k] = d
        return e

    def at(self, s) -> np.ndarray:
        """Points (K, 2) m at arc lengths ``s`` (K,) m (clipped to the tour)."""
        s = np.asarray(s, np.float64)
        return np.stack([np.interp(s, self.arc, self.path[:, k]) for k in range(2)], axis=-1)

    def room_at(self, s) -> np.ndarray:
        """Room index (K,) of the tour at arc lengths ``s`` (K,) m."""
        k = np.clip(np.searchsorted(self.arc, np.asarray(s, np.float64)), 0, len(self.arc) - 1)
        return self.path_room[k]


def _structure_free(caster, fs: FreeSpace, height: float = STRUCTURE_HEIGHT) -> np.ndarray:
    """(ny, nx) bool: the cells of ``fs``'s grid that are open at ``height`` m above the floor
    (a ray down meets an upward-facing surface, a ray up a downward-facing one), i.e. not
    inside walls or full-height structure. Below doorway lintels and above most furniture,
    so rooms there are empty rectangles joined by their doorways."""
    ny, nx = fs.shape
    J, I = np.indices(fs.shape)
    xy = fs.centre(J.ravel(), I.ravel())
    o = np.column_stack([xy, np.full(len(xy), fs.floor_z + height)])
    down = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    _, tri_dn, _, _ = caster.cast(o, down)
    _, tri_up, _, _ = caster.cast(o, -down)
    nz = caster.mesh.face_normals[:, 2]
    ok = (tri_dn >= 0) & (tri_up >= 0)
    open_ = ok & (nz[np.maximum(tri_dn, 0)] > 0.5) & (nz[np.maximum(tri_up, 0)] < -0.5)
    if not open_.any():  # inconsistent winding: accept either facing
        open_ = ok & (np.abs(nz[np.maximum(tri_dn, 0)]) > 0.5) & (np.abs(nz[np.maximum(tri_up, 0)]) > 0.5)
    return open_.reshape(ny, nx)


def _segment_rooms(caster, fs: FreeSpace) -> tuple[np.ndarray, np.ndarray]:
    """Rooms of the free space, from the structure (walls) only: the open cells at
    STRUCTURE_HEIGHT at least ROOM_CLEARANCE from a wall form connected areas (a doorway
    narrower than twice that cuts them apart); those of at least MIN_ROOM_AREA are the rooms'
    cores, and every walkable cell joins the core nearest to it along the open space.
    Returns the (ny, nx) room map (-1 off the walkable space) and the rooms' centres (R, 2) m
    (mean of their walkable cells)."""
    struct = _structure_free(caster, fs) | fs.free
    clear = ndimage.distance_transform_edt(struct) * fs.res
    seeds = struct & (clear >= ROOM_CLEARANCE)
    lab, nlab = ndimage.label(seeds, structure=np.ones((3, 3)))
    sizes = ndimage.sum(seeds, lab, index=np.arange(1, nlab + 1)) * fs.res ** 2 if nlab else np.zeros(0)
    keep = [k + 1 for k in range(nlab) if sizes[k] >= MIN_ROOM_AREA]
    g, idx = _grid_graph(struct)
    seed_lab = np.full(fs.shape, -1, np.int64)
    for r, k in enumerate(keep):
        seed_lab[lab == k] = r
    rooms = np.full(fs.shape, -1, np.int64)
    if keep:
        dist, _, sources = dijkstra(g, indices=idx[seed_lab >= 0], min_only=True, return_predecessors=True)
        jj, ii = np.nonzero(struct)
        reach = np.isfinite(dist)
        rooms[jj[reach], ii[reach]] = seed_lab[struct][sources[reach]]
    rooms[~fs.free] = -1
    present = [r for r in range(len(keep)) if np.any(rooms == r)]
    if not present:  # no spacious area: the whole walkable space is one room
        rooms = np.where(fs.free, 0, -1)
        present = [0] if fs.free.any() else []
    if not present:
        raise InputError("no free floor area was found for a procedural trajectory (the scene is too cluttered "
                         "or too small); lower world.trajectory.clearance or give trajectory files.")
    remap = np.full(max(present) + 2, -1, np.int64)
    remap[np.asarray(present)] = np.arange(len(present))
    rooms = np.where(rooms >= 0, remap[rooms], -1)
    centres = np.stack([fs.centre(*np.nonzero(rooms == r)).mean(axis=0) for r in range(len(present))])
    return rooms, centres


def _weighted_graph(mask: np.ndarray, clearance: np.ndarray, want: float):
    """:func:`_grid_graph` of ``mask`` whose edges cost more near obstacles (up to 3x at no
    clearance, 1x at ``want`` metres or more), so shortest paths keep to the middle of
    passages and doorways."""
    g, idx = _grid_graph(mask)
    cl = clearance[mask]
    rows = np.repeat(np.arange(g.shape[0]), np.diff(g.indptr))
    c = np.minimum(cl[rows], cl[g.indices])
    g.data = g.data * (1.0 + 2.0 * np.clip(1.0 - c / want, 0.0, 1.0))
    return g, idx


def _farthest_points(pts: np.ndarray, n: int, rng: np.random.Generator) -> list[int]:
    """``n`` spread-out indices into ``pts`` (farthest-point sampling from a random start,
    each pick random among the farthest 10 %)."""
    chosen = [int(rng.integers(len(pts)))]
    dmin = np.linalg.norm(pts - pts[chosen[0]], axis=1)
    for _ in range(min(n, len(pts)) - 1):
        far = np.argsort(dmin, kind="stable")[-max(1, len(dmin) // 10):]
        k = int(far[rng.integers(len(far))])
        chosen.append(k)
        dmin = np.minimum(dmin, np.linalg.norm(pts - pts[k], axis=1))
    return chosen


def _open_order(D: np.ndarray, entry: np.ndarray | None, exit_: np.ndarray | None) -> list[int]:
    """Order the items 0..m-1 (distance matrix ``D`` (m, m)) as an open path of least length,
    counting the distances ``entry`` (m,) from where the path comes from and ``exit_`` (m,) to
    where it goes next (either may be None): exhaustive up to 7 items, else nearest neighbour
    improved by 2-opt."""
    m = len(D)
    e = np.zeros(m) if entry is None else np.asarray(entry, float)
    x = np.zeros(m) if exit_ is None else np.asarray(exit_, float)

    def cost(seq) -> float:
        return e[seq[0]] + x[seq[-1]] + sum(D[a, b] for a, b in zip(seq[:-1], seq[1:]))

    if m <= 7:
        return list(min(itertools.permutations(range(m)), key=cost))
    cur = int(np.argmin(e)) if entry is not None else (int(np.argmax(x)) if exit_ is not None else 0)
    seq, rest = [cur], set(range(m)) - {cur}
    while rest:
        cur = min(sorted(rest), key=lambda k: D[cur, k])
        seq.append(cur)
        rest.remove(cur)
    improved = True
    while improved:
        improved = False
        for i in range(m - 1):
            for j in range(i + 1, m):
                cand = seq[:i] + seq[i:j + 1][::-1] + seq[j + 1:]
                if cost(cand) < cost(seq) - 1e-9:
                    seq, improved = cand, True
    return seq


def _trace(pred: np.ndarray, src: int, dst: int) -> list[int]:
    """Nodes of the shortest path from ``src`` (excluded) to ``dst`` (included) given the
    predecessor row of a Dijkstra search from ``src``."""
    seg, v = [], dst
    while v != src and v >= 0:
        seg.append(int(v))
        v = pred[v]
    return seg[::-1]


class _RoomSweep:
    """Candidate waypoints of one room for the tour: up to 3x the base count (one per ~3 m^2
    of the room's floor, 2 to cfg.waypoints), spread out by farthest-point sampling over the
    largest walkable piece of the room (preferring cells cfg.clearance from obstacles), with
    shortest-path distances and predecessors inside the room. ``nodes`` = their nodes in the
    tour's graph; ``local`` = in the room's subgraph, whose nodes are the graph's ``ids``."""

    def __init__(self, fs: FreeSpace, g, idx: np.ndarray, mask: np.ndarray, cfg, c_path: float,
                 rng: np.random.Generator) -> None:
        lab, nlab = ndimage.label(mask, structure=np.ones((3, 3)))
        if nlab > 1:
            sizes = ndimage.sum(mask, lab, index=np.arange(1, nlab + 1))
            mask = lab == (1 + int(np.argmax(sizes)))
        jj, ii = np.nonzero(mask)
        pts = fs.centre(jj, ii)
        area = float(mask.sum()) * fs.res ** 2
        self.n_base = int(np.clip(round(area / 3.0), 2, cfg.waypoints))
        n_max = 3 * self.n_base
        c = cfg.clearance
        sel = fs.clearance[jj, ii] >= c
        while sel.sum() < 4 * n_max and c > c_path:
            c *= 0.8
            sel = fs.clearance[jj, ii] >= c
        if sel.sum() < 2:
            sel = np.ones(len(jj), bool)
        ks = np.nonzero(sel)[0]
        self.ids = idx[jj, ii]
        self.local = [int(ks[k]) for k in _farthest_points(pts[ks], n_max, rng)]
        self.n_base = min(self.n_base, len(self.local))
        self.nodes = self.ids[self.local]
        sub = g[self.ids][:, self.ids]
        d, self.pred = dijkstra(sub, indices=self.local, return_predecessors=True)
        self.dist = np.atleast_2d(d)[:, self.local]
        self.pred = np.atleast_2d(self.pred)


def chunk_tour(caster, bounds: np.ndarray, cfg, rng: np.random.Generator, fs: FreeSpace | None = None) -> Tour:
    """The tour of split 'chunks': one open walk that visits every room of the scene in turn.

    Rooms are the free areas separated by walls and doorways (:func:`_segment_rooms`; in the
    built-in house its six rooms). They are visited in nearest-neighbour order of their
    distances along the free space, starting at an end of the longest room-to-room route (the
    one nearer the origin; for the house: the serpentine chain of its doorways, from the room
    at x, y = 0). In each room the tour walks through spread-out waypoints (farthest-point
    sampling, preferably ``cfg.clearance`` from obstacles) so the camera sweeps it: as many of
    them (at least 2) as makes its share of the tour closest to the median room's share with
    one waypoint per ~3 m^2 of floor (2 to ``cfg.waypoints``), so that rooms get about equal
    lengths of tour. Waypoints are joined by shortest paths that keep to the middle of
    doorways, and the path is smoothed (Gaussian, mode 'nearest', as strongly as keeps 60 % of
    the clearance from obstacles). A scene with one room gets one long path through all its
    waypoints (up to 3 per ~3 m^2). Deterministic for the state of ``rng``.
    """
    fs = fs or FreeSpace(caster, bounds, cfg.height)
    rooms, centres = _segment_rooms(caster, fs)
    n_rooms = len(centres)
    c_path = 0.6 * cfg.clearance
    while True:  # the walkable graph: relax the clearance until most of every room is reachable
        walk = fs.free & (fs.clearance >= c_path) & (rooms >= 0)
        lab, nlab = ndimage.label(walk, structure=np.ones((3, 3)))
        if nlab == 0:
            main = walk
        else:
            sizes = ndimage.sum(walk, lab, index=np.arange(1, nlab + 1))
            main = lab == (1 + int(np.argmax(sizes)))
        n_walk = np.bincount(rooms[walk], minlength=n_rooms)
        n_main = np.bincount(rooms[main], minlength=n_rooms)
        reached = {r for r in range(n_rooms) if n_main[r] > 0}
        if np.all(n_main >= 0.5 * n_walk) and len(reached) == n_rooms or c_path <= 0.1:
            break
        c_path *= 0.8
    if main.sum() < 2:
        raise InputError("no free floor area was found for a procedural trajectory (the scene is too cluttered "
                         "or too small); lower world.trajectory.clearance or give trajectory files.")
    if len(reached) < n_rooms:
        log.warning("split chunks: %d of %d rooms cannot be reached at %.2f m from obstacles; the tour skips them",
                    n_rooms - len(reached), n_rooms, c_path)
    g, idx = _weighted_graph(main, fs.clearance, cfg.clearance)
    rs = sorted(reached)
    anchors = []  # each room's walkable cell nearest its centre
    for r in rs:
        jj, ii = np.nonzero(main & (rooms == r))
        k = int(np.argmin(np.linalg.norm(fs.centre(jj, ii) - centres[r], axis=1)))
        anchors.append(int(idx[jj[k], ii[k]]))
    d_anc = np.atleast_2d(dijkstra(g, indices=anchors))
    # room order: nearest neighbour along the free space from an end of the longest route
    DR = d_anc[:, anchors]
    order_i = [0]
    if len(rs) > 1:
        i, j = np.unravel_index(int(np.argmax(DR)), DR.shape)
        order_i = [min((int(i), int(j)), key=lambda k: float(centres[rs[k]].sum()))]
        while len(order_i) < len(rs):
            cur = order_i[-1]
            order_i.append(min((k for k in range(len(rs)) if k not in order_i), key=lambda k: DR[cur, k]))
    order = [rs[k] for k in order_i]
    sweeps = [_RoomSweep(fs, g, idx, main & (rooms == rs[k]), cfg, c_path, rng) for k in order_i]

    def plan(k: int, prev: int | None, d_prev: np.ndarray | None, m: int) -> tuple[list[int], float]:
        """Order the first m waypoints of the k-th room of the tour; its length (m) counts half
        of the legs in from ``prev`` (distances d_prev) and out to the next room's anchor."""
        sw = sweeps[k]
        entry = d_prev[sw.nodes[:m]] if prev is not None else None
        exit_ = d_anc[order_i[k + 1]][sw.nodes[:m]] if k + 1 < len(order) else None
        seq = _open_order(sw.dist[:m, :m], entry, exit_)
        length = sum(sw.dist[a, b] for a, b in zip(seq[:-1], seq[1:]))
        length += 0.5 * (entry[seq[0]] if entry is not None else 0.0)
        length += 0.5 * (exit_[seq[-1]] if exit_ is not None else 0.0)
        return seq, float(length)

    # every room gets about the same length of tour (the median room's sweep through its base
    # number of waypoints): each room walks through as many of its waypoints (at least 2) as
    # comes closest, so equal chunks of the tour hold whole rooms
    target = float(np.median([plan(k, order_i[k - 1] if k else None, d_anc[order_i[k - 1]] if k else None,
                                   sweeps[k].n_base)[1] for k in range(len(order))]))
    if len(order) == 1:  # a single room: one long path through all its waypoints
        target = np.inf
    cells: list[int] = []
    prev, d_prev, p_prev = None, None, None
    for k, sw in enumerate(sweeps):
        options = [plan(k, prev, d_prev, m) for m in range(min(2, len(sw.nodes)), len(sw.nodes) + 1)]
        seq, _ = min(reversed(options), key=lambda o: abs(o[1] - target))
        first = sw.nodes[seq[0]]
        if prev is None:
            cells.append(first)
        else:
            cells.extend(_trace(p_prev, prev, first))
        for a_, b_ in zip(seq[:-1], seq[1:]):
            cells.extend(int(sw.ids[v]) for v in _trace(sw.pred[a_], sw.local[a_], sw.local[b_]))
        prev = sw.nodes[seq[-1]]
        if k + 1 < len(sweeps):
            d_prev, p_prev = dijkstra(g, indices=prev, return_predecessors=True)
    flat = np.nonzero(main.ravel())[0][np.asarray(cells, np.int64)]
    path = _smooth(fs.centre(*np.unravel_index(flat, fs.shape)), fs, c_path, closed=False)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    j, i = fs.cell(path)
    pr = rooms[j, i]
    for k in range(len(pr)):  # points off the room map (none expected): the previous point's room
        if pr[k] < 0:
            pr[k] = pr[k - 1] if k > 0 else order[0]
    log.debug("split chunks: %d rooms, order %s, tour %.1f m", n_rooms, order, arc[-1])
    return Tour(path, arc, rooms, centres, order, pr, fs)


def _resample_open(path: np.ndarray, step: float) -> np.ndarray:
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 1e-9:
        return path[:1]
    q = np.concatenate([np.arange(0.0, s[-1], step), [s[-1]]])
    if len(q) > 2 and q[-1] - q[-2] < 0.25 * step:
        q = np.delete(q, -2)
    return np.stack([np.interp(q, s, path[:, k]) for k in range(2)], axis=1)


def _chunk_trajectories(fs: FreeSpace, caster, bounds, n_agents: int, times: np.ndarray, cfg,
                        rng: np.random.Generator, rate: float, duration: float) -> list[Trajectory]:
    tour = chunk_tour(caster, bounds, cfg, rng, fs)
    edges = tour.edges(n_agents, cfg.chunk_snap)
    chunk = float(np.min(np.diff(edges)))
    if chunk < MIN_CHUNK_M:
        raise InputError(f"world.trajectory.split: 'chunks' cuts the {tour.length:.1f} m tour through the free space "
                         f"of the scene into {n_agents} chunks, the shortest {chunk:.2f} m, under the {MIN_CHUNK_M} m "
                         f"each agent needs to walk; use fewer agents, a larger scene (e.g. the built-in 'house'), "
                         f"a lower world.trajectory.clearance, or split: 'regions' or 'none'.")
    out = []
    for a in range(n_agents):
        s0, L = float(edges[a]), float(edges[a + 1] - edges[a])
        # m/s: the configured walking speed, or the one that walks the chunk chunk_passes times
        # over the run's duration (s)
        speed = cfg.speed if cfg.chunk_passes is None else cfg.chunk_passes * L / max(float(duration), 1e-9)
        u = np.mod(speed * times, 2 * L)  # ping-pong inside the chunk, from its start
        forward = u <= L
        s = s0 + np.where(forward, u, 2 * L - u)
        direction = np.where(forward, 1.0, -1.0)[:, None]
        xy = tour.at(s)
        tangent = (tour.at(np.clip(s + 0.15, s0, s0 + L)) - tour.at(np.clip(s - 0.15, s0, s0 + L))) * direction
        # the room whose centre the camera looks at: the one the agent is in (at a cut on a
        # doorway, the one on the agent's own side)
        inner = min(0.3, 0.5 * L)
        centre = tour.centres[tour.room_at(np.clip(s, s0 + inner, s0 + L - inner))]
        # the camera looks fully at that centre over the last END_TURN_M before a cut to a
        # teammate's chunk, and when walking away from the centre (towards a wall or a doorway):
        # the robot looks into its own part rather than out of a doorway into a teammate's, and
        # never blends two opposite directions
        to_end = np.minimum(s - s0 if a > 0 else np.inf, s0 + L - s if a < n_agents - 1 else np.inf)
        ramp = np.clip(1.0 - to_end / END_TURN_M, 0.0, 1.0)
        to_c = centre - xy
        tn = tangent / np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
        cos = np.sum(tn * to_c, axis=1) / np.maximum(np.linalg.norm(to_c, axis=1), 1e-9)
        away = np.clip(-cos / 0.5, 0.0, 1.0)
        w = cfg.look_at_center
        look = w + (1.0 - w) * np.maximum(ramp, away) if w > 0 else 0.0
        out.append(_poses_along(xy, tangent, centre, times, fs, cfg, rng, rate, f"procedural agent {a} (chunk {a})",
                                look))
        log.debug("agent %d: chunk %.1f-%.1f m of a %.1f m tour, %d poses", a, s0, s0 + L, tour.length, len(times))
    return out
