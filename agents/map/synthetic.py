"""A tiny analytic scene for tests, benchmarks and decoder pretraining without the world
package: an axis-aligned box room (3 x 3 x 2.5 m) holding a sphere and a box, coloured by
position, seen by a pinhole camera orbiting inside. Depth is exact ray casting.
"""
from __future__ import annotations

import math

import numpy as np

from ramensim.core.frames import Frame, Intrinsics

ROOM_LO = np.array([0.0, 0.0, 0.0])
ROOM_HI = np.array([3.0, 3.0, 2.5])
SPHERE_C = np.array([2.15, 0.8, 0.5])
SPHERE_R = 0.4
BOX_LO = np.array([0.6, 1.8, 0.0])
BOX_HI = np.array([1.3, 2.5, 0.8])


def bounds(margin: float = 0.1) -> np.ndarray:
    """Scene bounds (2, 3) in metres: the room plus ``margin`` on each side."""
    return np.stack([ROOM_LO - margin, ROOM_HI + margin])


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Camera-to-world (4, 4), OpenCV axes (x right, y down, z forward), world z up."""
    f = target - eye
    f = f / np.linalg.norm(f)
    right = np.cross(f, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(f, right)
    c2w = np.eye(4)
    c2w[:3, 0], c2w[:3, 1], c2w[:3, 2], c2w[:3, 3] = right, down, f, eye
    return c2w


def cast(o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Ray parameter t of the first hit (N,) for rays o + d t from inside the room."""
    inv = 1.0 / np.where(np.abs(d) < 1e-12, 1e-12, d)
    t_room = np.min(np.where(d > 0, (ROOM_HI - o) * inv, (ROOM_LO - o) * inv), axis=1)
    t = t_room
    # sphere
    oc = o - SPHERE_C
    a = np.sum(d * d, axis=1)
    b = np.sum(oc * d, axis=1)
    c = np.sum(oc * oc, axis=1) - SPHERE_R ** 2
    disc = b * b - a * c
    ok = disc > 0
    ts = np.where(ok, (-b - np.sqrt(np.maximum(disc, 0))) / a, np.inf)
    t = np.where((ts > 1e-6) & (ts < t), ts, t)
    # box (slab test)
    t1, t2 = (BOX_LO - o) * inv, (BOX_HI - o) * inv
    tn = np.max(np.minimum(t1, t2), axis=1)
    tf = np.min(np.maximum(t1, t2), axis=1)
    hit = (tn <= tf) & (tn > 1e-6)
    return np.where(hit & (tn < t), tn, t)


def colour(p: np.ndarray) -> np.ndarray:
    """Smooth colour (N, 3) in [0, 1] as a function of world position."""
    return np.clip(np.stack([0.5 + 0.4 * np.sin(2.1 * p[:, 0] + 0.3),
                             0.5 + 0.4 * np.sin(1.7 * p[:, 1] + 1.1),
                             0.5 + 0.4 * np.cos(2.3 * p[:, 2])], axis=1), 0.0, 1.0)


def render(c2w: np.ndarray, K: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Exact (rgb (H, W, 3) float32, depth (H, W) float32 metres) of the scene."""
    v, u = np.mgrid[0:K.height, 0:K.width]
    d_cam = np.stack([(u.ravel() - K.cx) / K.fx, (v.ravel() - K.cy) / K.fy,
                      np.ones(u.size)], axis=1)
    d = d_cam @ c2w[:3, :3].T
    o = np.broadcast_to(c2w[:3, 3], d.shape)
    t = cast(o, d)
    rgb = colour(o + d * t[:, None])
    return (rgb.reshape(K.height, K.width, 3).astype(np.float32),
            t.reshape(K.height, K.width).astype(np.float32))


def intrinsics(width: int = 80, height: int = 60) -> Intrinsics:
    """Pinhole intrinsics with a ~77 degree horizontal field of view."""
    f = 0.625 * width
    return Intrinsics(f, f, (width - 1) / 2, (height - 1) / 2, width, height)


def trajectory(n: int, phase: float = 0.0) -> list[np.ndarray]:
    """n camera poses on an orbit around the room centre, looking outwards and down."""
    centre = (ROOM_LO + ROOM_HI) / 2
    poses = []
    for i in range(n):
        a = 2 * math.pi * (i / n) + phase
        eye = centre + np.array([0.35 * math.cos(a), 0.35 * math.sin(a), 0.2 * math.sin(3 * a)])
        target = eye + np.array([math.cos(a + 0.6), math.sin(a + 0.6), -0.35 - 0.25 * math.cos(2 * a)])
        poses.append(look_at(eye, target))
    return poses


def frames(n: int = 24, width: int = 80, height: int = 60, phase: float = 0.0,
           fps: float = 5.0) -> list[Frame]:
    """n RGB-D frames along ``trajectory(n, phase)``."""
    K = intrinsics(width, height)
    out = []
    for i, c2w in enumerate(trajectory(n, phase)):
        rgb, depth = render(c2w, K)
        out.append(Frame(index=i, t=i / fps, rgb=rgb, depth=depth, c2w=c2w, K=K))
    return out
