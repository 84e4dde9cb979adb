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
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import trimesh

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PinholeCamera:
    """Pinhole intrinsics in pixels (fx, fy, cx, cy) and image size (width, height) in pixels,
    with the near/far planes of the visibility frustum in metres."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    near_m: float = 0.0
    far_m: float = 1.0e6

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
    with one row-major 4x4 per line (16 numbers separated by spaces or commas; blank lines
    and lines starting with ``#`` are skipped). Poses with non-finite entries (ScanNet marks
    lost tracking with inf) are dropped with a warning. Returns (N, 4, 4) float64.

    Raises FileNotFoundError / ValueError with the file, the line and what was expected.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: poses file not found; expected a .npy of shape (N, 4, 4) or a "
                                f"text file with one row-major 4x4 camera-to-world matrix per line.")
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
        poses = arr.astype(np.float64)
    else:
        rows = []
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{p}: cannot be read as text ({exc}); expected one row-major 4x4 pose "
                             f"(16 numbers) per line, or a .npy file.") from None
        for lineno, line in enumerate(text.splitlines(), start=1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            parts = s.replace(",", " ").split()
            try:
                vals = [float(v) for v in parts]
            except ValueError:
                raise ValueError(f"{p}, line {lineno}: {s[:80]!r} is not a list of numbers; expected "
                                 f"16 numbers (a row-major 4x4 camera-to-world pose).") from None
            if len(vals) != 16:
                raise ValueError(f"{p}, line {lineno}: {len(vals)} numbers; expected 16 (a row-major "
                                 f"4x4 camera-to-world pose per line).")
            rows.append(vals)
        poses = np.asarray(rows, dtype=np.float64).reshape(-1, 4, 4)
    if len(poses) == 0:
        raise ValueError(f"{p}: holds no poses; expected at least one 4x4 camera-to-world matrix.")
    ok = np.isfinite(poses).all(axis=(1, 2))
    if not ok.all():
        log.warning("%s: dropping %d of %d poses with non-finite entries", p, int((~ok).sum()), len(poses))
        poses = poses[ok]
        if len(poses) == 0:
            raise ValueError(f"{p}: every pose has non-finite entries; expected finite 4x4 matrices.")
    return poses


def _check_poses(poses: Any) -> np.ndarray:
    arr = np.asarray(poses, dtype=np.float64)
    if arr.ndim == 2 and arr.shape == (4, 4):
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (4, 4):
        raise ValueError(f"cull: poses of shape {arr.shape}; expected (N, 4, 4) camera-to-world matrices.")
    return arr


def _project(points: np.ndarray, c2w: np.ndarray, cam: PinholeCamera
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frustum test of world points for one camera-to-world pose.

    Returns (idx, u, v, z) for the points inside the image with near <= z <= far: ``idx`` indexes
    ``points``, (u, v) are pixel coordinates and z the camera depth (m) of those points.
    """
    w2c = np.linalg.inv(c2w)
    R = w2c[:3, :3].astype(points.dtype)
    t = w2c[:3, 3].astype(points.dtype)
    z = points @ R[2] + t[2]
    idx = np.flatnonzero((z >= max(cam.near_m, 1e-9)) & (z <= cam.far_m))
    p = points[idx]
    z = z[idx]
    u = cam.fx * (p @ R[0] + t[0]) / z + cam.cx
    v = cam.fy * (p @ R[1] + t[1]) / z + cam.cy
    ok = (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
    return idx[ok], u[ok], v[ok], z[ok]


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


def visible_points(points: Any, poses: Any, cam: PinholeCamera,
                   occluder: trimesh.Trimesh | None = None,
                   depth_maps: Sequence[np.ndarray] | np.ndarray | None = None,
                   eps_m: float = 0.03, stride: int = 4) -> np.ndarray:
    """Boolean (N,) mask: True where a point is seen by at least one of ``poses``.

    Frustum: 0 <= u < width, 0 <= v < height, near_m <= z <= far_m. Occlusion (if
    ``occluder`` or ``depth_maps`` is given): additionally z <= depth + ``eps_m`` at the
    pixel the point projects to, where depth is rendered from ``occluder`` every
    ``stride`` pixels (:func:`render_depth`) or read from ``depth_maps[i]`` ((H, W) metres,
    0 or non-finite = no measurement, which does not occlude). Points already seen are not
    re-tested, so cost falls as coverage grows.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    P = _check_poses(poses)
    if depth_maps is not None and len(depth_maps) != len(P):
        raise ValueError(f"cull: {len(depth_maps)} depth maps for {len(P)} poses; expected one per pose.")
    seen = np.zeros(len(pts), dtype=bool)
    todo = np.arange(len(pts))
    s = max(int(stride), 1)
    for i, c2w in enumerate(P):
        if len(todo) == 0:
            break
        # project relative to the camera centre in float32: cheap and exact enough (um at 10 m)
        local = (pts[todo] - c2w[:3, 3]).astype(np.float32)
        centred = c2w.copy()
        centred[:3, 3] = 0.0
        idx, u, v, z = _project(local, centred, cam)
        if len(idx) == 0:
            continue
        if depth_maps is not None:
            dm = np.asarray(depth_maps[i], dtype=np.float64)
            if dm.shape != (cam.height, cam.width):
                raise ValueError(f"cull: depth map {i} has shape {dm.shape}; expected "
                                 f"(height, width) = ({cam.height}, {cam.width}) in metres.")
            d = dm[np.minimum(v.astype(np.int64), cam.height - 1), np.minimum(u.astype(np.int64), cam.width - 1)]
            d = np.where(np.isfinite(d) & (d > 0), d, np.inf)
            idx = idx[z <= d + eps_m]
        elif occluder is not None:
            dm = render_depth(occluder, c2w, cam, s)
            d = dm[np.minimum((v // s).astype(np.int64), dm.shape[0] - 1),
                   np.minimum((u // s).astype(np.int64), dm.shape[1] - 1)]
            idx = idx[z <= d + eps_m]
        seen[todo[idx]] = True
        todo = np.flatnonzero(~seen)
    return seen


def cull_mesh(mesh: trimesh.Trimesh, vertex_seen: np.ndarray) -> trimesh.Trimesh:
    """Copy of ``mesh`` without the faces whose three vertices are all unseen (NICE-SLAM),
    and without unreferenced vertices. Vertex colours are kept."""
    seen = np.asarray(vertex_seen, dtype=bool)
    if seen.shape != (len(mesh.vertices),):
        raise ValueError(f"cull_mesh: mask of shape {seen.shape} for {len(mesh.vertices)} vertices; "
                         f"expected one boolean per vertex.")
    out = mesh.copy()
    if len(out.faces) == 0:
        return out
    keep = seen[out.faces].any(axis=1)
    out.update_faces(keep)
    out.remove_unreferenced_vertices()
    return out


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
                  occluder: trimesh.Trimesh | None = None,
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
    if max_edge_m is not None and len(mesh.faces) and float(mesh.edges_unique_length.max()) > max_edge_m:
        mesh = subdivide(mesh, max_edge_m)
    seen = visible_points(mesh.vertices, poses, cam, occluder=occluder, depth_maps=depth_maps,
                          eps_m=eps_m, stride=stride)
    return cull_mesh(mesh, seen)
