"""Composing the world of a run from its :class:`WorldConfig`: the scene, each agent's
frame source and trajectory, and the camera intrinsics."""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Callable

import numpy as np

from ramensim.core.frames import Frame, FrameFeed, Intrinsics
from ramensim.core.errors import InputError
from ramensim.world.camera import RGBDCamera
from ramensim.world.config import (BuiltinSceneConfig, DatasetSceneConfig, FileTrajectoryConfig,
                                   MeshSceneConfig, WorldConfig)
from ramensim.world.datasets import read_replica, read_scannet, read_tum, split_frames
from ramensim.world.datasets.common import DatasetFrame, Sequence
from ramensim.world.frame_cache import attach_frame_cache
from ramensim.world.scenes import Scene, builtin_scene, load_mesh_scene
from ramensim.world.sources import DatasetFrameSource, FrameSource, RenderedFrameSource
from ramensim.world.trajectories import Trajectory, load_matrix, load_tum, procedural_trajectories

log = logging.getLogger(__name__)

RngFactory = Callable[[str], np.random.Generator]


@dataclass
class World:
    """The world of one run.

    ``scene``: ground-truth mesh and bounds, or None for a dataset without a mesh;
    ``sources[i]``: agent i's frames; ``intrinsics``: the frames' camera; ``bounds`` (2, 3)
    metres: the region to map (the scene's bounds, else estimated from the depth images);
    ``fps`` frames/s and ``keyframe_every`` from the camera settings.
    """

    scene: Scene | None
    sources: list[FrameSource]
    intrinsics: Intrinsics
    bounds: np.ndarray
    fps: float
    keyframe_every: int
    camera: RGBDCamera | None = field(default=None, repr=False)

    @property
    def n_agents(self) -> int:
        return len(self.sources)

    @property
    def trajectories(self) -> list[Trajectory]:
        return [s.trajectory for s in self.sources]

    def position(self, agent: int, t: float) -> np.ndarray:
        """Camera centre (3,) in metres of ``agent`` at time ``t`` (s), e.g. for radio range."""
        return self.sources[agent].position(t)

    def frames_for(self, agent: int) -> list[tuple[float, np.ndarray]]:
        """``agent``'s frame schedule: [(t seconds, c2w (4, 4))]."""
        return self.sources[agent].frames()

    def render(self, agent: int, idx: int) -> Frame:
        """Frame ``idx`` of ``agent`` (rendered or read on demand)."""
        return self.sources[agent].render(idx)

    def is_keyframe(self, idx: int) -> bool:
        """Every k-th frame (k = keyframe_every), starting with the first, is a keyframe."""
        return idx % self.keyframe_every == 0

    def frame_feed(self, agent: int) -> FrameFeed:
        """What ``agent``'s camera delivers to its mapper."""
        return FrameFeed(times=[t for t, _ in self.frames_for(agent)], render=partial(self.render, agent),
                           is_keyframe=self.is_keyframe, taken_by=lambda k: agent)

    def close(self) -> None:
        if self.camera is not None:
            self.camera.close()


def _resolve(path: str, base_dir: Path | None) -> Path:
    p = Path(path).expanduser()
    return p if p.is_absolute() or base_dir is None else Path(base_dir) / p


def _default_rngs(name: str) -> np.random.Generator:
    from ramensim.core.seeding import Seeds

    return Seeds(0).numpy(name)


def _seed_of(rng_factory: RngFactory, name: str) -> int:
    return int(rng_factory(name).integers(0, 2**63 - 1))


def load_scene(cfg: WorldConfig, base_dir: Path | None = None) -> Scene | None:
    """The ground-truth scene of ``cfg`` (None for a dataset without a mesh)."""
    sc = cfg.scene
    if isinstance(sc, BuiltinSceneConfig):
        return builtin_scene(sc.name, sc.seed)
    if isinstance(sc, MeshSceneConfig):
        return load_mesh_scene(_resolve(sc.path, base_dir), sc.bounds, sc.default_color, sc.up_axis,
                               sc.bounds_padding)
    seq = _read_sequence(sc, base_dir)
    mesh = _resolve(sc.mesh, base_dir) if sc.mesh else seq.mesh_path
    return load_mesh_scene(mesh) if mesh is not None else None


def build_world(cfg: WorldConfig, n_agents: int, duration_s: float, rng_factory: RngFactory | None = None,
                base_dir: str | Path | None = None, threads: int | None = None) -> World:
    """Build the world for ``n_agents`` agents over ``duration_s`` simulated seconds.

    ``rng_factory(name)`` gives the generator of a named component (e.g.
    ``ramensim.core.seeding.Seeds(seed).numpy``); ``base_dir`` resolves relative file paths (the
    scenario's folder); ``threads`` = ray-casting threads (default: all cores).
    Mesh scenes: agent i's frames are at t = k / fps for t < duration_s along its
    trajectory. Datasets: agent i gets its share of the sequence (contiguous chunk or
    region), timed from 0 s; frames past duration_s are kept (the run stops on its own).
    """
    if n_agents < 1:
        raise InputError(f"the number of agents is {n_agents}; expected at least 1.")
    rngs = rng_factory or _default_rngs
    base = Path(base_dir) if base_dir is not None else None
    cam = cfg.camera
    if isinstance(cfg.scene, DatasetSceneConfig):
        return _dataset_world(cfg, n_agents, rngs, base)
    if len(np.arange(0.0, duration_s, 1.0 / cam.fps)) == 0:
        raise InputError(f"the run lasts {duration_s:g} s, so no agent gets a camera frame (one every "
                         f"{1.0 / cam.fps:g} s at world.camera.fps = {cam.fps:g}); give a positive duration.")
    scene = load_scene(cfg, base)
    K = Intrinsics(cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height)
    camera = RGBDCamera(scene.mesh, K, cam.sensor, threads)  # range limits always apply; noise if set
    tcfg = cfg.trajectory
    if isinstance(tcfg, FileTrajectoryConfig):
        if len(tcfg.paths) < n_agents:
            raise InputError(f"world.trajectory.paths lists {len(tcfg.paths)} file(s) but there are {n_agents} "
                             f"agents; expected one trajectory file per agent.")
        load = (lambda p: load_tum(p, tcfg.loop)) if tcfg.format == "tum" else \
            (lambda p: load_matrix(p, tcfg.fps, tcfg.loop))
        trajs = [load(_resolve(p, base)) for p in tcfg.paths[:n_agents]]
    else:
        seed = _seed_of(rngs, "world.trajectory")
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, tcfg.seed])))
        trajs = procedural_trajectories(camera.caster, scene.bounds, n_agents, duration_s, tcfg, rng)
    times = np.arange(0.0, duration_s, 1.0 / cam.fps)
    sources = [RenderedFrameSource(camera, trajs[i], times, _seed_of(rngs, f"world.sensor.{i}"))
               for i in range(n_agents)]
    attach_frame_cache(sources, camera)  # a trial's frames rendered once (world/frame_cache.py)
    return World(scene, sources, K, scene.bounds.copy(), cam.fps, cam.keyframe_every, camera)


def _read_sequence(sc: DatasetSceneConfig, base: Path | None) -> Sequence:
    root = _resolve(sc.path, base)
    if sc.kind == "replica":
        seq = read_replica(root, sc.fps, sc.skip_invalid_poses)
    elif sc.kind == "scannet":
        seq = read_scannet(root, sc.fps, sc.skip_invalid_poses)
    else:
        seq = read_tum(root, sc.max_time_diff, sc.skip_invalid_poses)
    frames = seq.frames[::sc.stride]
    if sc.max_frames is not None:
        frames = frames[:sc.max_frames]
    if not frames:
        raise InputError(f"{root}: no frames left after stride {sc.stride} and max_frames {sc.max_frames}.")
    seq.frames = frames
    if sc.depth_scale is not None:
        seq.depth_scale = sc.depth_scale
    return seq


def _dataset_world(cfg: WorldConfig, n_agents: int, rngs: RngFactory, base: Path | None) -> World:
    sc: DatasetSceneConfig = cfg.scene  # type: ignore[assignment]
    cam = cfg.camera
    seq = _read_sequence(sc, base)
    native = seq.K if sc.intrinsics == "dataset" else Intrinsics(cam.fx, cam.fy, cam.cx, cam.cy,
                                                                 cam.width, cam.height)
    K = native if sc.image_scale == 1.0 else native.scaled(sc.image_scale)
    if 2 * sc.crop_edge >= min(native.width, native.height):
        raise InputError(f"world.scene.crop_edge is {sc.crop_edge} pixels, but the images are {native.width}x"
                         f"{native.height}; expected fewer than half the smaller side.")
    parts = split_frames(seq.frames, n_agents, sc.split)
    sources = []
    for i, idx in enumerate(parts):
        fr = [seq.frames[k] for k in idx]
        if sc.split == "chunks":
            t0 = fr[0].t
            fr = [DatasetFrame(f.t - t0, f.c2w, f.rgb_path, f.depth_path) for f in fr]
        else:
            fr = [DatasetFrame(j / sc.fps, f.c2w, f.rgb_path, f.depth_path) for j, f in enumerate(fr)]
        src_cls = partial(CroppedDatasetFrameSource, crop=sc.crop_edge) if sc.crop_edge else DatasetFrameSource
        sources.append(src_cls(fr, native, K, seq.depth_scale, cam.sensor, _seed_of(rngs, f"world.sensor.{i}")))
    mesh = _resolve(sc.mesh, base) if sc.mesh else seq.mesh_path
    scene = load_mesh_scene(mesh) if mesh is not None else None
    if sc.bounds is not None:
        bounds = np.asarray(sc.bounds, dtype=np.float64)
    else:
        bounds = scene.bounds.copy() if scene is not None else _bounds_from_depth(sources)
    fps = sc.fps
    return World(scene, sources, K, bounds, fps, cam.keyframe_every, None)


class CroppedDatasetFrameSource(DatasetFrameSource):
    """Dataset frames whose ``crop`` border pixels (at native resolution) read no depth:
    NICE-SLAM/Co-SLAM's ``crop_edge``. The map draws rays among valid-depth pixels only, so
    this is their crop (and shifted intrinsics) for mapping; the images keep their size."""

    def __init__(self, *args, crop: int, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.crop = int(crop)

    @staticmethod
    def _zero_border(depth: np.ndarray, c: int) -> np.ndarray:
        if c <= 0:
            return depth
        d = depth.copy()
        d[:c] = 0.0
        d[-c:] = 0.0
        d[:, :c] = 0.0
        d[:, -c:] = 0.0
        return d

    def load_depth(self, idx: int) -> np.ndarray:
        return self._zero_border(super().load_depth(idx), self.crop)

    def render(self, idx: int) -> Frame:
        f = super().render(idx)
        c = int(np.ceil(self.crop * self.intrinsics.width / self.native.width))  # at the rendered size
        return Frame(index=f.index, t=f.t, rgb=f.rgb, depth=self._zero_border(f.depth, c), c2w=f.c2w, K=f.K)


def _bounds_from_depth(sources: list[DatasetFrameSource], n_frames: int = 12, pad: float = 0.2) -> np.ndarray:
    """Scene bounds (2, 3) in metres estimated by back-projecting every 8th pixel of up to
    ``n_frames`` frames spread over all agents (0.5 / 99.5 percentiles, padded by ``pad``)."""
    pts = []
    total = sum(len(s) for s in sources)
    picks = np.unique(np.linspace(0, total - 1, min(n_frames, total)).astype(int))
    offsets = np.cumsum([0] + [len(s) for s in sources])
    for g in picks:
        a = int(np.searchsorted(offsets, g, side="right") - 1)
        src = sources[a]
        k = int(g - offsets[a])
        d = src.load_depth(k)[::8, ::8]
        K = src.native
        v, u = np.nonzero(d > 0)
        z = d[v, u]
        u, v = u * 8, v * 8
        pc = np.stack([(u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z], axis=1)
        c2w = src.frames()[k][1]
        pts.append(pc @ c2w[:3, :3].T + c2w[:3, 3])
        pts.append(c2w[None, :3, 3])
    P = np.concatenate(pts)
    lo, hi = np.percentile(P, 0.5, axis=0) - pad, np.percentile(P, 99.5, axis=0) + pad
    return np.stack([lo, hi])
