"""What every dataset reader produces, image loading with validation, and splitting a
sequence's frames between agents."""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from ramensim.core.frames import Intrinsics
from ramensim.core.errors import InputError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DatasetFrame:
    """One posed RGB-D frame on disk: ``t`` seconds, ``c2w`` (4, 4) OpenCV camera-to-world (m)."""

    t: float
    c2w: np.ndarray
    rgb_path: Path
    depth_path: Path


@dataclass
class Sequence:
    """A dataset sequence: its frames in capture order, native intrinsics, depth units per
    metre, and the ground-truth mesh file if the dataset has one."""

    name: str
    frames: list[DatasetFrame]
    K: Intrinsics
    depth_scale: float
    mesh_path: Path | None = None
    meta: dict = field(default_factory=dict)


def require_file(p: Path, what: str) -> Path:
    if not p.is_file():
        raise InputError(f"{p}: file not found; expected {what}.")
    return p


def require_dir(p: Path, what: str) -> Path:
    if not p.is_dir():
        raise InputError(f"{p}: folder not found; expected {what}.")
    return p


def read_rgb(path: Path, size: tuple[int, int]) -> np.ndarray:
    """Colour image as float32 (H, W, 3) in [0, 1], resized (bilinear) to ``size`` = (W, H)
    if it differs (ScanNet colour is larger than its depth)."""
    try:
        with Image.open(path) as im:
            im = im.convert("RGB")
            if im.size != size:
                im = im.resize(size, Image.BILINEAR)
            return np.asarray(im, dtype=np.float32) / 255.0
    except FileNotFoundError:
        raise InputError(f"{path}: colour image not found; the dataset lists it as a frame.") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot be read as an image ({exc}); expected a JPG/PNG colour image.") from None


def read_depth(path: Path, scale: float, size: tuple[int, int]) -> np.ndarray:
    """16-bit depth PNG as float32 (H, W) metres (value / ``scale``; 0 = missing). Its size
    must be ``size`` = (W, H), the intrinsics' image size."""
    try:
        with Image.open(path) as im:
            if im.size != size:
                raise InputError(f"{path}: depth image is {im.size[0]}x{im.size[1]} pixels; expected "
                                 f"{size[0]}x{size[1]} (the intrinsics' image size).")
            arr = np.asarray(im)
    except FileNotFoundError:
        raise InputError(f"{path}: depth image not found; the dataset lists it as a frame.") from None
    except InputError:
        raise
    except OSError as exc:
        raise InputError(f"{path}: cannot be read as an image ({exc}); expected a 16-bit depth PNG.") from None
    if arr.ndim != 2:
        raise InputError(f"{path}: depth image has {arr.shape[2] if arr.ndim == 3 else arr.ndim} channels; "
                         f"expected a single-channel 16-bit PNG.")
    d = arr.astype(np.float32) / np.float32(scale)
    if not np.all(np.isfinite(d)):
        raise InputError(f"{path}: depth contains NaN or infinite values; expected finite depths.")
    return d


def resize_frame(rgb: np.ndarray, depth: np.ndarray, K: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Resize rgb (bilinear) and depth (nearest, so no depths are invented at edges) to
    ``K``'s image size."""
    size = (K.width, K.height)
    if depth.shape == (K.height, K.width):
        return rgb, depth
    rgb8 = Image.fromarray(np.round(rgb * 255).astype(np.uint8)).resize(size, Image.BILINEAR)
    dimg = Image.fromarray(depth.astype(np.float32), mode="F").resize(size, Image.NEAREST)
    return np.asarray(rgb8, np.float32) / 255.0, np.asarray(dimg, np.float32)


def split_frames(frames: list[DatasetFrame], n_agents: int, mode: str) -> list[list[int]]:
    """Indices of each agent's frames. 'chunks': n contiguous chunks of near-equal length
    (the paper's rule); 'regions': by camera position along the axis of largest spread,
    in n quantile slabs (equal frame counts, capture order kept within each)."""
    n = len(frames)
    if n < n_agents:
        raise InputError(f"the dataset has {n} frames (after stride/max_frames) but there are {n_agents} "
                         f"agents; every agent needs at least one frame.")
    if mode == "chunks":
        return [c.tolist() for c in np.array_split(np.arange(n), n_agents)]
    pos = np.stack([f.c2w[:3, 3] for f in frames])
    axis = int(np.argmax(pos.max(axis=0) - pos.min(axis=0)))
    order = np.argsort(pos[:, axis], kind="stable")
    return [sorted(c.tolist()) for c in np.array_split(order, n_agents)]
