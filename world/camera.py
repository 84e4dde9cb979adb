"""RGB-D camera: render colour and depth of a mesh by ray casting with Embree.

Pinhole model, OpenCV axes (x right, y down, z forward); ``c2w`` maps camera to world
coordinates. The ray of pixel (u, v) (pixel centres at integer coordinates) is
``d_cam = ((u - cx) / fx, (v - cy) / fy, 1)``: un-normalised, so the ray parameter of the
hit is directly the depth z in the camera frame (not the ray length). Colour is the
barycentric interpolation of the hit triangle's vertex colours (or its face colour).

Ray casting uses trimesh's Embree backend (``trimesh.ray.ray_pyembree.RayMeshIntersector``,
package ``embreex``); rays are split across threads (Embree releases the GIL).
"""
from __future__ import annotations

import logging
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import trimesh

from ramensim.core.frames import Frame, Intrinsics
from ramensim.world.config import SensorConfig

log = logging.getLogger(__name__)


def pixel_rays(K: Intrinsics) -> np.ndarray:
    """Camera-frame ray directions of every pixel, (H*W, 3) float64, row-major (v, u),
    with z = 1 so that a ray parameter equals camera depth."""
    u, v = np.meshgrid(np.arange(K.width, dtype=np.float64), np.arange(K.height, dtype=np.float64))
    d = np.stack([(u - K.cx) / K.fx, (v - K.cy) / K.fy, np.ones_like(u)], axis=-1)
    return d.reshape(-1, 3)


class MeshRayCaster:
    """First-hit ray queries on a mesh with Embree, returning hit distance in ray-parameter
    units, triangle ids and barycentric coordinates (u, v) of the hit."""

    def __init__(self, mesh: trimesh.Trimesh, threads: int | None = None) -> None:
        if not trimesh.ray.has_embree:
            raise RuntimeError("trimesh reports no Embree backend (package 'embreex' missing); "
                               "install embreex to render RGB-D frames.")
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        self.mesh = mesh
        self.intersector = RayMeshIntersector(mesh)
        wrap = self.intersector._scene  # noqa: SLF001 - trimesh's cached Embree scene wrapper
        self._scene, self._origin, self._scale = wrap.scene, np.asarray(wrap.origin), float(wrap.scale)
        self.threads = max(1, threads if threads is not None else (os.cpu_count() or 1))
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None

    @property
    def backend(self) -> str:
        """Name of the ray-casting backend in use ('embree')."""
        mod = type(self.intersector).__module__
        return "embree" if mod.endswith("ray_pyembree") else mod

    def cast(self, origins: np.ndarray, directions: np.ndarray):
        """Cast rays ``origins + s * directions`` (world, m; directions need not be unit).

        Returns ``(s, tri, bu, bv)``: s (N,) float64 ray parameter of the first hit (inf on a
        miss), tri (N,) int triangle index (-1 on a miss), bu, bv (N,) float32 barycentric
        coordinates of the hit (point = (1-bu-bv) V0 + bu V1 + bv V2).
        """
        o = ((np.asarray(origins, np.float64) - self._origin) * self._scale).astype(np.float32)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        if o.shape[0] == 1 and d.shape[0] > 1:
            o = np.broadcast_to(o, d.shape)
        o = np.ascontiguousarray(o)
        n = len(d)
        if self._pool is None or n < 4096:
            res = [self._scene.run(o, d, output=1)]
        else:
            cuts = np.linspace(0, n, self.threads + 1).astype(int)
            res = list(self._pool.map(lambda ab: self._scene.run(o[ab[0]:ab[1]], d[ab[0]:ab[1]], output=1),
                                      zip(cuts[:-1], cuts[1:])))
        tri = np.concatenate([r["primID"] for r in res]).astype(np.int64)
        s = np.concatenate([r["tfar"] for r in res]).astype(np.float64) / self._scale
        bu = np.concatenate([r["u"] for r in res])
        bv = np.concatenate([r["v"] for r in res])
        miss = tri < 0
        s[miss] = np.inf
        return s, tri, bu, bv

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False)
            self._pool = None


class MeshColors:
    """Colour lookup of a hit: barycentric interpolation of vertex colours, or the face
    colour for face-coloured meshes (RGB float32 in [0, 1])."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        vis = mesh.visual
        if vis.kind == "face":
            self.face = np.asarray(vis.face_colors[:, :3], np.float32) / 255.0
            self.corner = None
        else:
            vc = np.asarray(vis.vertex_colors[:, :3], np.float32) / 255.0
            self.corner = np.ascontiguousarray(vc[np.asarray(mesh.faces)])  # (F, 3 corners, 3)
            self.face = None

    def lookup(self, tri: np.ndarray, bu: np.ndarray, bv: np.ndarray) -> np.ndarray:
        """(N, 3) colours at hits ``tri`` with barycentrics (bu, bv); tri must be >= 0."""
        if self.face is not None:
            return self.face[tri]
        c = self.corner[tri]  # (N, 3, 3)
        w0 = (1.0 - bu - bv)[:, None]
        return c[:, 0] * w0 + c[:, 1] * bu[:, None] + c[:, 2] * bv[:, None]


class RGBDCamera:
    """Renders posed RGB-D :class:`ramensim.core.frames.Frame` s of a mesh with intrinsics ``K``.

    ``sensor`` (optional) applies the seeded depth sensor model: Gaussian depth noise with
    std sigma = a + b z^2 (m), a fraction of missing pixels, and range limits; a frame with
    a sensor model needs a ``numpy.random.Generator``.
    """

    def __init__(self, mesh: trimesh.Trimesh, K: Intrinsics, sensor: SensorConfig | None = None,
                 threads: int | None = None) -> None:
        self.K = K
        self.sensor = sensor
        self.caster = MeshRayCaster(mesh, threads)
        self.colors = MeshColors(mesh)
        self._dirs_cam = pixel_rays(K).astype(np.float32)  # Embree works in float32

    @property
    def backend(self) -> str:
        return self.caster.backend

    def render_arrays(self, c2w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ideal (noise-free) rgb (H, W, 3) float32 in [0, 1] and depth (H, W) float32 in
        metres (camera z; 0 where a ray hits nothing) from camera pose ``c2w`` (4, 4)."""
        c2w = np.asarray(c2w, np.float64)
        R, t = c2w[:3, :3], c2w[:3, 3]
        dirs = self._dirs_cam @ R.T.astype(np.float32)
        z, tri, bu, bv = self.caster.cast(t[None, :], dirs)
        hit = tri >= 0
        H, W = self.K.height, self.K.width
        rgb = np.zeros((H * W, 3), np.float32)
        if hit.all():
            rgb[:] = self.colors.lookup(tri, bu, bv)
        else:
            rgb[hit] = self.colors.lookup(tri[hit], bu[hit], bv[hit])
        depth = np.where(hit, z, 0.0).astype(np.float32)
        return np.clip(rgb, 0.0, 1.0).reshape(H, W, 3), depth.reshape(H, W)

    def render(self, c2w: np.ndarray, t: float = 0.0, index: int = 0,
               rng: np.random.Generator | None = None) -> Frame:
        """One posed frame at time ``t`` (s); the sensor model (if any) draws from ``rng``."""
        rgb, depth = self.render_arrays(c2w)
        if self.sensor is not None:
            if rng is None:
                raise ValueError("RGBDCamera.render: a sensor model is set, so a numpy.random.Generator "
                                 "'rng' is required for its noise (none was given).")
            rgb, depth = apply_sensor(rgb, depth, self.sensor, rng)
        return Frame(index=int(index), t=float(t), rgb=rgb, depth=depth,
                     c2w=np.array(c2w, dtype=np.float64), K=self.K)

    def close(self) -> None:
        self.caster.close()


def apply_sensor(rgb: np.ndarray, depth: np.ndarray, s: SensorConfig,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Depth sensor model: z' = z + N(0, (a + b z^2)^2) (m), readings outside
    [min_range, max_range] and a random ``missing_fraction`` of pixels set to 0 (missing),
    optional Gaussian colour noise. Draws in a fixed order from ``rng`` (deterministic)."""
    d = depth.astype(np.float32, copy=True)
    valid = d > 0
    if s.depth_noise_a > 0 or s.depth_noise_b > 0:
        sigma = s.depth_noise_a + s.depth_noise_b * d.astype(np.float64) ** 2
        d = np.where(valid, d + rng.standard_normal(d.shape) * sigma, 0.0).astype(np.float32)
    if s.missing_fraction > 0:
        d[rng.random(d.shape) < s.missing_fraction] = 0.0
    d[(d < s.min_range) | (d > s.max_range)] = 0.0
    if s.color_noise > 0:
        rgb = np.clip(rgb + rng.normal(0.0, s.color_noise, rgb.shape), 0.0, 1.0).astype(np.float32)
    return rgb, d
