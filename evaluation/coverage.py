"""What each robot's camera saw of the ground truth, and what the team saw: the direct
measure of what communication can bring (paper Fig. 1).

Ground-truth surface points are tested for visibility from each agent's camera poses with
the same frustum + occlusion test as the culling of the metrics
(:func:`ramensim.evaluation.cull.visible_points`, docs/ALGORITHM.md section 5). Definitions,
over the points of the *evaluated* ground truth (culled to what any robot saw):

- own coverage of agent a (%): share of the points agent a's camera saw;
- the *unseen part* of agent a: the points a never saw but a teammate did; its completion
  ratio (%) and holes (cm) say how much of the teammates' knowledge reached a's map;
- the *far part* of a map on a communication graph: the points neither its own robot(s) nor
  any of their graph neighbours saw, but some other robot did; what reaches the map there has
  crossed at least two links (paper Fig. 7: information propagation through a path);
- team coverage (%): share of the whole ground-truth surface (area, before culling) that
  any robot saw.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import trimesh

from ramensim.evaluation.cull import PinholeCamera, visible_points


def seen_by_agent(points: np.ndarray, poses_per_agent: Sequence[np.ndarray], cam: PinholeCamera,
                  occluder: trimesh.Trimesh | None = None, eps_m: float = 0.03,
                  stride: int = 4) -> np.ndarray:
    """Boolean (n_agents, N): entry (a, k) is True when point k (metres) is seen by at least
    one of agent a's camera-to-world poses (frustum, plus occlusion by ``occluder``)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.zeros((len(poses_per_agent), len(pts)), dtype=bool)
    for a, poses in enumerate(poses_per_agent):
        poses = np.asarray(poses, dtype=np.float64).reshape(-1, 4, 4)
        if len(poses):
            out[a] = visible_points(pts, poses, cam, occluder=occluder, eps_m=eps_m, stride=stride)
    return out


def own_coverage_pct(seen: np.ndarray) -> np.ndarray:
    """Per agent, the share (%) of the points it saw, from :func:`seen_by_agent`'s mask."""
    seen = np.asarray(seen, dtype=bool)
    if seen.shape[1] == 0:
        return np.full(seen.shape[0], np.nan)
    return seen.mean(axis=1) * 100.0


def unseen_part(seen: np.ndarray, agent: int) -> np.ndarray:
    """Mask of the points ``agent`` never saw but a teammate did."""
    seen = np.asarray(seen, dtype=bool)
    others = np.delete(seen, agent, axis=0).any(axis=0) if seen.shape[0] > 1 else np.zeros(seen.shape[1], bool)
    return others & ~seen[agent]


def own_and_near(n_robots: int, fed_by: Sequence[int],
                 neighbours: Sequence[Sequence[int]] | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Boolean (n_robots,) masks of a map's own robots (``fed_by``) and of those plus their
    graph neighbours (``neighbours``: per robot, its neighbours); the second is None when
    ``neighbours`` is (a graph that changes with time)."""
    own = np.zeros(n_robots, dtype=bool)
    own[list(fed_by)] = True
    if neighbours is None:
        return own, None
    near = own.copy()
    for k in fed_by:
        near[list(neighbours[k])] = True
    return own, near


def far_part(seen: np.ndarray, near: np.ndarray) -> np.ndarray:
    """Mask of the points seen by some robot outside ``near`` and by no robot in it.

    ``seen``: :func:`seen_by_agent`'s (n_agents, N) mask; ``near``: boolean (n_agents,), the
    robots feeding the map and their neighbours on the communication graph."""
    seen = np.asarray(seen, dtype=bool)
    near = np.asarray(near, dtype=bool)
    if near.shape != (seen.shape[0],):
        raise ValueError(f"far_part: near has shape {near.shape}; expected ({seen.shape[0]},), one flag per robot.")
    return seen[~near].any(axis=0) & ~seen[near].any(axis=0)


def area(mesh: trimesh.Trimesh) -> float:
    """Surface area (m^2); 0 for an empty mesh."""
    return float(mesh.area) if len(mesh.faces) else 0.0
