"""The free space of a scene at camera height (:class:`FreeSpace`) and the closed walking loops
of splits 'none' and 'regions' through it; camera poses along a path (:func:`_poses_along`).
Metres, seconds.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from ramensim.core.errors import InputError
from ramensim.world.trajectories.poses import Trajectory, look_rotation


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

def _resample_open(path: np.ndarray, step: float) -> np.ndarray:
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 1e-9:
        return path[:1]
    q = np.concatenate([np.arange(0.0, s[-1], step), [s[-1]]])
    if len(q) > 2 and q[-1] - q[-2] < 0.25 * step:
        q = np.delete(q, -2)
    return np.stack([np.interp(q, s, path[:, k]) for k in range(2)], axis=1)
