"""What each agent's camera sees of a world's ground truth, before any run: the share of the
team's view that each robot has on its own (the room communication has to bring something),
and the share of the whole scene the team sees.

Ground-truth surface points (area-uniform) are tested with the frustum + occlusion test of the
metrics' culling (:func:`ramensim.evaluation.coverage.seen_by_agent`) from every frame pose of
every agent.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ramensim.core.errors import InputError


@dataclass(frozen=True)
class CoverageReport:
    """``own_pct[a]``: share (%) of the points seen by any agent that agent a saw itself;
    ``team_pct``: share (%) of all sampled ground-truth points that any agent saw;
    ``n_points``: points sampled; ``n_seen``: points seen by any agent; ``n_frames[a]``:
    agent a's frames."""

    own_pct: tuple[float, ...]
    team_pct: float
    n_points: int
    n_seen: int
    n_frames: tuple[int, ...]

    def table(self) -> str:
        """The report as a small text table, one line per agent."""
        n = len(self.own_pct)
        lines = ["own coverage: % of what the team sees",
                 f"{'agent':>5} {'frames':>6} {'own %':>6}"]
        for a, (p, f) in enumerate(zip(self.own_pct, self.n_frames)):
            lines.append(f"{a:>5} {f:>6} {p:>6.1f}")
        lines.append(f"1/n = {100.0 / n:.1f} %; the team sees {self.team_pct:.1f} %")
        lines.append(f"of {self.n_points} ground-truth surface points")
        return "\n".join(lines)


def coverage_report(world, near_m: float = 0.0, far_m: float = 1.0e6, n_points: int = 50_000,
                    seed: int = 0, eps_m: float = 0.03, stride: int = 4) -> CoverageReport:
    """Own coverage per agent and team coverage of ``world`` (a :class:`ramensim.world.World`
    with a ground-truth scene) from ``n_points`` area-uniform samples of the scene mesh
    (generator seeded by ``seed``), seen through the world's intrinsics between ``near_m`` and
    ``far_m`` metres, occluded by the scene mesh (depth tolerance ``eps_m`` m, depth rendered
    every ``stride`` pixels), from every frame pose of every agent."""
    from ramensim.evaluation.coverage import seen_by_agent
    from ramensim.evaluation.cull import PinholeCamera
    from ramensim.evaluation.metrics import sample_surface

    if world.scene is None:
        raise InputError("the world has no ground-truth mesh (a dataset without one), so its coverage "
                         "cannot be measured; give world.scene.mesh.")
    K = world.intrinsics
    cam = PinholeCamera.of(K, near_m, far_m)
    points = sample_surface(world.scene.mesh, n_points, np.random.default_rng(seed))
    poses = [np.asarray([c2w for _, c2w in world.frames_for(a)], np.float64).reshape(-1, 4, 4)
             for a in range(world.n_agents)]
    seen = seen_by_agent(points, poses, cam, occluder=world.scene.mesh, eps_m=eps_m, stride=stride)
    union = seen.any(axis=0)
    n_seen = int(union.sum())
    own = tuple(float(100.0 * (seen[a] & union).sum() / n_seen) if n_seen else float("nan")
                for a in range(len(poses)))
    return CoverageReport(own, 100.0 * n_seen / len(points), len(points), n_seen, tuple(len(p) for p in poses))
