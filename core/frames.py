"""Posed RGB-D frames: the one currency between the world (scenes, datasets) and agents."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

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


@dataclass(frozen=True, slots=True)
class FrameFeed:
    """The frames one learner receives, in capture order.

    ``times[k]``: capture time of frame k (s, relative to the agent's start); ``render(k)``
    produces it; ``is_keyframe(k)`` says whether its pixels enter the ray database;
    ``taken_by(k)`` is the robot whose camera took it (the centralised learner's source
    merges every robot's frames)."""

    times: Sequence[float]
    render: Callable[[int], Frame]
    is_keyframe: Callable[[int], bool]
    taken_by: Callable[[int], int]

    @staticmethod
    def merged(sources: Sequence["FrameFeed"]) -> "FrameFeed":
        """Every source's frames in time order (ties: source order, then frame order)."""
        items = sorted(((t, a, i) for a, s in enumerate(sources) for i, t in enumerate(s.times)),
                       key=lambda x: (x[0], x[1], x[2]))
        return FrameFeed(
            times=[t for t, _, _ in items],
            render=lambda k: sources[items[k][1]].render(items[k][2]),
            is_keyframe=lambda k: sources[items[k][1]].is_keyframe(items[k][2]),
            taken_by=lambda k: sources[items[k][1]].taken_by(items[k][2]),
        )
