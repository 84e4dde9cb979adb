"""Camera rays from posed RGB-D frames and the per-agent keyframe ray database.

OpenCV convention (docs/ALGORITHM.md section 1): ``d_cam = ((u-cx)/fx, (v-cy)/fy, 1)`` at
integer pixel (u, v), ``d = R_c2w d_cam`` un-normalised, so the ray parameter z along
``o + d z`` is camera depth in metres and ``o`` is the camera centre.
"""
from __future__ import annotations

import numpy as np
import torch

from ramensim.core.frames import Frame, Intrinsics


def check_frame(frame: Frame) -> None:
    """Raise ValueError if a frame's arrays do not fit its intrinsics."""
    h, w = frame.K.height, frame.K.width
    if frame.depth.shape != (h, w) or frame.rgb.shape != (h, w, 3):
        raise ValueError(f"Frame {frame.index} (t={frame.t} s): depth {frame.depth.shape} and rgb "
                         f"{frame.rgb.shape} must be ({h}, {w}) and ({h}, {w}, 3) to match "
                         f"its intrinsics {w}x{h}.")
    if frame.c2w.shape != (4, 4) or not np.all(np.isfinite(frame.c2w)):
        raise ValueError(f"Frame {frame.index} (t={frame.t} s): c2w must be a finite 4x4 "
                         f"camera-to-world matrix, got shape {frame.c2w.shape}.")


def pixel_directions(K: Intrinsics, u: torch.Tensor, v: torch.Tensor,
                     c2w: np.ndarray) -> torch.Tensor:
    """World ray directions (N, 3) float32 (un-normalised, unit camera z) for pixels (u, v)."""
    R = torch.as_tensor(np.asarray(c2w)[:3, :3], dtype=torch.float32)
    d_cam = torch.stack([(u.float() - K.cx) / K.fx, (v.float() - K.cy) / K.fy,
                         torch.ones_like(u, dtype=torch.float32)], dim=1)
    return d_cam @ R.t()


def image_rays(c2w: np.ndarray, K: Intrinsics, stride: int = 1) -> tuple[torch.Tensor, torch.Tensor, tuple[int, int]]:
    """All rays of an image (every ``stride``-th pixel): origins (N, 3), directions (N, 3),
    and the (rows, cols) of the sub-sampled image."""
    vs = torch.arange(0, K.height, stride)
    us = torch.arange(0, K.width, stride)
    vv, uu = torch.meshgrid(vs, us, indexing="ij")
    d = pixel_directions(K, uu.reshape(-1), vv.reshape(-1), c2w)
    o = torch.as_tensor(np.asarray(c2w)[:3, 3], dtype=torch.float32).expand_as(d).contiguous()
    return o, d, (len(vs), len(us))


def frame_rays(frame: Frame, pixel_ids: np.ndarray | torch.Tensor) -> dict[str, torch.Tensor]:
    """Rays of selected pixels (flat ids ``v * W + u``): origin, dir, rgb, depth (float32)."""
    ids = torch.as_tensor(pixel_ids, dtype=torch.int64)
    W = frame.K.width
    u, v = ids % W, ids // W
    d = pixel_directions(frame.K, u, v, frame.c2w)
    o = torch.as_tensor(frame.c2w[:3, 3], dtype=torch.float32).expand_as(d).contiguous()
    rgb = torch.as_tensor(frame.rgb.reshape(-1, 3), dtype=torch.float32)[ids]
    depth = torch.as_tensor(frame.depth.reshape(-1), dtype=torch.float32)[ids]
    return {"origin": o, "dir": d, "rgb": rgb, "depth": depth}


def valid_pixel_ids(frame: Frame) -> torch.Tensor:
    """Flat ids of pixels with a finite depth reading > 0."""
    d = np.asarray(frame.depth).reshape(-1)
    return torch.as_tensor(np.flatnonzero(np.isfinite(d) & (d > 0)), dtype=torch.int64)


class RayDatabase:
    """Growable store of rays (origin, dir, rgb, depth), capacity doubling so adding a
    keyframe never re-copies everything. Rows: (M, 10) float32 = o(3) d(3) rgb(3) D(1)."""

    def __init__(self, capacity: int = 4096) -> None:
        self._buf = torch.empty(max(capacity, 1), 10, dtype=torch.float32)
        self.size = 0
        self.n_frames = 0

    def add(self, rays: dict[str, torch.Tensor]) -> None:
        n = rays["depth"].shape[0]
        need = self.size + n
        if need > self._buf.shape[0]:
            cap = self._buf.shape[0]
            while cap < need:
                cap *= 2
            new = torch.empty(cap, 10, dtype=torch.float32)
            new[: self.size] = self._buf[: self.size]
            self._buf = new
        rows = self._buf[self.size: need]
        rows[:, 0:3] = rays["origin"]
        rows[:, 3:6] = rays["dir"]
        rows[:, 6:9] = rays["rgb"]
        rows[:, 9] = rays["depth"]
        self.size = need
        self.n_frames += 1

    def rows(self) -> torch.Tensor:
        """View of the stored rays (size, 10)."""
        return self._buf[: self.size]

    def sample(self, n: int, generator: torch.Generator) -> torch.Tensor:
        """n rows drawn uniformly with replacement (n, 10)."""
        ids = torch.randint(0, self.size, (n,), generator=generator)
        return self._buf[ids]
