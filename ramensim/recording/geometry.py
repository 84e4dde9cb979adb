"""Small array helpers for the recorder: image striding, pinhole matrices, mesh normals,
and the bounded-segment trajectory trail. Pure numpy; inputs are never modified."""
from __future__ import annotations

import numpy as np

TRAJECTORY_SEGMENT_POINTS = 128
"""Points per trajectory segment entity: bounds the size of each re-logged strip."""


def stride_image(image: np.ndarray, k: int) -> np.ndarray:
    """Every k-th pixel of an (H, W[, C]) image in both axes (a contiguous copy)."""
    if k == 1:
        return np.ascontiguousarray(image)
    return np.ascontiguousarray(image[::k, ::k])


def rgb_to_uint8(rgb: np.ndarray) -> np.ndarray:
    """float RGB in [0, 1] -> uint8 0-255 (rounded, clipped); uint8 passes through."""
    a = np.asarray(rgb)
    if a.dtype == np.uint8:
        return a
    return np.clip(a.astype(np.float32) * 255.0 + 0.5, 0.0, 255.0).astype(np.uint8)


def depth_to_mm(depth: np.ndarray) -> np.ndarray:
    """Depth in metres (float, 0 or non-finite = invalid) -> uint16 millimetres (0 = invalid),
    rounded and clipped to 65.535 m: half the bytes of float32 at 1 mm resolution."""
    d = np.nan_to_num(np.asarray(depth, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    return np.clip(d * 1000.0 + 0.5, 0.0, 65535.0).astype(np.uint16)


def strided_intrinsics(K: tuple[float, float, float, float, int, int], k: int) -> tuple[np.ndarray, tuple[int, int]]:
    """Image-from-camera matrix (3x3, pixels) and (width, height) of an image strided by k.

    With OpenCV's convention (pixel i's centre at coordinate i), kept pixel j is old
    pixel k*j, so u' = u / k: fx, fy, cx, cy all divide by k; the size is ceil(W / k).
    """
    fx, fy, cx, cy, w, h = K
    mat = np.array([[fx / k, 0.0, cx / k], [0.0, fy / k, cy / k], [0.0, 0.0, 1.0]], dtype=np.float64)
    return mat, (-(-int(w) // k), -(-int(h) // k))


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (V, 3) float32 of a triangle mesh; zero where a
    vertex touches no face of non-zero area."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n = np.zeros_like(v)
    if len(f) and len(v):
        fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        idx = f.reshape(-1)
        for d in range(3):
            w = np.repeat(fn[:, d], 3)
            n[:, d] = np.bincount(idx, weights=w, minlength=len(v))
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    np.divide(n, norm, out=n, where=norm > 0)
    return n.astype(np.float32)


class TrajectoryTrail:
    """An agent's trajectory so far, kept as bounded segments.

    Re-logging a single growing strip costs O(N^2) bytes over a run; instead the trail
    is cut into segments of at most ``segment_points`` points, each its own entity. A
    finished segment is never logged again (latest-at keeps showing it), so the total
    is O(N * segment_points) and scrubbing back in time still shows the trail "so far".
    """

    def __init__(self, min_step_m: float, segment_points: int = TRAJECTORY_SEGMENT_POINTS) -> None:
        if segment_points < 2:
            raise ValueError(f"TrajectoryTrail: segment_points={segment_points}, expected at least 2.")
        self.min_step_m = float(min_step_m)
        self.segment_points = int(segment_points)
        self.segment_index = 0
        self._buf = np.zeros((self.segment_points, 3), dtype=np.float32)
        self._n = 0
        self._last = np.zeros(3)

    def add(self, position: np.ndarray) -> tuple[int, np.ndarray] | None:
        """Offer a camera position (m). Returns (segment index, (M, 3) float32 points, a
        view valid until the next call) to log when the point was kept and the segment
        has a line to draw, else None."""
        p = np.asarray(position, dtype=np.float64).reshape(3)
        if self._n and float(np.linalg.norm(p - self._last)) <= self.min_step_m:
            return None
        if self._n >= self.segment_points:
            self.segment_index += 1
            self._buf[0] = self._buf[self._n - 1]
            self._n = 1
        self._buf[self._n] = p
        self._n += 1
        self._last = p
        if self._n < 2:
            return None
        return self.segment_index, self._buf[: self._n]
