"""Coloured primitives and furniture for the built-in scenes.

A :class:`MeshBuilder` accumulates closed, outward-facing triangle meshes with per-vertex
RGB colours (floats in [0, 1]); furniture functions add the parts of one object and record
its footprint on the floor (for trajectory clearance and scene layout). Units: metres, z up,
the floor at z = 0. ``yaw`` is a rotation about z in multiples of 90 degrees (counted in
quarter turns) so footprints stay axis-aligned rectangles.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

# Unit cube corners and outward-wound triangles (counter-clockwise seen from outside).
_CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                    [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=np.float64)
_CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                    [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]],
                   dtype=np.int64)


@dataclass
class MeshBuilder:
    """Collects coloured triangle soups into one :class:`trimesh.Trimesh`.

    ``rng`` jitters vertex colours slightly (``color_jitter``, fraction of full scale) so
    surfaces carry a little shading variation, like real textures.
    """

    rng: np.random.Generator
    color_jitter: float = 0.04
    vertices: list[np.ndarray] = field(default_factory=list)
    faces: list[np.ndarray] = field(default_factory=list)
    colors: list[np.ndarray] = field(default_factory=list)
    footprints: list[tuple[float, float, float, float]] = field(default_factory=list)
    _count: int = 0

    def add(self, vertices: np.ndarray, faces: np.ndarray, color, jitter: float | None = None) -> None:
        """Append a triangle mesh with one base colour (RGB in [0, 1]), or one per vertex
        ((n, 3)), plus seeded jitter."""
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces, dtype=np.int64)
        j = self.color_jitter if jitter is None else jitter
        base = np.asarray(color, dtype=np.float64)
        c = np.clip((base[None, :] if base.ndim == 1 else base)
                    + self.rng.normal(0.0, j, size=(len(v), 1)), 0.0, 1.0)
        self.vertices.append(v)
        self.faces.append(f + self._count)
        self.colors.append(np.broadcast_to(c, (len(v), 3)).copy())
        self._count += len(v)

    def box(self, lo, hi, color, jitter: float | None = None) -> None:
        """Axis-aligned closed box from corner ``lo`` to ``hi`` (m)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        self.add(lo + _CUBE_V * (hi - lo), _CUBE_F, color, jitter)

    def two_tone_box(self, lo, hi, axis: int, color_lo, color_hi, jitter: float | None = None) -> None:
        """Axis-aligned closed box from ``lo`` to ``hi`` (m) whose face at lo[axis] has colour
        ``color_lo`` and whose face at hi[axis] has ``color_hi`` (e.g. a wall between two
        rooms painted differently on each side; the faces between blend)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        c = np.where(_CUBE_V[:, [axis]] > 0.5, np.asarray(color_hi, float)[None], np.asarray(color_lo, float)[None])
        self.add(lo + _CUBE_V * (hi - lo), _CUBE_F, c, jitter)

    def cylinder(self, center_xy, z0: float, z1: float, radius: float, color, sections: int = 16) -> None:
        """Closed vertical cylinder between heights z0 and z1 (m)."""
        m = trimesh.creation.cylinder(radius=radius, height=z1 - z0, sections=sections)
        m.apply_translation([center_xy[0], center_xy[1], 0.5 * (z0 + z1)])
        self.add(m.vertices, m.faces, color)

    def sphere(self, center, radius: float, color, subdivisions: int = 2) -> None:
        """Closed icosphere (m)."""
        m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
        m.apply_translation(center)
        self.add(m.vertices, m.faces, color)

    def tiled_floor(self, x0: float, x1: float, y0: float, y1: float, z: float, tile: float,
                    colors: list, thickness: float = 0.1) -> None:
        """A slab whose top face (at height z) is a grid of separately coloured square tiles
        (checker of ``colors``), closed by a plain box below it (m)."""
        xs = np.unique(np.concatenate([np.arange(x0, x1, tile), [x1]]))
        ys = np.unique(np.concatenate([np.arange(y0, y1, tile), [y1]]))
        for i in range(len(xs) - 1):
            for j in range(len(ys) - 1):
                v = np.array([[xs[i], ys[j], z], [xs[i + 1], ys[j], z],
                              [xs[i + 1], ys[j + 1], z], [xs[i], ys[j + 1], z]])
                self.add(v, [[0, 1, 2], [0, 2, 3]], colors[(i + j) % len(colors)])
        # sides and bottom: the box without its top (the tiles close it)
        lo = np.array([x0, y0, z - thickness])
        hi = np.array([x1, y1, z])
        self.add(lo + _CUBE_V * (hi - lo), _CUBE_F[[0, 1, 4, 5, 6, 7, 8, 9, 10, 11]], colors[0], 0.0)

    def footprint(self, x0: float, y0: float, x1: float, y1: float) -> None:
        """Record an obstacle's floor rectangle (m)."""
        self.footprints.append((min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)))

    def mesh(self) -> trimesh.Trimesh:
        """The accumulated mesh with per-vertex colours (RGBA uint8)."""
        v = np.concatenate(self.vertices)
        f = np.concatenate(self.faces)
        c = np.concatenate(self.colors)
        rgba = np.concatenate([np.round(c * 255), np.full((len(c), 1), 255)], axis=1).astype(np.uint8)
        return trimesh.Trimesh(vertices=v, faces=f, vertex_colors=rgba, process=False)


class Placer:
    """Maps an object's local frame (x along its width, y along its depth, origin at the
    footprint's lower-left corner) into the room with a quarter-turn yaw, so every
    furniture function can be written once in local coordinates."""

    def __init__(self, b: MeshBuilder, x: float, y: float, w: float, d: float, yaw: int = 0):
        self.b, self.x, self.y, self.w, self.d, self.yaw = b, x, y, w, d, yaw % 4
        fw, fd = (w, d) if self.yaw % 2 == 0 else (d, w)
        b.footprint(x, y, x + fw, y + fd)

    def _pt(self, lx: float, ly: float) -> tuple[float, float]:
        w, d = self.w, self.d
        if self.yaw == 0:
            return self.x + lx, self.y + ly
        if self.yaw == 1:  # quarter turn: local +x -> world +y
            return self.x + (d - ly), self.y + lx
        if self.yaw == 2:
            return self.x + (w - lx), self.y + (d - ly)
        return self.x + ly, self.y + (w - lx)

    def box(self, lx0, ly0, z0, lx1, ly1, z1, color, jitter=None) -> None:
        ax, ay = self._pt(lx0, ly0)
        bx, by = self._pt(lx1, ly1)
        self.b.box([min(ax, bx), min(ay, by), z0], [max(ax, bx), max(ay, by), z1], color, jitter)

    def cylinder(self, lx, ly, z0, z1, r, color, sections=16) -> None:
        self.b.cylinder(self._pt(lx, ly), z0, z1, r, color, sections)

    def sphere(self, lx, ly, z, r, color) -> None:
        px, py = self._pt(lx, ly)
        self.b.sphere([px, py, z], r, color)


def _legs(p: Placer, w: float, d: float, h: float, s: float, color) -> None:
    for lx, ly in ((0, 0), (w - s, 0), (0, d - s), (w - s, d - s)):
        p.box(lx, ly, 0.0, lx + s, ly + s, h, color)


def desk(b: MeshBuilder, x, y, yaw=0, w=1.4, d=0.7, h=0.75, top=(0.55, 0.38, 0.22), leg=(0.2, 0.2, 0.22),
         with_monitor=True, rng: np.random.Generator | None = None) -> None:
    """Desk with thin legs; optionally a monitor (thin screen on a stand), keyboard and mug.
    The desk's front (where a person sits) is local y = 0."""
    p = Placer(b, x, y, w, d, yaw)
    p.box(0, 0, h - 0.03, w, d, h, top)
    _legs(p, w, d, h - 0.03, 0.04, leg)
    if with_monitor:
        mx = 0.5 * w
        p.box(mx - 0.12, d - 0.28, h, mx + 0.12, d - 0.10, h + 0.015, (0.1, 0.1, 0.1))   # base
        p.box(mx - 0.025, d - 0.20, h, mx + 0.025, d - 0.16, h + 0.25, (0.12, 0.12, 0.12))  # neck
        p.box(mx - 0.30, d - 0.16, h + 0.12, mx + 0.30, d - 0.14, h + 0.47, (0.05, 0.05, 0.07))  # screen
        p.box(mx - 0.28, d - 0.165, h + 0.14, mx + 0.28, d - 0.16, h + 0.45, (0.15, 0.3, 0.6), 0.08)
        p.box(mx - 0.22, 0.12, h, mx + 0.22, 0.27, h + 0.02, (0.85, 0.85, 0.82))  # keyboard
        p.cylinder(w - 0.2, 0.2, h, h + 0.1, 0.04, (0.8, 0.15, 0.15) if rng is None
                   else tuple(rng.uniform(0.1, 0.9, 3)), 12)  # mug


def chair(b: MeshBuilder, x, y, yaw=0, color=(0.15, 0.25, 0.55), s=0.45) -> None:
    """Office chair: seat, thin legs and a backrest at local y = s."""
    p = Placer(b, x, y, s, s, yaw)
    p.box(0, 0, 0.43, s, s, 0.48, color)
    _legs(p, s, s, 0.43, 0.03, (0.25, 0.25, 0.25))
    p.box(0, s - 0.05, 0.48, s, s, 0.95, color)


def bookshelf(b: MeshBuilder, x, y, yaw=0, w=0.9, d=0.32, h=1.9, color=(0.45, 0.3, 0.18),
              rng: np.random.Generator | None = None) -> None:
    """Open bookshelf (back at local y = d) with shelves holding books of random colours."""
    p = Placer(b, x, y, w, d, yaw)
    t = 0.02
    p.box(0, 0, 0, t, d, h, color)
    p.box(w - t, 0, 0, w, d, h, color)
    p.box(t, d - t, 0, w - t, d, h, color)
    n = 5
    for k in range(n + 1):
        z = k * (h - t) / n
        p.box(t, 0, z, w - t, d - t, z + t, color)
        if k == n or rng is None:
            continue
        lx = t + 0.02
        while lx < w - 0.1:
            bw = float(rng.uniform(0.025, 0.06))
            bh = float(rng.uniform(0.15, 0.3))
            if rng.random() < 0.85:
                p.box(lx, 0.05, z + t, lx + bw, d - t - 0.02, z + t + bh, tuple(rng.uniform(0.1, 0.9, 3)))
            lx += bw + 0.005


def sofa(b: MeshBuilder, x, y, yaw=0, w=2.0, d=0.9, color=(0.5, 0.55, 0.35)) -> None:
    """Sofa with its back at local y = d and arms at both ends."""
    p = Placer(b, x, y, w, d, yaw)
    p.box(0, 0, 0.0, w, d, 0.42, color)
    p.box(0, d - 0.2, 0.42, w, d, 0.85, color)
    p.box(0, 0, 0.42, 0.18, d - 0.2, 0.62, color)
    p.box(w - 0.18, 0, 0.42, w, d - 0.2, 0.62, color)
    for k in range(3):
        c = tuple(np.clip(np.asarray(color) + 0.12, 0, 1))
        p.box(0.2 + k * (w - 0.4) / 3 + 0.02, 0.05, 0.42, 0.2 + (k + 1) * (w - 0.4) / 3 - 0.02, d - 0.22, 0.52, c)


def table(b: MeshBuilder, x, y, yaw=0, w=1.2, d=0.6, h=0.45, top=(0.3, 0.2, 0.12), leg=(0.2, 0.15, 0.1)) -> None:
    """Table (coffee or dining, by height) with thin legs."""
    p = Placer(b, x, y, w, d, yaw)
    p.box(0, 0, h - 0.04, w, d, h, top)
    _legs(p, w, d, h - 0.04, 0.05, leg)


def tv_unit(b: MeshBuilder, x, y, yaw=0, w=1.6, d=0.4) -> None:
    """Low cabinet with a thin TV on a stand; the wall side is local y = d."""
    p = Placer(b, x, y, w, d, yaw)
    p.box(0, 0, 0, w, d, 0.5, (0.9, 0.9, 0.88))
    p.box(0.4 * w, 0.15, 0.5, 0.6 * w, 0.3, 0.52, (0.1, 0.1, 0.1))
    p.box(0.48 * w, 0.2, 0.52, 0.52 * w, 0.24, 0.62, (0.1, 0.1, 0.1))
    p.box(0.1 * w, 0.18, 0.62, 0.9 * w, 0.22, 1.3, (0.03, 0.03, 0.03))
    p.box(0.12 * w, 0.175, 0.64, 0.88 * w, 0.18, 1.28, (0.2, 0.25, 0.35), 0.1)


def plant(b: MeshBuilder, x, y, size=0.4, pot=(0.7, 0.35, 0.2), leaves=(0.2, 0.55, 0.2)) -> None:
    """Potted plant: cylinder pot, thin stem, spherical foliage."""
    b.footprint(x - size / 2, y - size / 2, x + size / 2, y + size / 2)
    b.cylinder((x, y), 0.0, 0.35, 0.15 * size / 0.4, pot)
    b.cylinder((x, y), 0.35, 0.8, 0.012, (0.3, 0.25, 0.1), 8)
    b.sphere([x, y, 0.95], 0.22 * size / 0.4, leaves)


def floor_lamp(b: MeshBuilder, x, y, shade=(0.95, 0.9, 0.7)) -> None:
    """Floor lamp: round base, thin pole, shade (a thin object)."""
    b.footprint(x - 0.18, y - 0.18, x + 0.18, y + 0.18)
    b.cylinder((x, y), 0.0, 0.03, 0.15, (0.2, 0.2, 0.2))
    b.cylinder((x, y), 0.03, 1.5, 0.012, (0.25, 0.25, 0.25), 8)
    b.cylinder((x, y), 1.5, 1.75, 0.18, shade, 20)


def bed(b: MeshBuilder, x, y, yaw=0, w=1.6, d=2.0, color=(0.85, 0.85, 0.9)) -> None:
    """Bed: frame, mattress, pillows, headboard at local y = d."""
    p = Placer(b, x, y, w, d, yaw)
    p.box(0, 0, 0, w, d, 0.3, (0.4, 0.28, 0.18))
    p.box(0.03, 0.03, 0.3, w - 0.03, d - 0.05, 0.5, color)
    p.box(0, d - 0.05, 0, w, d, 1.0, (0.4, 0.28, 0.18))
    p.box(0.1, d - 0.5, 0.5, 0.45 * w, d - 0.1, 0.62, (0.95, 0.95, 0.95))
    p.box(0.55 * w, d - 0.5, 0.5, w - 0.1, d - 0.1, 0.62, (0.95, 0.95, 0.95))


def cabinet(b: MeshBuilder, x, y, yaw=0, w=1.0, d=0.6, h=0.9, color=(0.8, 0.8, 0.75), top=None) -> None:
    """Closed cabinet / counter / wardrobe with door handles on its front (local y = 0)."""
    p = Placer(b, x, y, w, d, yaw)
    p.box(0, 0, 0, w, d, h, color)
    if top is not None:
        p.box(-0.0, -0.02, h, w, d, h + 0.03, top)
    n = max(1, int(round(w / 0.5)))
    for k in range(n):
        hx = (k + 0.5) * w / n
        p.box(hx - 0.06, -0.02, h * 0.75, hx + 0.06, 0.0, h * 0.75 + 0.02, (0.6, 0.6, 0.6))


def wall_picture(b: MeshBuilder, x0, y0, x1, y1, z0, z1, color) -> None:
    """Picture on a wall: a dark frame (box x0..x1, y0..y1, z0..z1, m; its thin side is the
    depth) and a coloured canvas 4 mm proud of it on both faces."""
    b.box([x0, y0, z0], [x1, y1, z1], (0.15, 0.1, 0.05))
    thin_x = (x1 - x0) < (y1 - y0)
    m = 0.04
    if thin_x:
        b.box([x0 - 0.004, y0 + m, z0 + m], [x1 + 0.004, y1 - m, z1 - m], color, 0.1)
    else:
        b.box([x0 + m, y0 - 0.004, z0 + m], [x1 - m, y1 + 0.004, z1 - m], color, 0.1)
