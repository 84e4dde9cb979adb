"""Frame sources: each agent's stream of posed RGB-D frames, rendered or read lazily.

A source lists its frames' ``(t, c2w)`` up front (cheap) and produces the image of frame
``idx`` only when asked (:meth:`render`), so nothing is rendered or decoded ahead of use.
Frame ``idx`` is the same whenever and in whatever order it is asked for: its sensor noise
comes from a generator seeded by (the agent's seed, idx).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ramensim.core.frames import Frame, Intrinsics
from ramensim.world.camera import RGBDCamera, apply_sensor
from ramensim.world.config import SensorConfig
from ramensim.world.datasets.common import DatasetFrame, read_depth, read_rgb, resize_frame
from ramensim.world.trajectories import Trajectory


def frame_rng(seed: int, idx: int) -> np.random.Generator:
    """The sensor-noise generator of frame ``idx`` of a source with seed ``seed``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), int(idx)])))


@runtime_checkable
class FrameSource(Protocol):
    """One agent's posed frames: ``frames()`` -> [(t seconds, c2w (4, 4))], ``render(idx)``
    -> :class:`ramensim.core.frames.Frame`, ``position(t)`` -> camera centre (3,) m."""

    intrinsics: Intrinsics
    trajectory: Trajectory

    def frames(self) -> list[tuple[float, np.ndarray]]: ...

    def __len__(self) -> int: ...

    def render(self, idx: int) -> Frame: ...

    def position(self, t: float) -> np.ndarray: ...


class RenderedFrameSource:
    """Frames rendered from a mesh along a trajectory at the given times (s).

    ``store`` (a :class:`ramensim.world.frame_cache.FrameStore`, set by
    :func:`ramensim.world.frame_cache.attach_frame_cache`) serves the frames a run of the same
    trial already rendered, the same bytes; a frame it lacks is rendered and written to it."""

    def __init__(self, camera: RGBDCamera, trajectory: Trajectory, times: np.ndarray, seed: int) -> None:
        self.camera = camera
        self.trajectory = trajectory
        self.intrinsics = camera.K
        self._times = np.asarray(times, np.float64)
        self._poses = trajectory.poses_at(self._times) if len(self._times) else np.zeros((0, 4, 4))
        self._seed = int(seed)
        self.store = None

    @property
    def seed(self) -> int:
        """The sensor-noise seed of this source (frame k draws from ``frame_rng(seed, k)``)."""
        return self._seed

    def frames(self) -> list[tuple[float, np.ndarray]]:
        return [(float(t), p.copy()) for t, p in zip(self._times, self._poses)]

    def __len__(self) -> int:
        return len(self._times)

    def render(self, idx: int) -> Frame:
        store = self.store
        if store is not None:
            cached = store.load(idx)
            if cached is not None:
                return Frame(index=int(idx), t=float(self._times[idx]), rgb=cached[0], depth=cached[1],
                             c2w=np.array(self._poses[idx], dtype=np.float64), K=self.intrinsics)
        rng = frame_rng(self._seed, idx) if self.camera.sensor is not None else None
        frame = self.camera.render(self._poses[idx], t=float(self._times[idx]), index=idx, rng=rng)
        if store is not None:
            store.save(idx, frame.rgb, frame.depth)
        return frame

    def position(self, t: float) -> np.ndarray:
        return self.trajectory.position(t)


class DatasetFrameSource:
    """Frames read from dataset files (decoded on demand), resized to ``K`` and passed
    through the sensor model (depth range limits at least)."""

    def __init__(self, frames: list[DatasetFrame], native: Intrinsics, K: Intrinsics, depth_scale: float,
                 sensor: SensorConfig | None, seed: int) -> None:
        if not frames:
            raise ValueError("a DatasetFrameSource needs at least one frame")
        self._frames = frames
        self.native = native
        self.intrinsics = K
        self.depth_scale = depth_scale
        self.sensor = sensor
        self._seed = int(seed)
        times = np.array([f.t for f in frames])
        poses = np.stack([f.c2w for f in frames])
        # a trajectory through the frames' poses, for positions between frames
        if len(times) > 1 and np.any(np.diff(times) <= 0):
            times = np.arange(len(times), dtype=np.float64) * max(np.median(np.diff(np.sort(times))), 1e-3)
            self._frames = [DatasetFrame(float(t), f.c2w, f.rgb_path, f.depth_path) for t, f in zip(times, frames)]
        self.trajectory = Trajectory(times, poses, loop=False, source="dataset frames")

    def frames(self) -> list[tuple[float, np.ndarray]]:
        return [(f.t, f.c2w.copy()) for f in self._frames]

    def __len__(self) -> int:
        return len(self._frames)

    def load_depth(self, idx: int) -> np.ndarray:
        """Depth of frame ``idx`` at native resolution (m), without the sensor model."""
        f = self._frames[idx]
        return read_depth(f.depth_path, self.depth_scale, (self.native.width, self.native.height))

    def render(self, idx: int) -> Frame:
        f = self._frames[idx]
        size = (self.native.width, self.native.height)
        depth = read_depth(f.depth_path, self.depth_scale, size)
        rgb = read_rgb(f.rgb_path, size)
        rgb, depth = resize_frame(rgb, depth, self.intrinsics)
        if self.sensor is not None:
            rgb, depth = apply_sensor(rgb, depth, self.sensor, frame_rng(self._seed, idx))
        return Frame(index=idx, t=f.t, rgb=rgb.astype(np.float32), depth=depth.astype(np.float32),
                     c2w=f.c2w.copy(), K=self.intrinsics)

    def position(self, t: float) -> np.ndarray:
        return self.trajectory.position(t)
