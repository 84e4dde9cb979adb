"""Posed RGB-D frames: the one currency between the world (scenes, datasets) and agents."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Intrinsics:
    """Pinhole intrinsics in pixels, OpenCV convention (x right, y down, z forward)."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def as_tuple(self) -> tuple[float, float, float, float, int, int]:
        return (self.fx, self.fy, self.cx, self.cy, self.width, self.height)

    def scaled(self, factor: float) -> "Intrinsics":
        """Intrinsics of the image resized by ``factor`` (pixel-centre convention)."""
        w = max(1, int(round(self.width * factor)))
        h = max(1, int(round(self.height * factor)))
        sx, sy = w / self.width, h / self.height
        return Intrinsics(self.fx * sx, self.fy * sy, (self.cx + 0.5) * sx - 0.5,
                          (self.cy + 0.5) * sy - 0.5, w, h)


@dataclass(frozen=True, slots=True)
class Frame:
    """One posed RGB-D frame.

    rgb: float32 (H, W, 3) in [0, 1]; depth: float32 (H, W) in metres, 0 = no reading;
    c2w: float64 (4, 4) camera-to-world, OpenCV camera axes; t: timestamp in seconds.
    """

    index: int
    t: float
    rgb: np.ndarray
    depth: np.ndarray
    c2w: np.ndarray
    K: Intrinsics
