"""A synthetic event stream shaped like a real run (frames, rounds, messages, meshes,
uncertainty, metrics, notices) over a simple room, for the recorder's tests, its
benchmark and a demo recording. Not a simulation: the numbers are made up, but every
event type and field is exercised with realistic sizes and rates."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ramensim.core.events import (
    Diverged,
    Event,
    Fate,
    FrameCaptured,
    LinkChange,
    MapSnapshot,
    MessageDelivered,
    MessageDropped,
    MessageSent,
    MetricsEvaluated,
    Notice,
    RoundCompleted,
    UncertaintySnapshot,
)

DROP_REASONS = tuple(f.reason for f in (Fate.LOSS, Fate.OUT_OF_RANGE, Fate.WINDOW_CLOSED, Fate.QUEUE_OVERFLOW))


@dataclass(frozen=True)
class SyntheticScene:
    """A room mesh: vertices (V, 3) m, faces (F, 3), colours (V, 3) uint8, bounds (2, 3) m."""

    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray
    bounds: np.ndarray


def grid_box(lo: np.ndarray, hi: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The six faces of the box [lo, hi] (m), each an n x n grid of quads split into
    triangles; returns vertices (6 (n+1)^2, 3) and faces (12 n^2, 3), outward normals."""
    verts, faces = [], []
    u = np.linspace(0.0, 1.0, n + 1)
    uu, vv = np.meshgrid(u, u, indexing="ij")
    for axis in range(3):
        for side in (0, 1):
            a, b = [d for d in range(3) if d != axis]
            p = np.zeros((n + 1, n + 1, 3))
            p[..., axis] = hi[axis] if side else lo[axis]
            p[..., a] = lo[a] + uu * (hi[a] - lo[a])
            p[..., b] = lo[b] + vv * (hi[b] - lo[b])
            base = sum(len(v) for v in verts)
            verts.append(p.reshape(-1, 3))
            idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1) + base
            q = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1).reshape(-1, 4)
            t1, t2 = q[:, [0, 1, 2]], q[:, [0, 2, 3]]
            flip = (side == 1) == ((axis == 1))  # keep a consistent winding per face
            if flip:
                t1, t2 = t1[:, ::-1], t2[:, ::-1]
            faces.append(np.concatenate([t1, t2]))
    return np.concatenate(verts), np.concatenate(faces).astype(np.int64)


def synthetic_scene(subdivisions: int = 20) -> SyntheticScene:
    """A 6 x 4 x 3 m room (z up) with a table-sized box, coloured by height."""
    room_v, room_f = grid_box(np.array([-3.0, -2.0, 0.0]), np.array([3.0, 2.0, 3.0]), subdivisions)
    box_v, box_f = grid_box(np.array([-0.5, -0.4, 0.0]), np.array([0.5, 0.4, 0.8]), max(2, subdivisions // 4))
    v = np.concatenate([room_v, box_v])
    f = np.concatenate([room_f[:, ::-1], box_f + len(room_v)])  # room seen from inside
    h = (v[:, 2] / 3.0)[:, None]
    c = np.clip(np.array([200, 170, 120]) * (1 - h) + np.array([120, 160, 210]) * h, 0, 255).astype(np.uint8)
    return SyntheticScene(v, f, c, np.array([[-3.0, -2.0, 0.0], [3.0, 2.0, 3.0]]))


def _look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Camera-to-world (4x4, OpenCV axes: x right, y down, z forward) looking at target, z up world."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, np.array([0.0, 0.0, 1.0]))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, eye
    return m


def synthetic_events(n_agents: int = 3, duration_s: float = 20.0, *, rng: np.random.Generator,
                     fps: float = 10.0, round_hz: float = 5.0, image_hw: tuple[int, int] = (120, 160),
                     mesh_period_s: float = 5.0, metrics_period_s: float = 2.0,
                     success_rate: float = 0.7, scene: SyntheticScene | None = None) -> list[Event]:
    """Events of ``n_agents`` circling a room for ``duration_s`` simulated seconds, sorted
    by time. Images are shared arrays (a few per agent) to keep memory small; messages
    go to every other agent after each round and arrive with probability ``success_rate``."""
    scene = scene if scene is not None else synthetic_scene()
    h, w = image_hw
    fx = fy = 0.8 * w
    K = (fx, fy, (w - 1) / 2, (h - 1) / 2, w, h)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    images = []
    for a in range(n_agents):
        rgb = np.stack([xx / w, yy / h, np.full_like(xx, (a + 1) / (n_agents + 1))], axis=-1).astype(np.float32)
        depth = (1.0 + 2.0 * yy / h + 0.1 * a).astype(np.float32)
        images.append((rgb, depth))
    ev: list[Event] = []
    center = np.array([0.0, 0.0, 0.4])

    def pose(a: int, t: float) -> np.ndarray:
        ang = 0.3 * t + 2 * math.pi * a / n_agents
        eye = np.array([2.0 * math.cos(ang), 1.3 * math.sin(ang), 1.2 + 0.1 * a])
        return _look_at(eye, center)

    for a in range(n_agents):
        for i in range(int(duration_s * fps) + 1):
            t = i / fps
            rgb, depth = images[a]
            ev.append(FrameCaptured(t=t, agent=a, index=i, keyframe=(i % 5 == 0), rgb=rgb, depth=depth,
                                    c2w=pose(a, t), K=K))
    msg = 0
    for a in range(n_agents):
        for r in range(int(duration_s * round_hz)):
            t = (r + 1) / round_hz + 1e-3 * a
            loss = 2.0 * math.exp(-t / 8.0) + 0.05 * float(rng.random())
            ages = {b: (None if r == 0 else round(float(rng.uniform(0.0, 1.0)), 3))
                    for b in range(n_agents) if b != a}
            ev.append(RoundCompleted(t=t, agent=a, round=r, duration=1.0 / round_hz,
                                     scalars={"loss": loss, "loss_sdf": 0.6 * loss, "dual_norm": 0.1 * loss},
                                     copy_ages=ages))
            for b in range(n_agents):
                if b == a:
                    continue
                msg += 1
                nbytes = 200_000 + int(rng.integers(0, 1000))
                ev.append(MessageSent(t=t, msg_id=msg, src=a, dst=b, nbytes=nbytes, stamp=t))
                if rng.random() < success_rate:
                    lat = float(rng.uniform(0.01, 0.2))
                    ev.append(MessageDelivered(t=t + lat, msg_id=msg, src=a, dst=b, nbytes=nbytes, stamp=t,
                                               latency=lat, age=lat))
                else:
                    reason = DROP_REASONS[int(rng.integers(0, len(DROP_REASONS)))]
                    ev.append(MessageDropped(t=t + 0.05, msg_id=msg, src=a, dst=b, nbytes=nbytes, stamp=t,
                                             reason=reason))
    nf = len(scene.faces)
    for k in range(1, int(duration_s / mesh_period_s) + 1):
        t = k * mesh_period_s
        frac = min(1.0, k * mesh_period_s / duration_s)
        for a in range(n_agents):
            f = scene.faces[: max(1, int(frac * nf))]
            used, inv = np.unique(f, return_inverse=True)
            ev.append(MapSnapshot(t=t, agent=a, vertices=scene.vertices[used].astype(np.float32),
                                  faces=inv.reshape(-1, 3).astype(np.int64), colors=scene.colors[used]))
            g = np.stack(np.meshgrid(*[np.linspace(lo, hi, 8) for lo, hi in zip(*scene.bounds)],
                                     indexing="ij"), -1).reshape(-1, 3)
            counts = rng.poisson(lam=10.0 * frac, size=len(g)).astype(np.float64)
            ev.append(UncertaintySnapshot(t=t, agent=a, points=g, counts=counts))
    for k in range(1, int(duration_s / metrics_period_s) + 1):
        t = k * metrics_period_s
        for a in range(n_agents):
            ev.append(MetricsEvaluated(t=t, agent=a, metrics={"completion_ratio_pct": min(100.0, 5.0 * t),
                                                              "artifacts_cm": 10.0 / (1.0 + t)}))
        ev.append(MetricsEvaluated(t=t, agent=-1, metrics={"consensus_error": 1.0 / (1.0 + t)}))
    if n_agents >= 2:
        ev.append(LinkChange(t=0.0, a=0, b=1, up=True, cause="range"))
        ev.append(LinkChange(t=duration_s / 2, a=0, b=1, up=False, cause="window"))
    ev.append(Notice(t=duration_s / 2, text="communication window closed", level="warning"))
    ev.append(Notice(t=0.0, text="run started", level="info", agent=0))
    if n_agents >= 3:
        ev.append(Diverged(t=duration_s * 0.9, agent=n_agents - 1, round=int(duration_s * 0.9 * round_hz),
                           reason="non-finite loss"))
    ev.sort(key=lambda e: e.t)
    return ev
