"""Camera trajectories: timed camera-to-world poses with slerp interpolation.

Poses are 4x4 camera-to-world matrices in OpenCV camera axes (x right, y down, z forward),
metres; times in seconds. Sources: procedural walking paths through the free space of a
mesh scene (:func:`procedural_trajectories`), or files (:func:`load_tum`, :func:`load_matrix`).
"""
from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.transform import Rotation, Slerp

from ramensim.errors import InputError
from ramensim.world.textfile import content_lines

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
def _read_rows(path: Path, ncols: int, what: str) -> tuple[np.ndarray, list[int]]:
    """Numeric rows of a text file (comments '#' and blank lines skipped); every row must
    have ``ncols`` finite numbers. Returns (rows, 1-based line numbers)."""
    if not path.is_file():
        raise InputError(f"{path}: trajectory file not found; expected {what}.")
    rows, lines = [], []
    for no, s in content_lines(path, f"a text file with {what}"):
        parts = s.replace(",", " ").split()
        if len(parts) != ncols:
            raise InputError(f"{path}, line {no}: found {len(parts)} values ({s[:60]!r}); expected {what}.")
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise InputError(f"{path}, line {no}: {s[:60]!r} is not all numbers; expected {what}.") from None
        if not all(math.isfinite(v) for v in vals):
            raise InputError(f"{path}, line {no}: contains NaN or infinite values ({s[:60]!r}); "
                             f"expected finite numbers ({what}).")
        rows.append(vals)
        lines.append(no)
    if not rows:
        raise InputError(f"{path}: contains no poses; expected {what}.")
    return np.asarray(rows, np.float64), lines


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


def load_tum(path: str | Path, loop: bool = True) -> Trajectory:
    """TUM trajectory: lines 'timestamp tx ty tz qx qy qz qw' (s, m, unit quaternion)."""
    p = Path(path)
    what = "TUM lines 'timestamp tx ty tz qx qy qz qw'"
    rows, lines = _read_rows(p, 8, what)
    poses = np.stack([quat_pose(r[1:4], r[4:8], f"{p}, line {no}") for r, no in zip(rows, lines)])
    t = rows[:, 0]
    _check_increasing(t, lines, p)
    return Trajectory(t - t[0], poses, loop=loop, source=str(p))


def load_matrix(path: str | Path, fps: float, loop: bool = True) -> Trajectory:
    """One row-major 4x4 camera-to-world matrix per line (16 numbers, m), at ``fps`` poses/s."""
    p = Path(path)
    rows, lines = _read_rows(p, 16, "one row-major 4x4 camera-to-world matrix per line (16 numbers)")
    poses = np.stack([check_pose_matrix(r.reshape(4, 4), f"{p}, line {no}") for r, no in zip(rows, lines)])
    return Trajectory(np.arange(len(poses)) / fps, poses, loop=loop, source=str(p))


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
    return _smooth_closed(path, fs, c * 0.6)


def _resample_closed(path: np.ndarray, step: float) -> np.ndarray:
    closed = np.vstack([path, path[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total <= 1e-9:
        return path[:1]
    q = np.arange(0.0, total, step)
    return np.stack([np.interp(q, s, closed[:, k]) for k in range(2)], axis=1)


def _smooth_closed(path: np.ndarray, fs: FreeSpace, min_clear: float) -> np.ndarray:
    """Resample to 5 cm and smooth with a periodic Gaussian, as strongly as keeps every
    point at least ``min_clear`` metres from obstacles."""
    p = _resample_closed(path, 0.05)
    if len(p) < 4:
        return p
    for sigma in (12.0, 8.0, 5.0, 3.0, 1.5, 0.0):
        q = ndimage.gaussian_filter1d(p, sigma, axis=0, mode="wrap") if sigma else p
        j, i = fs.cell(q)
        if np.all(fs.clearance[j, i] >= min_clear) or sigma == 0.0:
            return _resample_closed(q, 0.05)
    return p


def procedural_trajectories(caster, bounds: np.ndarray, n_agents: int, duration: float, cfg,
                            rng: np.random.Generator, rate: float = 10.0) -> list[Trajectory]:
    """Walking-speed camera paths for ``n_agents`` agents through the free space of the mesh
    behind ``caster`` (a :class:`ramensim.world.camera.MeshRayCaster`).

    ``cfg`` is a ProceduralTrajectoryConfig (speed m/s, height m, pitch deg, clearance m,
    split). Each path is a smoothed closed loop walked repeatedly at ``cfg.speed``, sampled
    at ``rate`` poses/s over [0, duration] s. The camera looks along the path blended
    towards the centre of the agent's region (``look_at_center``) and pitches by pitch_deg.
    """
    fs = FreeSpace(caster, bounds, cfg.height)
    regions = _region_masks(fs, n_agents, cfg.split)
    out = []
    times = np.arange(0.0, duration + 1.0 / rate, 1.0 / rate)
    for a in range(n_agents):
        path = _loop_path(fs, regions[a] & fs.free, cfg.clearance, cfg.waypoints, rng)
        closed = np.vstack([path, path[:1]])
        seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        lap = float(arc[-1])
        if lap < 1e-6:
            raise InputError("a procedural trajectory collapsed to a point (its free area is tiny); "
                             "lower world.trajectory.clearance or use split: none.")
        start = float(rng.uniform(0, lap))
        direction = 1.0 if rng.random() < 0.5 else -1.0
        s = np.mod(start + direction * cfg.speed * times, lap)
        xy = np.stack([np.interp(s, arc, closed[:, k]) for k in range(2)], axis=1)
        tangent = np.stack([np.interp(np.mod(s + direction * 0.3, lap), arc, closed[:, k]) for k in range(2)], 1) - xy
        jj, ii = np.nonzero(regions[a] & fs.free)
        centre = fs.centre(jj, ii).mean(axis=0)
        to_c = centre - xy
        tn = tangent / np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
        cn = to_c / np.maximum(np.linalg.norm(to_c, axis=1, keepdims=True), 1e-9)
        fwd = (1 - cfg.look_at_center) * tn + cfg.look_at_center * cn
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
        out.append(Trajectory(times, poses, loop=False, source=f"procedural agent {a}"))
        log.debug("agent %d: lap %.1f m, %d poses", a, lap, len(times))
    return out
