"""Colours of the recording: one per agent, one per message outcome, and a colour map."""
from __future__ import annotations

import numpy as np

from ramensim.core.events import Fate

_TAB10 = np.array(
    [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
     (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207)],
    dtype=np.uint8,
)

_VIRIDIS = np.array(
    [(68, 1, 84), (71, 44, 122), (59, 81, 139), (44, 113, 142), (33, 144, 141),
     (39, 173, 129), (92, 200, 99), (170, 220, 50), (253, 231, 37)],
    dtype=np.float64,
)
"""Viridis sampled at 9 evenly spaced points of [0, 1] (sRGB 0-255)."""

DELIVERED = (60, 200, 90)
"""Colour of a delivered message's line (sRGB)."""

_LOST = {
    Fate.LOSS.reason: (230, 50, 50),
    Fate.PACKET_LOSS.reason: (230, 50, 50),
    Fate.OUT_OF_RANGE.reason: (255, 140, 0),
    Fate.WINDOW_CLOSED.reason: (170, 90, 220),
    Fate.QUEUE_OVERFLOW.reason: (240, 220, 40),
    Fate.NO_LINK.reason: (150, 150, 150),
    Fate.COLLISION.reason: (200, 30, 200),
    Fate.RETRY_LIMIT.reason: (120, 60, 30),
}
"""The colour of each drop reason of ``ramensim.core.events.Fate`` (a test checks every one has one)."""
_LOST_OTHER = (230, 50, 120)

SCENE_GREY = (190, 190, 190, 255)
"""Albedo of a ground-truth scene mesh that has no vertex colours (sRGBA)."""


def agent_color(index: int) -> tuple[int, int, int]:
    """The colour of agent ``index`` (sRGB 0-255), cycling through 10 distinct colours."""
    c = _TAB10[index % len(_TAB10)]
    return int(c[0]), int(c[1]), int(c[2])


def lost_color(reason: str) -> tuple[int, int, int]:
    """The colour of a lost message's line, by the reason it was dropped (sRGB 0-255)."""
    return _LOST.get(reason, _LOST_OTHER)


def viridis(values: np.ndarray) -> np.ndarray:
    """Map values in [0, 1] (clipped) to viridis colours, (N, 3) uint8 sRGB."""
    x = np.clip(np.nan_to_num(np.asarray(values, dtype=np.float64), nan=0.0), 0.0, 1.0)
    pos = x * (len(_VIRIDIS) - 1)
    lo = np.minimum(pos.astype(np.int64), len(_VIRIDIS) - 2)
    frac = (pos - lo)[:, None]
    rgb = _VIRIDIS[lo] * (1.0 - frac) + _VIRIDIS[lo + 1] * frac
    return np.rint(rgb).astype(np.uint8)
