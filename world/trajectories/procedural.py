"""Procedural trajectories, the entry point: walking-speed camera paths through a scene's free
space for every agent, as split 'none' / 'regions' (:mod:`.freespace`) or 'chunks' (:mod:`.tour`).
"""
from __future__ import annotations

import logging

import numpy as np

from ramensim.core.errors import InputError
from ramensim.world.trajectories.freespace import FreeSpace, _loop_path, _poses_along, _region_masks, _split_too_fine
from ramensim.world.trajectories.poses import Trajectory
from ramensim.world.trajectories.tour import _chunk_trajectories

log = logging.getLogger(__name__)


def procedural_trajectories(caster, bounds: np.ndarray, n_agents: int, duration: float, cfg,
                            rng: np.random.Generator, rate: float = 10.0) -> list[Trajectory]:
    """Walking-speed camera paths for ``n_agents`` agents through the free space of the mesh
    behind ``caster`` (a :class:`ramensim.world.camera.MeshRayCaster`).

    ``cfg`` is a ProceduralTrajectoryConfig (speed m/s, height m, pitch deg, clearance m,
    split), sampled at ``rate`` poses/s over [0, duration] s. Split 'none' / 'regions': each
    path is a smoothed closed loop in the agent's region walked repeatedly at ``cfg.speed``;
    the camera looks along the path blended towards the centre of the agent's region
    (``look_at_center``). Split 'chunks': one tour through every room (:func:`chunk_tour`) is
    cut by arc length into ``n_agents`` equal contiguous chunks; agent i walks chunk i from
    its start at ``cfg.speed`` (or ``cfg.chunk_passes`` times over the run, each agent at its
    own speed, chunk length x passes / duration in m/s) and back (ping-pong), looking along the path blended towards
    the centre of the room it is in. The camera pitches by pitch_deg in both cases. With
    ``chunk_passes`` the speed depends on ``duration``, so a shorter run's path is not the
    beginning of a longer one's (it is otherwise, up to the heading's smoothing radius).
    """
    fs = FreeSpace(caster, bounds, cfg.height)
    times = np.arange(0.0, duration + 1.0 / rate, 1.0 / rate)
    if cfg.split == "chunks":
        return _chunk_trajectories(fs, caster, bounds, n_agents, times, cfg, rng, rate, duration)
    regions = _region_masks(fs, n_agents, cfg.split)
    out = []
    for a in range(n_agents):
        try:
            path = _loop_path(fs, regions[a] & fs.free, cfg.clearance, cfg.waypoints, rng)
        except InputError as exc:
            raise InputError(_split_too_fine(fs, n_agents, cfg, a, str(exc))) from None
        closed = np.vstack([path, path[:1]])
        seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        lap = float(arc[-1])
        if lap < 1e-6:
            raise InputError(_split_too_fine(fs, n_agents, cfg, a, "its loop collapsed to a point"))
        start = float(rng.uniform(0, lap))
        direction = 1.0 if rng.random() < 0.5 else -1.0
        s = np.mod(start + direction * cfg.speed * times, lap)
        xy = np.stack([np.interp(s, arc, closed[:, k]) for k in range(2)], axis=1)
        tangent = np.stack([np.interp(np.mod(s + direction * 0.3, lap), arc, closed[:, k]) for k in range(2)], 1) - xy
        jj, ii = np.nonzero(regions[a] & fs.free)
        centre = fs.centre(jj, ii).mean(axis=0)
        out.append(_poses_along(xy, tangent, centre, times, fs, cfg, rng, rate, f"procedural agent {a}"))
        log.debug("agent %d: lap %.1f m, %d poses", a, lap, len(times))
    return out
