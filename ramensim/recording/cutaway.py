"""The cut-away view of a closed scene (and of the maps) for the recording: everything
below a horizontal cut plane is drawn as it is, steep faces above it (the upper walls) are
drawn faded, and the rest above it (ceilings, lights, the tops of walls) is left out, so
that the rooms and the maps in them are seen from above like a doll's house.

Triangles that cross the plane are clipped exactly: with signed heights d_i = h(v_i) - c of
a triangle's vertices along the up axis (m), an edge (i, j) with d_i and d_j of opposite
signs meets the plane at p = v_i + (v_j - v_i) d_i / (d_i - d_j), and the part on the kept
side is re-triangulated with the winding of the original (one triangle when one vertex is
kept, two when two are). Vertex colours are interpolated with the same weights.
Pure numpy; inputs are never modified.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UP_AXES = {"RIGHT_HAND_Z_UP": (0.0, 0.0, 1.0), "FLU": (0.0, 0.0, 1.0), "RIGHT_HAND_Y_UP": (0.0, 1.0, 0.0),
           "RUB": (0.0, 1.0, 0.0), "RIGHT_HAND_Y_DOWN": (0.0, -1.0, 0.0), "RDF": (0.0, -1.0, 0.0)}
"""The world's up direction (unit vector) for each ``recording.world_coordinates`` preset."""

STEEP_COS = 0.5
"""A face is steep (a wall) when |cos| of the angle between its normal and up is below this
(steeper than 60 degrees from horizontal)."""


def up_vector(world_coordinates: str) -> np.ndarray:
    """The up direction (3,) of a ``world_coordinates`` preset (z up when unknown)."""
    return np.asarray(UP_AXES.get(world_coordinates, (0.0, 0.0, 1.0)), dtype=np.float64)


@dataclass(frozen=True)
class MeshPart:
    """A triangle mesh: vertices (V, 3) float32 m, faces (F, 3) uint32, colours (V, C)
    uint8 or None."""

    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray | None

    def __len__(self) -> int:
        return len(self.faces)


def cut_height(lo: float, hi: float, fraction: float) -> float:
    """The cut plane's height (m along up): ``fraction`` of the way from ``lo`` to ``hi``."""
    return float(lo + fraction * (hi - lo))


def _compact(v: np.ndarray, f: np.ndarray, c: np.ndarray | None) -> MeshPart:
    """Drop unreferenced vertices (faces renumbered in order of first use of the sorted ids)."""
    if len(f) == 0:
        return MeshPart(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32),
                        None if c is None else np.zeros((0, c.shape[1]), np.uint8))
    used, inv = np.unique(f.reshape(-1), return_inverse=True)
    return MeshPart(v[used].astype(np.float32), inv.reshape(-1, 3).astype(np.uint32),
                    None if c is None else c[used])


def clip_below(vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray | None, up: np.ndarray,
               height: float, face_mask: np.ndarray | None = None) -> MeshPart:
    """The part of the mesh at or below ``height`` (m along ``up``), crossing triangles
    clipped (module docstring). ``face_mask`` (F,) bool keeps only those faces first."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    c = None if colors is None else np.asarray(colors)
    if face_mask is not None:
        f = f[np.asarray(face_mask, dtype=bool)]
    if len(f) == 0 or len(v) == 0:
        return _compact(v, f[:0], c)
    d = v @ np.asarray(up, dtype=np.float64) - float(height)
    # a face that only touches the plane from above (no vertex strictly below, not all on it)
    # would clip to a sliver of zero area: leave it out
    df = d[f]
    f = f[(df < 0.0).any(axis=1) | (df == 0.0).all(axis=1)]
    below = d[f] <= 0.0
    nb = below.sum(axis=1)
    new_v, new_c, new_f = [v], [] if c is None else [c.astype(np.float64)], [f[nb == 3]]
    base = len(v)

    def cross(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Indices of new vertices where edges (i, j) meet the plane (i kept, j cut off)."""
        nonlocal base
        t = (d[i] / (d[i] - d[j]))[:, None]
        new_v.append(v[i] + (v[j] - v[i]) * t)
        if c is not None:
            cf = c.astype(np.float64)
            new_c.append(cf[i] + (cf[j] - cf[i]) * t)
        idx = np.arange(base, base + len(i))
        base += len(i)
        return idx

    # one vertex kept: roll it to the front, then (a, ab, ac) keeps the winding
    one = f[nb == 1]
    if len(one):
        first = np.argmax(below[nb == 1], axis=1)
        r = np.stack([one[np.arange(len(one)), (first + k) % 3] for k in range(3)], axis=1)
        p_ab, p_ac = cross(r[:, 0], r[:, 1]), cross(r[:, 0], r[:, 2])
        new_f.append(np.stack([r[:, 0], p_ab, p_ac], axis=1))
    # two kept: roll the cut-off vertex a to the front; the polygon b, c, p_ca, p_ab
    two = f[nb == 2]
    if len(two):
        first = np.argmin(below[nb == 2], axis=1)
        r = np.stack([two[np.arange(len(two)), (first + k) % 3] for k in range(3)], axis=1)
        p_ca, p_ab = cross(r[:, 2], r[:, 0]), cross(r[:, 1], r[:, 0])
        new_f.append(np.stack([r[:, 1], r[:, 2], p_ca], axis=1))
        new_f.append(np.stack([r[:, 1], p_ca, p_ab], axis=1))
    vv = np.concatenate(new_v)
    ff = np.concatenate(new_f)
    cc = None
    if c is not None:
        cc = np.clip(np.rint(np.concatenate(new_c)), 0, 255).astype(np.uint8) if c.dtype == np.uint8 \
            else np.concatenate(new_c).astype(c.dtype)
    return _compact(vv, ff, cc)


def steep_faces(vertices: np.ndarray, faces: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(F,) bool: faces whose normal is within 60 degrees of horizontal (walls, sides);
    degenerate faces count as not steep."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(n, axis=1)
    cos = np.abs(n @ np.asarray(up, dtype=np.float64)) / np.where(norm > 0, norm, 1.0)
    return (norm > 0) & (cos < STEEP_COS)


def cutaway(vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray | None, up: np.ndarray,
            height: float) -> tuple[MeshPart, MeshPart]:
    """(lower, upper walls): the mesh clipped to at or below ``height`` (m along ``up``), and
    its steep faces clipped to at or above it. What is above the plane and not steep
    (ceilings) is in neither."""
    up = np.asarray(up, dtype=np.float64)
    lower = clip_below(vertices, faces, colors, up, height)
    upper = clip_below(vertices, faces, colors, -up, -float(height), face_mask=steep_faces(vertices, faces, up))
    return lower, upper
