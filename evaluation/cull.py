"""Cull meshes to what the cameras saw (NICE-SLAM's evaluation protocol, docs/ALGORITHM.md section 5).

A vertex is *seen* if, for at least one camera pose, it projects inside the image, lies
between the near and far planes and -- with occlusion -- is not behind the surface that
camera sees (depth rendered from the ground-truth mesh by ray casting, or given depth
maps). A face is culled when all three of its vertices are unseen. The same test is
applied to the reconstruction and to the ground truth, so neither is scored on space the
robots never looked at. Poses are camera-to-world 4x4 matrices with OpenCV axes
(x right, y down, z forward), metres.
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import trimesh

from ramensim.core.frames import Intrinsics
from ramensim.core.posefile import read_pose_lines, skip_non_finite
from ramensim.evaluation import _native

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class PinholeCamera(Intrinsics):
    """The visibility frustum of a camera: its pinhole intrinsics (:class:`ramensim.core.frames.Intrinsics`:
    fx, fy, cx, cy, width, height in pixels; one camera type for the world and the culling)
    with the near/far planes of the frustum in metres."""

    near_m: float = 0.0
    far_m: float = 1.0e6

    @classmethod
    def of(cls, K: Intrinsics, near_m: float = 0.0, far_m: float = 1.0e6) -> "PinholeCamera":
        """The frustum of a camera with intrinsics ``K`` between ``near_m`` and ``far_m`` (m)."""
        return cls(K.fx, K.fy, K.cx, K.cy, K.width, K.height, near_m, far_m)

    def __post_init__(self) -> None:
        bad = [f"{k} = {getattr(self, k)!r}" for k in ("fx", "fy", "width", "height")
               if not (np.isfinite(getattr(self, k)) and getattr(self, k) > 0)]
        if not (np.isfinite(self.cx) and np.isfinite(self.cy)):
            bad.append(f"cx, cy = {self.cx!r}, {self.cy!r}")
        if not (0.0 <= self.near_m < self.far_m):
            bad.append(f"near_m, far_m = {self.near_m!r}, {self.far_m!r}")
        if bad:
            raise ValueError(f"PinholeCamera: {'; '.join(bad)} invalid; expected fx, fy > 0 px, finite "
                             f"cx, cy (px), width, height > 0 px and 0 <= near_m < far_m (metres).")


def load_poses(path: str | Path) -> np.ndarray:
    """Read camera-to-world poses: a ``.npy`` of shape (N, 4, 4) or (N, 16), or a text file
    with one row-major 4x4 per line (:func:`ramensim.core.posefile.read_pose_lines`: 16 numbers
    separated by spaces or commas; blank lines and ``#`` comments skipped). Poses with
    non-finite entries (lost tracking) are skipped with one warning, by the rule of every pose
    file (:func:`ramensim.core.posefile.finite_poses`). Returns (N, 4, 4) float64.

    Raises FileNotFoundError, or ValueError (an InputError) naming the file, the line and what
    was expected."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: poses file not found; expected a .npy of shape (N, 4, 4) or a "
                                f"text file with one row-major 4x4 camera-to-world matrix per line.")
    lines = None
    if p.suffix.lower() == ".npy":
        try:
            arr = np.load(p, allow_pickle=False)
        except Exception as exc:
            raise ValueError(f"{p}: cannot be read as a .npy array ({exc}); expected a float array of "
                             f"shape (N, 4, 4).") from None
        if arr.ndim == 2 and arr.shape[1] == 16:
            arr = arr.reshape(-1, 4, 4)
        if arr.ndim != 3 or arr.shape[1:] != (4, 4):
            raise ValueError(f"{p}: array of shape {arr.shape}; expected (N, 4, 4) camera-to-world poses.")
        if len(arr) == 0:
            raise ValueError(f"{p}: holds no poses; expected at least one 4x4 camera-to-world matrix.")
        poses = arr.astype(np.float64)
    else:
        poses, lines = read_pose_lines(p)
    return poses[skip_non_finite(poses, p, lines)]


def _check_poses(poses: Any) -> np.ndarray:
    arr = np.asarray(poses, dtype=np.float64)
    if arr.ndim == 2 and arr.shape == (4, 4):
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (4, 4):
        raise ValueError(f"cull: poses of shape {arr.shape}; expected (N, 4, 4) camera-to-world matrices.")
    return arr


def render_depth(mesh: trimesh.Trimesh, c2w: np.ndarray, cam: PinholeCamera,
                 stride: int = 1) -> np.ndarray:
    """Depth image (m, along the optical axis; inf where no surface) of ``mesh`` seen from
    ``c2w``, ray cast (embree when installed) through every ``stride``-th pixel centre.

    Returns shape (ceil(height / stride), ceil(width / stride)): entry (r, c) is the ray
    through the centre of the image block u in [c*stride, (c+1)*stride), v in
    [r*stride, (r+1)*stride), so a point at (u, v) reads entry (v // stride, u // stride).
    """
    s = max(int(stride), 1)
    us = np.minimum(np.arange(0, cam.width, s, dtype=np.float64) + 0.5 * s, cam.width - 0.5)
    vs = np.minimum(np.arange(0, cam.height, s, dtype=np.float64) + 0.5 * s, cam.height - 0.5)
    uu, vv = np.meshgrid(us, vs)
    d_cam = np.stack([(uu - cam.cx) / cam.fx, (vv - cam.cy) / cam.fy, np.ones_like(uu)], axis=-1)
    d_cam = d_cam.reshape(-1, 3)
    dirs = d_cam @ c2w[:3, :3].T
    norms = np.linalg.norm(dirs, axis=1, keepdims=True)
    dirs_unit = dirs / norms
    origins = np.broadcast_to(c2w[:3, 3], dirs.shape)
    depth = np.full(len(dirs), np.inf)
    if len(mesh.faces):
        locs, idx_ray, _ = mesh.ray.intersects_location(origins, dirs_unit, multiple_hits=False)
        if len(idx_ray):
            # z depth = distance along the unit ray / |d_cam| (d_cam has z = 1).
            dist = np.linalg.norm(locs - origins[idx_ray], axis=1)
            z = dist / norms[idx_ray, 0]
            np.minimum.at(depth, idx_ray, z)  # nearest hit per ray
    return depth.reshape(len(vs), len(us))


# point-pose pairs tested at once by :func:`visible_points` (bounds its temporaries to ~100 MB)
_BLOCK_PAIRS = 1 << 20


def pose_key(c2w: np.ndarray) -> bytes:
    """A camera pose as a dictionary key: its 16 float64 entries' bytes (equal poses, equal keys)."""
    return np.ascontiguousarray(c2w, dtype=np.float64).tobytes()


def _poses_per_call(per_image: int, n_poses: int) -> int:
    """Poses per kernel call, so that their float64 depth images (``per_image`` pixels each; 0:
    none) stay under ~32 MB."""
    return max(1, (32 << 20) // max(8 * per_image, 1)) if per_image else n_poses


class TestedPoses:
    """The camera poses a growing mask has been tested against (visibility is an OR over poses,
    so a later call tests only the poses it has not seen), by :func:`pose_key`."""

    def __init__(self) -> None:
        self._keys: set[bytes] = set()

    def untested(self, poses: Any) -> tuple[bool, list[int], list[bytes]]:
        """(restart, indices of ``poses`` not tested yet, every pose's key). ``restart``: a pose
        tested before is missing (fewer poses than before), so the caller clears its mask; every
        pose then counts as untested. Mark them with :meth:`add` once tested."""
        keys = [pose_key(c2w) for c2w in poses]
        restart = not self._keys.issubset(keys)
        if restart:
            self._keys.clear()
        return restart, [i for i, k in enumerate(keys) if k not in self._keys], keys

    def add(self, keys: Any) -> None:
        """Mark these pose keys tested."""
        self._keys.update(keys)


class OccluderDepths:
    """Depth images (:func:`render_depth`) of one fixed occluder mesh seen from camera poses,
    each rendered once and kept for later calls with the same pose (up to ``max_bytes`` of
    images; beyond that they are rendered on every call). The evaluation of a run tests many
    meshes (ground truth, every agent's map, the metric samples) against the same poses at
    every periodic evaluation, so the ray casting is done once per pose per run."""

    def __init__(self, mesh: trimesh.Trimesh, cam: PinholeCamera, stride: int = 4,
                 max_bytes: int = 256 << 20) -> None:
        self.mesh, self.cam, self.stride = mesh, cam, max(int(stride), 1)
        self.max_bytes = int(max_bytes)
        self._images: dict[bytes, np.ndarray] = {}
        self._block_max: dict[bytes, np.ndarray] = {}
        self._bytes = 0

    def block_max(self, c2w: np.ndarray) -> np.ndarray:
        """:func:`block_max_depth` of the image seen from ``c2w`` (kept beside it)."""
        key = pose_key(c2w)
        bm = self._block_max.get(key)
        if bm is None:
            bm = block_max_depth(self(c2w)[None], False)[0]
            if key in self._images:
                self._block_max[key] = bm
        return bm

    def __call__(self, c2w: np.ndarray) -> np.ndarray:
        """The (ceil(H / stride), ceil(W / stride)) depth image (m) seen from ``c2w``."""
        key = pose_key(c2w)
        img = self._images.get(key)
        if img is None:
            img = render_depth(self.mesh, c2w, self.cam, self.stride)
            if self._bytes + img.nbytes <= self.max_bytes:
                self._images[key] = img
                self._bytes += img.nbytes
        return img


def visible_points(points: Any, poses: Any, cam: PinholeCamera,
                   occluder: trimesh.Trimesh | OccluderDepths | None = None,
                   depth_maps: Sequence[np.ndarray] | np.ndarray | None = None,
                   eps_m: float = 0.03, stride: int = 4, native: bool | None = None,
                   cluster_m: float | None = None) -> np.ndarray:
    """Boolean (N,) mask: True where a point is seen by at least one of ``poses``.

    Frustum: 0 <= u < width, 0 <= v < height, near_m <= z <= far_m, with (u, v) = (fx x / z
    + cx, fy y / z + cy) in pixels and (x, y, z) the point in camera coordinates (m).
    Occlusion (if ``occluder`` or ``depth_maps`` is given): additionally z <= depth +
    ``eps_m`` at the pixel the point projects to, where depth is rendered from ``occluder``
    every ``stride`` pixels (:func:`render_depth`; pass an :class:`OccluderDepths` to reuse
    the images across calls) or read from ``depth_maps[i]`` ((H, W) metres, 0 or non-finite
    = no measurement, which does not occlude).

    Points already seen are not re-tested, so cost falls as coverage grows. The test runs in
    the compiled kernel ``csrc/visibility.c`` (``native`` None: when it builds) or in numpy,
    on blocks of poses at once; both in float64, and the mask is the OR over poses, so it
    does not depend on the path, the blocking or the thread count. The kernel groups the
    points into cubes of ``cluster_m`` m (default :data:`CLUSTER_M`; 0: point by point) and
    skips a pose for every cube outside its frustum: the same mask, at a cost that no longer
    grows with (unseen points x poses) as a run goes on (docs/BENCHMARKS.md).
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    P = _check_poses(poses)
    if depth_maps is not None and len(depth_maps) != len(P):
        raise ValueError(f"cull: {len(depth_maps)} depth maps for {len(P)} poses; expected one per pose.")
    depths = (OccluderDepths(occluder, cam, stride) if isinstance(occluder, trimesh.Trimesh) else occluder)
    seen = np.zeros(len(pts), dtype=np.uint8)
    w2c = np.ascontiguousarray(np.linalg.inv(P)[:, :3, :4])
    lib = _native.get_lib() if native is not False else None
    if native and lib is None:
        raise RuntimeError("cull: the native visibility kernel is unavailable (see the warning logged)")
    test = _visible_numpy
    order = None
    cluster_m = CLUSTER_M if cluster_m is None else cluster_m
    if lib is not None and cluster_m > 0:  # clusters of nearby points (same mask, see visible_clustered)
        order, clusters = point_clusters(pts, cluster_m)
        pts = np.ascontiguousarray(pts[order])
        test = partial(_visible_native, clusters=clusters)
    per_image = (cam.height * cam.width if depth_maps is not None
                 else -(-cam.height // depths.stride) * -(-cam.width // depths.stride) if depths is not None else 0)
    step = _poses_per_call(per_image, len(P))
    for i in range(0, len(P), step):
        j = min(i + step, len(P))
        if depth_maps is not None:
            images = []
            for k in range(i, j):
                dm = np.asarray(depth_maps[k], dtype=np.float64)
                if dm.shape != (cam.height, cam.width):
                    raise ValueError(f"cull: depth map {k} has shape {dm.shape}; expected "
                                     f"(height, width) = ({cam.height}, {cam.width}) in metres.")
                images.append(dm)
            stack, s, measured = np.stack(images), 1, True
        elif depths is not None:
            stack, s, measured = np.stack([depths(c2w) for c2w in P[i:j]]), depths.stride, False
        else:
            stack, s, measured = None, 1, False
        if order is not None and depths is not None and depth_maps is None:  # block maxima kept per pose
            test(pts, w2c[i:j], cam, stack, s, measured, eps_m, seen, lib,
                 cmax=np.stack([depths.block_max(c2w) for c2w in P[i:j]]))
            continue
        test(pts, w2c[i:j], cam, stack, s, measured, eps_m, seen, lib)
    if order is not None:
        unsorted = np.empty_like(seen)
        unsorted[order] = seen
        seen = unsorted
    return seen.astype(bool)


CLUSTER_M = 0.25
"""Edge (m) of the cubes that group points for the visibility kernel's per-pose frustum test."""
CLUSTER_MARGIN_M = 1e-6
"""Slack (m) added to a cluster's radius, far above double rounding at metre scale: a pose
skips a cluster only when every point is that far outside its frustum."""


def point_clusters(pts: np.ndarray, size_m: float = CLUSTER_M) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Group points (N, 3) m by the ``size_m`` cube they fall in: returns the order that sorts
    them by cube, and the clusters as (start offsets (C + 1,) into the sorted points, spheres
    (C, 4): centre m and radius m, the half-diagonal of the cluster's bounding box). Points
    with a non-finite coordinate form one cluster of infinite radius (never skipped)."""
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=np.int64), (np.zeros(1, dtype=np.int64), np.zeros((0, 4)))
    finite = np.isfinite(pts).all(axis=1)
    lo = pts[finite].min(axis=0) if finite.any() else np.zeros(3)
    cell = np.zeros((n, 3), dtype=np.int64)
    cell[finite] = np.floor((pts[finite] - lo) / size_m).astype(np.int64)
    dims = cell.max(axis=0) + 1
    key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    key[~finite] = int(np.prod(dims))  # after every finite cell
    order = np.argsort(key, kind="stable")
    k = key[order]
    start = np.concatenate([[0], np.flatnonzero(np.diff(k)) + 1, [n]]).astype(np.int64)
    p = pts[order]
    box_lo = np.minimum.reduceat(p, start[:-1], axis=0)
    box_hi = np.maximum.reduceat(p, start[:-1], axis=0)
    spheres = np.empty((len(start) - 1, 4), dtype=np.float64)
    spheres[:, :3] = 0.5 * (box_lo + box_hi)
    spheres[:, 3] = 0.5 * np.linalg.norm(box_hi - box_lo, axis=1)
    if not finite.all():
        spheres[-1] = (0.0, 0.0, 0.0, np.inf)
    return order, (start, np.ascontiguousarray(spheres))


def _visible_native(pts: np.ndarray, w2c: np.ndarray, cam: PinholeCamera, depth: np.ndarray | None,
                    stride: int, measured: bool, eps_m: float, seen: np.ndarray, lib: Any,
                    clusters: tuple[np.ndarray, np.ndarray] | None = None,
                    cmax: np.ndarray | None = None) -> None:
    """``seen`` |= visibility from the poses ``w2c`` ((n, 3, 4) world-to-camera), in C: per
    point (``visible``), or per cluster of :func:`point_clusters` (``visible_clustered``,
    ``pts`` sorted by cluster), the same mask."""
    d = None if depth is None else np.ascontiguousarray(depth, dtype=np.float64)
    dh, dw = (d.shape[1], d.shape[2]) if d is not None else (0, 0)
    camera = (float(cam.fx), float(cam.fy), float(cam.cx), float(cam.cy), int(cam.width), int(cam.height),
              max(cam.near_m, 1e-9), float(cam.far_m), None if d is None else d.ctypes.data, dh, dw,
              int(stride), int(measured), float(eps_m))
    if clusters is None:
        lib.visible(pts.ctypes.data, len(pts), w2c.ctypes.data, len(w2c), *camera, seen.ctypes.data,
                    _native.nthreads())
        return
    start, spheres = clusters
    ch = cw = 0
    if d is not None:
        if cmax is None:
            cmax = block_max_depth(d, measured, DEPTH_BLOCK)
        cmax = np.ascontiguousarray(cmax, dtype=np.float64)
        ch, cw = cmax.shape[1], cmax.shape[2]
    lib.visible_clustered(pts.ctypes.data, start.ctypes.data, len(start) - 1, spheres.ctypes.data,
                          w2c.ctypes.data, len(w2c), *camera, CLUSTER_MARGIN_M,
                          None if cmax is None else cmax.ctypes.data, ch, cw, DEPTH_BLOCK, seen.ctypes.data,
                          _native.nthreads())


def spheres_may_be_seen(spheres: np.ndarray, poses: Any, cam: PinholeCamera,
                        occluder: OccluderDepths | None = None, eps_m: float = 0.03,
                        may: np.ndarray | None = None) -> np.ndarray | None:
    """Boolean (S,): False only where no point of a sphere (``spheres`` (S, 4): centre m, radius m)
    can be seen by any of ``poses`` by :func:`visible_points`' test: the sphere is outside every
    pose's frustum or, with ``occluder``'s depth images, behind the largest depth of the pixel
    blocks it projects to (the bound the clustered kernel skips by; :data:`CLUSTER_MARGIN_M`
    added). ``may``: an earlier result for other poses, extended (visibility is an OR over
    poses, so marks only grow and poses can be added a batch at a time). None when the native
    kernel is unavailable (then no sphere can be ruled out cheaply)."""
    lib = _native.get_lib()
    if lib is None:
        return None
    sph = np.ascontiguousarray(spheres, dtype=np.float64).reshape(-1, 4)
    out = np.zeros(len(sph), dtype=np.uint8) if may is None else np.asarray(may, dtype=bool).astype(np.uint8)
    P = _check_poses(poses) if len(poses) else np.zeros((0, 4, 4))
    if len(P) == 0 or len(sph) == 0:
        return out.astype(bool)
    w2c = np.ascontiguousarray(np.linalg.inv(P)[:, :3, :4])
    per_image = -(-cam.height // occluder.stride) * -(-cam.width // occluder.stride) if occluder is not None else 0
    step = _poses_per_call(per_image, len(P))
    for i in range(0, len(P), step):
        j = min(i + step, len(P))
        depth = cmax = None
        dh = dw = ch = cw = 0
        stride = 1
        if occluder is not None:  # the kernel reads only the images' shape and their block maxima
            first = occluder(P[i])
            dh, dw, stride = first.shape[0], first.shape[1], occluder.stride
            depth = np.ascontiguousarray(first[None])
            cmax = np.ascontiguousarray(np.stack([occluder.block_max(c2w) for c2w in P[i:j]]), dtype=np.float64)
            ch, cw = cmax.shape[1], cmax.shape[2]
        lib.spheres_may_see(sph.ctypes.data, len(sph), w2c[i:j].ctypes.data, j - i, float(cam.fx), float(cam.fy),
                            float(cam.cx), float(cam.cy), int(cam.width), int(cam.height), max(cam.near_m, 1e-9),
                            float(cam.far_m), None if depth is None else depth.ctypes.data, dh, dw, int(stride),
                            float(eps_m), CLUSTER_MARGIN_M, None if cmax is None else cmax.ctypes.data, ch, cw,
                            DEPTH_BLOCK, out.ctypes.data, _native.nthreads())
    return out.astype(bool)


REGION_MARGIN_M = 1e-3
"""Slack (m) added to a block's sphere in :class:`SeenBlocks`: marching-cubes vertices are float32
(about 1e-6 m of rounding at 10 m), so a vertex of a cell may lie that far outside its box."""


class SeenBlocks:
    """Which cells of a regular grid some camera pose may see, by blocks of ``block`` x ``block`` x
    ``block`` cells (:func:`spheres_may_be_seen` on each block's bounding sphere, plus
    :data:`REGION_MARGIN_M`): a cell marked False holds no point that :func:`visible_points`
    would find seen by those poses, so a mesh culled to them keeps no face whose vertices all
    lie in such cells. Kept between calls on the same grid: poses already tested are not tested
    again (marks only grow), as the evaluator's ground-truth culling does."""

    def __init__(self, cam: PinholeCamera, occluder: OccluderDepths | None = None, eps_m: float = 0.03,
                 block: int = 4) -> None:
        self.cam, self.occluder, self.eps_m, self.block = cam, occluder, float(eps_m), max(int(block), 1)
        self._grid: tuple | None = None
        self._spheres = np.zeros((0, 4))
        self._may: np.ndarray | None = None
        self._tested = TestedPoses()
        self._lock = threading.Lock()  # a team's maps are extracted on several threads at once

    def cells(self, origin: np.ndarray, cell_m: float, shape: tuple[int, int, int], poses: Any) -> np.ndarray:
        """Boolean array of ``shape``: the cells ``origin + [i, i + 1] * cell_m`` (m) of a block that
        some pose of ``poses`` ((N, 4, 4) camera-to-world) may see; all True when the native
        kernel is unavailable (nothing ruled out). Thread-safe: one call tests, the others wait."""
        if _native.get_lib() is None:
            return np.ones(shape, dtype=bool)
        with self._lock:
            return self._cells(origin, cell_m, shape, poses)

    def _cells(self, origin: np.ndarray, cell_m: float, shape: tuple[int, int, int], poses: Any) -> np.ndarray:
        P = _check_poses(poses) if len(poses) else np.zeros((0, 4, 4))
        B = self.block
        nb = tuple(-(-int(n) // B) for n in shape)
        grid = (np.asarray(origin, dtype=np.float64).tobytes(), float(cell_m), tuple(int(n) for n in shape))
        if grid != self._grid:  # another grid: its blocks' bounding spheres, nothing tested yet
            idx = np.stack(np.unravel_index(np.arange(int(np.prod(nb))), nb), axis=1)
            lo = np.asarray(origin, dtype=np.float64) + idx * B * cell_m
            hi = np.asarray(origin, dtype=np.float64) + np.minimum((idx + 1) * B, shape) * cell_m
            self._spheres = np.empty((len(idx), 4))
            self._spheres[:, :3] = 0.5 * (lo + hi)
            self._spheres[:, 3] = 0.5 * np.linalg.norm(hi - lo, axis=1) + REGION_MARGIN_M
            self._grid, self._may, self._tested = grid, None, TestedPoses()
        restart, new, keys = self._tested.untested(P)
        if restart or self._may is None:  # fewer poses than before: start again
            self._may = np.zeros(len(self._spheres), dtype=bool)
        if new:
            may = spheres_may_be_seen(self._spheres, P[new], self.cam, self.occluder, self.eps_m, may=self._may)
            assert may is not None  # the kernel is there
            self._may = may
            self._tested.add(keys[i] for i in new)
        assert self._may is not None
        full = self._may.reshape(nb)
        ix = [np.arange(int(n)) // B for n in shape]
        return full[np.ix_(*ix)]


DEPTH_BLOCK = 4
"""Side (depth pixels) of the blocks whose largest depth bounds a cluster's occlusion test."""


def block_max_depth(depth: np.ndarray, measured: bool, block: int = DEPTH_BLOCK) -> np.ndarray:
    """Largest depth (m) of each ``block`` x ``block`` block of every image of ``depth`` (n, H, W),
    (n, ceil(H / block), ceil(W / block)) float64; a pixel without a surface (inf) or, for
    ``measured`` images, without a measurement (0 or non-finite: it never occludes) counts as
    +inf, so the block bound never hides a point the per-pixel test would keep."""
    n, h, w = depth.shape
    d = depth
    if measured:
        d = np.where(np.isfinite(depth) & (depth > 0), depth, np.inf)
    else:
        d = np.where(np.isnan(depth), np.inf, depth)
    ph, pw = -(-h // block) * block, -(-w // block) * block
    padded = np.full((n, ph, pw), -np.inf)
    padded[:, :h, :w] = d
    return np.ascontiguousarray(padded.reshape(n, ph // block, block, pw // block, block).max(axis=(2, 4)))


def _visible_numpy(pts: np.ndarray, w2c: np.ndarray, cam: PinholeCamera, depth: np.ndarray | None,
                   stride: int, measured: bool, eps_m: float, seen: np.ndarray, lib: Any = None) -> None:
    """The same test as ``csrc/visibility.c`` in numpy: the points not yet seen against
    blocks of poses at once (one matrix product per block)."""
    todo = np.flatnonzero(seen == 0)
    near = max(cam.near_m, 1e-9)
    i = 0
    while i < len(w2c) and len(todo):
        b = int(min(len(w2c) - i, max(1, _BLOCK_PAIRS // len(todo))))
        R, t = w2c[i:i + b, :, :3], w2c[i:i + b, :, 3]
        # camera coordinates of every pending point for every pose of the block: (M, b, 3)
        xyz = (pts[todo] @ R.transpose(2, 0, 1).reshape(3, 3 * b)).reshape(-1, b, 3) + t[None]
        z = xyz[:, :, 2]
        m_idx, b_idx = np.nonzero((z >= near) & (z <= cam.far_m))
        z = z[m_idx, b_idx]
        u = cam.fx * xyz[m_idx, b_idx, 0] / z + cam.cx
        v = cam.fy * xyz[m_idx, b_idx, 1] / z + cam.cy
        inside = (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
        m_idx, b_idx, u, v, z = m_idx[inside], b_idx[inside], u[inside], v[inside], z[inside]
        if depth is not None:
            rows = np.minimum(v.astype(np.int64) // stride, depth.shape[1] - 1)
            cols = np.minimum(u.astype(np.int64) // stride, depth.shape[2] - 1)
            d = depth[i + b_idx, rows, cols]
            if measured:
                d = np.where(np.isfinite(d) & (d > 0), d, np.inf)
            m_idx = m_idx[z <= d + eps_m]
        seen[todo[m_idx]] = 1
        todo = todo[seen[todo] == 0]
        i += b


def cull_mesh(mesh: trimesh.Trimesh, vertex_seen: np.ndarray) -> trimesh.Trimesh:
    """Copy of ``mesh`` without the faces whose three vertices are all unseen (NICE-SLAM),
    and without unreferenced vertices (the others keep their order). Vertex or face colours
    are kept. Built from the arrays directly: trimesh's copy() + update_faces() +
    remove_unreferenced_vertices() give the same arrays at several times the cost."""
    seen = np.asarray(vertex_seen, dtype=bool)
    if seen.shape != (len(mesh.vertices),):
        raise ValueError(f"cull_mesh: mask of shape {seen.shape} for {len(mesh.vertices)} vertices; "
                         f"expected one boolean per vertex.")
    if len(mesh.faces) == 0:
        return mesh.copy()
    faces = np.asarray(mesh.faces)
    keep = seen[faces].any(axis=1)
    kept = faces[keep]
    used = np.zeros(len(mesh.vertices), dtype=bool)
    used[kept] = True
    index = np.cumsum(used, dtype=np.int64) - 1
    kind = mesh.visual.kind
    colours: dict = {}
    if kind == "vertex":
        colours["vertex_colors"] = np.asarray(mesh.visual.vertex_colors)[used]
    elif kind == "face":
        colours["face_colors"] = np.asarray(mesh.visual.face_colors)[keep]
    return trimesh.Trimesh(np.asarray(mesh.vertices)[used], index[kept], process=False, **colours)


def max_edge_length(mesh: trimesh.Trimesh) -> float:
    """Length (m) of the longest face edge (0 for a mesh without faces); cheaper than
    trimesh's ``edges_unique_length``, which first finds the unique edges."""
    if len(mesh.faces) == 0:
        return 0.0
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces)
    longest = 0.0
    for a, b in ((0, 1), (1, 2), (2, 0)):
        e = v[f[:, a]] - v[f[:, b]]
        longest = max(longest, float(np.einsum("ij,ij->i", e, e).max()))
    return float(np.sqrt(longest))


def subdivide(mesh: trimesh.Trimesh, max_edge_m: float) -> trimesh.Trimesh:
    """Split faces until no edge is longer than ``max_edge_m`` (m), keeping vertex colours."""
    colors = None
    if mesh.visual.kind == "vertex":
        colors = np.asarray(mesh.visual.vertex_colors)
    elif mesh.visual.kind == "face":
        colors = np.asarray(mesh.visual.face_colors)
    if colors is not None and mesh.visual.kind == "vertex":
        v, f, idx = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=max_edge_m,
                                                     return_index=True)
        # new vertices lie inside a source face: give them that face's first vertex colour
        vc = colors[mesh.faces[idx][:, 0]]
        vcol = np.zeros((len(v), colors.shape[1]), dtype=colors.dtype)
        vcol[f.ravel()] = np.repeat(vc, 3, axis=0)
        vcol[:len(mesh.vertices)] = colors
        return trimesh.Trimesh(v, f, vertex_colors=vcol, process=False)
    v, f, idx = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=max_edge_m,
                                                 return_index=True)
    out = trimesh.Trimesh(v, f, process=False)
    if colors is not None:
        out.visual.face_colors = colors[idx]
    return out


def cull_to_views(mesh: trimesh.Trimesh, poses: Any, cam: PinholeCamera,
                  occluder: trimesh.Trimesh | OccluderDepths | None = None,
                  depth_maps: Sequence[np.ndarray] | np.ndarray | None = None,
                  eps_m: float = 0.03, stride: int = 4,
                  max_edge_m: float | None = None) -> trimesh.Trimesh:
    """:func:`visible_points` on the mesh's vertices, then :func:`cull_mesh`. Pass the
    ground-truth mesh as ``occluder`` for NICE-SLAM's frustum + occlusion culling.

    Culling keeps a face if any of its vertices is seen, so a coarse mesh (a wall as two
    triangles) would be kept or dropped whole; faces longer than ``max_edge_m`` (m) are
    first subdivided so the cut follows what the cameras saw to within that length
    (None: cull the faces as given, like NICE-SLAM's script on dense scans)."""
    if len(mesh.vertices) == 0:
        return mesh.copy()
    if max_edge_m is not None and max_edge_length(mesh) > max_edge_m:
        mesh = subdivide(mesh, max_edge_m)
    seen = visible_points(mesh.vertices, poses, cam, occluder=occluder, depth_maps=depth_maps,
                          eps_m=eps_m, stride=stride)
    return cull_mesh(mesh, seen)
