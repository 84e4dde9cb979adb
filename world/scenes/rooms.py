"""The single-room built-in scenes: ``office``, ``living_room``, ``apartment`` (two rooms
joined by a doorway) and ``pretrain_room`` (for pretraining decoders only, never for
evaluation), and the room shell they and the house share. Each is closed (floor, ceiling,
walls as boxes with thickness); x and y span the floor, z points up, the floor is at z = 0,
units are metres. Each scene is declared once, at the end (``register_scene``).
"""
from __future__ import annotations

import numpy as np

from ramensim.world import furniture as fu
from ramensim.world.furniture import MeshBuilder
from ramensim.world.scenes.registry import SceneSpec, register_scene

WALL_T = 0.12  # wall thickness (m)
SLAB_T = 0.1   # floor / ceiling slab thickness (m)


# ----------------------------------------------------------------------------- room shell
class Room:
    """Helper to place furniture against the walls of the rectangle [x0, x1] x [y0, y1]."""

    def __init__(self, b: MeshBuilder, x0: float, y0: float, x1: float, y1: float) -> None:
        self.b, self.x0, self.y0, self.x1, self.y1 = b, x0, y0, x1, y1

    def at(self, wall: str, a: float, w: float, d: float, n: float = 0.0, facing_wall: bool = False):
        """World (x, y, yaw) of a w x d footprint whose back is against ``wall`` ('N', 'S',
        'E', 'W'), ``a`` metres along the wall and ``n`` metres out from it; with
        ``facing_wall`` the object faces the wall instead (its back to the room)."""
        if wall == "N":
            x, y, yaw = self.x0 + a, self.y1 - n - d, 0
        elif wall == "S":
            x, y, yaw = self.x0 + a, self.y0 + n, 2
        elif wall == "W":
            x, y, yaw = self.x0 + n, self.y0 + a, 1
        elif wall == "E":
            x, y, yaw = self.x1 - n - d, self.y0 + a, 3
        else:
            raise ValueError(f"wall {wall!r} is not one of N, S, E, W")
        return x, y, (yaw + 2) % 4 if facing_wall else yaw

    def picture(self, wall: str, a: float, w: float, z0: float, h: float, color) -> None:
        t = 0.03
        if wall == "N":
            fu.wall_picture(self.b, self.x0 + a, self.y1 - t, self.x0 + a + w, self.y1, z0, z0 + h, color)
        elif wall == "S":
            fu.wall_picture(self.b, self.x0 + a, self.y0, self.x0 + a + w, self.y0 + t, z0, z0 + h, color)
        elif wall == "W":
            fu.wall_picture(self.b, self.x0, self.y0 + a, self.x0 + t, self.y0 + a + w, z0, z0 + h, color)
        else:
            fu.wall_picture(self.b, self.x1 - t, self.y0 + a, self.x1, self.y0 + a + w, z0, z0 + h, color)

    def desk_with_chair(self, wall: str, a: float, rng: np.random.Generator, chair_color) -> None:
        w, d = 1.4, 0.7
        fu.desk(self.b, *self.at(wall, a, w, d)[:2], yaw=self.at(wall, a, w, d)[2], w=w, d=d,
                top=_jitter(rng, (0.55, 0.38, 0.22)), rng=rng)
        s = 0.45
        x, y, yaw = self.at(wall, a + 0.5 * (w - s), s, s, n=d + 0.12, facing_wall=True)
        fu.chair(self.b, x, y, yaw, color=chair_color, s=s)


def _jitter(rng: np.random.Generator, color, amount: float = 0.08):
    return tuple(np.clip(np.asarray(color, float) + rng.uniform(-amount, amount, 3), 0.0, 1.0))


def _shell(b: MeshBuilder, rng: np.random.Generator, lx: float, ly: float, h: float,
           wall_color, floor_colors, ceiling_color, inner_x: float | None = None,
           door: tuple[float, float] | None = None, door_h: float = 2.1,
           floor_colors_b=None) -> None:
    """Floor, ceiling and walls of the interior [0, lx] x [0, ly] x [0, h].

    Walls are boxes of thickness WALL_T from the slab bottoms (z = -SLAB_T) to the ceiling
    top (z = h + SLAB_T), so the shell is closed. With ``inner_x`` an interior wall at that x
    splits the space into two rooms joined by a doorway spanning y in ``door`` (height door_h).
    Floors and ceilings do not reach into walls, so a point inside a wall sees only wall faces.
    """
    t, z0, z1 = WALL_T, -SLAB_T, h + SLAB_T
    wc = wall_color
    b.box([-t, -t, z0], [lx + t, 0, z1], _jitter(rng, wc, 0.02))          # south
    b.box([-t, ly, z0], [lx + t, ly + t, z1], _jitter(rng, wc, 0.02))     # north
    b.box([-t, 0, z0], [0, ly, z1], _jitter(rng, wc, 0.02))               # west
    b.box([lx, 0, z0], [lx + t, ly, z1], _jitter(rng, wc, 0.02))          # east
    tile = 0.5
    if inner_x is None:
        b.tiled_floor(0, lx, 0, ly, 0.0, tile, floor_colors, SLAB_T)
        b.box([0, 0, h], [lx, ly, h + SLAB_T], ceiling_color, 0.01)
        return
    xa, xb = inner_x - t / 2, inner_x + t / 2
    d0, d1 = door
    b.box([xa, 0, z0], [xb, d0, z1], _jitter(rng, wc, 0.02))
    b.box([xa, d1, z0], [xb, ly, z1], _jitter(rng, wc, 0.02))
    b.box([xa, d0, door_h], [xb, d1, z1], _jitter(rng, wc, 0.02))         # lintel
    b.tiled_floor(0, xa, 0, ly, 0.0, tile, floor_colors, SLAB_T)
    b.tiled_floor(xb, lx, 0, ly, 0.0, tile, floor_colors_b or floor_colors, SLAB_T)
    b.box([xa, d0, z0], [xb, d1, 0.0], floor_colors[0], 0.0)               # threshold
    b.box([0, 0, h], [xa, ly, h + SLAB_T], ceiling_color, 0.01)
    b.box([xb, 0, h], [lx, ly, h + SLAB_T], ceiling_color, 0.01)


room_shell = _shell
"""Public name of the room shell for scenes of plugins (docs/EXTENDING.md)."""


def _ceiling_lights(b: MeshBuilder, xs, ys, h: float) -> None:
    for x in xs:
        for y in ys:
            b.box([x - 0.3, y - 0.3, h - 0.03], [x + 0.3, y + 0.3, h], (0.97, 0.97, 0.95), 0.0)


# ----------------------------------------------------------------------------- built-in scenes
def _office(rng: np.random.Generator) -> MeshBuilder:
    b = MeshBuilder(rng)
    lx, ly, h = rng.uniform(6.6, 7.4), rng.uniform(5.2, 5.8), rng.uniform(2.7, 2.9)
    _shell(b, rng, lx, ly, h, _jitter(rng, (0.88, 0.86, 0.8)),
           [_jitter(rng, (0.55, 0.55, 0.58), 0.04), _jitter(rng, (0.45, 0.47, 0.5), 0.04)], (0.95, 0.95, 0.95))
    r = Room(b, 0, 0, lx, ly)
    chair_c = _jitter(rng, (0.15, 0.25, 0.55))
    for k in range(3):
        r.desk_with_chair("N", 0.5 + k * (lx - 1.6) / 3 + rng.uniform(-0.1, 0.1), rng, chair_c)
    r.desk_with_chair("S", lx - 2.2 + rng.uniform(-0.2, 0.2), rng, chair_c)
    for k in range(2):
        x, y, yaw = r.at("W", 1.0 + k * 0.95, 0.9, 0.32)
        fu.bookshelf(b, x, y, yaw, color=_jitter(rng, (0.45, 0.3, 0.18)), rng=rng)
    x, y, yaw = r.at("E", 1.2, 1.8, 0.5)
    fu.cabinet(b, x, y, yaw, w=1.8, d=0.5, h=0.9, color=_jitter(rng, (0.75, 0.75, 0.72)), top=(0.3, 0.3, 0.32))
    # whiteboard on the east wall
    b.box([lx - 0.02, 1.2, 1.0], [lx, 3.0, 2.0], (0.98, 0.98, 0.98), 0.0)
    b.box([lx - 0.04, 1.6, 1.0], [lx, 2.6, 1.03], (0.3, 0.3, 0.3), 0.0)  # marker tray (thin)
    # meeting table with two chairs in the middle-south
    tx, ty = 0.5 * lx - 0.6 + rng.uniform(-0.3, 0.3), 1.2 + rng.uniform(-0.1, 0.1)
    fu.table(b, tx, ty, 0, w=1.2, d=0.8, h=0.74, top=_jitter(rng, (0.85, 0.85, 0.8)))
    fu.chair(b, tx + 0.35, ty + 0.8 + 0.12, 0, color=chair_c)
    fu.chair(b, tx + 0.35, ty - 0.12 - 0.45, 2, color=chair_c)
    fu.plant(b, 0.35, 0.35)
    fu.plant(b, lx - 0.35, ly - 1.2, size=0.5)
    fu.floor_lamp(b, 0.35, ly - 0.9)
    r.picture("S", 0.6, 1.0, 1.3, 0.7, _jitter(rng, (0.8, 0.4, 0.2), 0.2))
    r.picture("W", ly - 1.8, 0.9, 1.3, 0.6, _jitter(rng, (0.2, 0.5, 0.7), 0.2))
    _ceiling_lights(b, [lx / 3, 2 * lx / 3], [ly / 3, 2 * ly / 3], h)
    return b


def _living_room(rng: np.random.Generator) -> MeshBuilder:
    b = MeshBuilder(rng)
    lx, ly, h = rng.uniform(6.0, 7.0), rng.uniform(5.0, 5.8), rng.uniform(2.6, 2.8)
    _shell(b, rng, lx, ly, h, _jitter(rng, (0.93, 0.88, 0.78)),
           [_jitter(rng, (0.62, 0.45, 0.3), 0.04), _jitter(rng, (0.56, 0.4, 0.26), 0.04)], (0.96, 0.96, 0.94))
    r = Room(b, 0, 0, lx, ly)
    sw = 2.1
    sa = 0.5 * (lx - sw) - 0.8 + rng.uniform(-0.2, 0.2)
    x, y, yaw = r.at("S", sa, sw, 0.9, n=0.1)
    fu.sofa(b, x, y, yaw, w=sw, d=0.9, color=_jitter(rng, (0.45, 0.5, 0.35), 0.1))
    # rug (thin) and coffee table in front of the sofa
    b.box([sa - 0.2, 1.1, 0.0], [sa + sw + 0.2, 3.0, 0.012], _jitter(rng, (0.6, 0.2, 0.2), 0.1), 0.06)
    fu.table(b, sa + 0.45, 1.55, 0, w=1.2, d=0.6, h=0.42)
    x, y, yaw = r.at("N", sa + 0.25, 1.6, 0.4)
    fu.tv_unit(b, x, y, yaw)
    x, y, yaw = r.at("W", 2.0, 0.9, 0.32)
    fu.bookshelf(b, x, y, yaw, color=_jitter(rng, (0.9, 0.9, 0.88), 0.04), rng=rng)
    # armchair on the west side facing east
    x, y, yaw = r.at("W", 0.5, 0.9, 0.85, n=0.15)
    fu.sofa(b, x, y, yaw, w=0.9, d=0.85, color=_jitter(rng, (0.7, 0.55, 0.3), 0.1))
    # dining corner in the east
    dx, dy = lx - 1.9, ly - 2.4 + rng.uniform(-0.2, 0.2)
    fu.table(b, dx, dy, 1, w=1.2, d=0.8, h=0.75, top=_jitter(rng, (0.4, 0.26, 0.15)))
    cc = _jitter(rng, (0.3, 0.2, 0.12))
    fu.chair(b, dx - 0.12 - 0.45, dy + 0.37, 3, color=cc, s=0.45)
    fu.chair(b, dx + 0.8 + 0.12, dy + 0.37, 1, color=cc, s=0.45)
    x, y, yaw = r.at("E", 0.3, 1.2, 0.45)
    fu.cabinet(b, x, y, yaw, w=1.2, d=0.45, h=0.8, color=_jitter(rng, (0.5, 0.35, 0.2)))
    fu.plant(b, 0.35, ly - 0.35, size=0.5)
    fu.plant(b, lx - 0.35, 0.35)
    fu.floor_lamp(b, sa + sw + 0.35, 0.35)
    r.picture("S", sa + 0.3, 1.4, 1.2, 0.8, _jitter(rng, (0.3, 0.5, 0.8), 0.2))
    r.picture("E", ly - 1.5, 0.6, 1.4, 0.8, _jitter(rng, (0.9, 0.7, 0.2), 0.2))
    r.picture("W", ly - 1.6, 1.0, 1.3, 0.6, _jitter(rng, (0.2, 0.6, 0.3), 0.2))
    _ceiling_lights(b, [lx / 2], [ly / 2], h)
    return b


def _apartment(rng: np.random.Generator) -> MeshBuilder:
    b = MeshBuilder(rng)
    lx, ly, h = rng.uniform(7.6, 8.2), rng.uniform(4.8, 5.4), rng.uniform(2.6, 2.8)
    ix = 0.48 * lx + rng.uniform(-0.2, 0.2)
    door = (0.5 * ly - 0.45, 0.5 * ly + 0.45)
    _shell(b, rng, lx, ly, h, _jitter(rng, (0.9, 0.9, 0.85)),
           [_jitter(rng, (0.7, 0.6, 0.45), 0.04), _jitter(rng, (0.65, 0.55, 0.4), 0.04)], (0.96, 0.96, 0.96),
           inner_x=ix, door=door,
           floor_colors_b=[_jitter(rng, (0.8, 0.8, 0.8), 0.03), _jitter(rng, (0.3, 0.3, 0.32), 0.03)])
    xa, xb = ix - WALL_T / 2, ix + WALL_T / 2
    # bedroom (west)
    a = Room(b, 0, 0, xa, ly)
    x, y, yaw = a.at("W", 0.5 * ly - 0.8, 1.6, 2.0)
    fu.bed(b, x, y, yaw, color=_jitter(rng, (0.8, 0.82, 0.9), 0.1))
    x, y, yaw = a.at("N", 0.2, 1.2, 0.6)
    fu.cabinet(b, x, y, yaw, w=1.2, d=0.6, h=2.0, color=_jitter(rng, (0.85, 0.8, 0.7)))  # wardrobe
    a.desk_with_chair("S", 0.4, rng, _jitter(rng, (0.6, 0.2, 0.2)))
    fu.floor_lamp(b, 0.3, 0.5 * ly + 1.45)
    fu.plant(b, xa - 0.3, ly - 0.3)
    a.picture("W", 0.5 * ly - 0.5, 1.0, 1.3, 0.5, _jitter(rng, (0.5, 0.3, 0.7), 0.2))
    # kitchen / living (east)
    k = Room(b, xb, 0, lx, ly)
    kw = lx - xb
    x, y, yaw = k.at("N", 0.3, kw - 0.6, 0.6)
    fu.cabinet(b, x, y, yaw, w=kw - 0.6, d=0.6, h=0.9, color=_jitter(rng, (0.95, 0.95, 0.95), 0.03),
               top=(0.2, 0.2, 0.22))
    # wall cabinets above the counter (above head height)
    b.box([xb + 0.3, ly - 0.35, 1.55], [lx - 0.3, ly, 2.2], _jitter(rng, (0.95, 0.95, 0.95), 0.03))
    b.cylinder((xb + 0.8, ly - 0.3), 0.93, 1.15, 0.07, (0.7, 0.7, 0.75))  # kettle
    tx, ty = xb + 0.5 * kw - 0.6, 0.5 * ly - 0.4 + rng.uniform(-0.2, 0.2)
    fu.table(b, tx, ty, 0, w=1.2, d=0.8, h=0.75, top=_jitter(rng, (0.85, 0.75, 0.6)))
    cc = _jitter(rng, (0.2, 0.3, 0.25))
    fu.chair(b, tx + 0.15, ty + 0.8 + 0.12, 0, color=cc)
    fu.chair(b, tx + 0.6, ty + 0.8 + 0.12, 0, color=cc)
    fu.chair(b, tx + 0.35, ty - 0.12 - 0.45, 2, color=cc)
    x, y, yaw = k.at("S", 0.5 * kw - 0.9, 1.8, 0.85, n=0.05)
    fu.sofa(b, x, y, yaw, w=1.8, d=0.85, color=_jitter(rng, (0.25, 0.35, 0.6), 0.1))
    fu.plant(b, lx - 0.35, 0.35)
    k.picture("E", 0.5 * ly - 0.6, 1.2, 1.2, 0.8, _jitter(rng, (0.9, 0.5, 0.3), 0.2))
    _ceiling_lights(b, [0.5 * xa], [0.5 * ly], h)
    _ceiling_lights(b, [xb + 0.5 * kw], [0.5 * ly], h)
    return b


def _pretrain_room(rng: np.random.Generator) -> MeshBuilder:
    """A small room with random primitives (boxes, cylinders, spheres) of random colours:
    varied geometry and appearance for pretraining decoders, deliberately unlike the
    evaluation scenes."""
    b = MeshBuilder(rng, color_jitter=0.08)
    lx, ly, h = rng.uniform(4.0, 5.0), rng.uniform(3.5, 4.5), rng.uniform(2.5, 2.7)
    _shell(b, rng, lx, ly, h, tuple(rng.uniform(0.3, 0.95, 3)),
           [tuple(rng.uniform(0.2, 0.9, 3)), tuple(rng.uniform(0.2, 0.9, 3))], tuple(rng.uniform(0.7, 1.0, 3)))
    # objects hug the walls so the centre stays free for the camera
    for k in range(int(rng.integers(8, 13))):
        side = int(rng.integers(4))
        s = rng.uniform(0.15, 0.6, 3)
        along = rng.uniform(0.1, (lx if side < 2 else ly) - 0.8)
        off = rng.uniform(0.0, 0.4)
        if side == 0:
            x, y = along, off
        elif side == 1:
            x, y = along, ly - off - s[1]
        elif side == 2:
            x, y = off, along
        else:
            x, y = lx - off - s[0], along
        x, y = min(max(x, 0.0), lx - s[0]), min(max(y, 0.0), ly - s[1])
        c = tuple(rng.uniform(0.05, 0.95, 3))
        kind = int(rng.integers(3))
        z0 = 0.0 if rng.random() < 0.7 else float(rng.uniform(0.8, 1.6))
        if kind == 0:
            b.box([x, y, z0], [x + s[0], y + s[1], z0 + s[2] * 2], c)
        elif kind == 1:
            r = 0.5 * min(s[0], s[1])
            b.cylinder((x + r, y + r), z0, z0 + 2 * s[2], r, c)
        else:
            r = 0.5 * min(s[0], s[1])
            b.sphere([x + r, y + r, z0 + r], r, c)
        if z0 == 0.0:
            b.footprint(x, y, x + s[0], y + s[1])
    return b


register_scene(SceneSpec("office", _office, "one office room with desks, chairs and shelves"))
register_scene(SceneSpec("living_room", _living_room, "one living room"))
register_scene(SceneSpec("apartment", _apartment, "two rooms joined by a doorway"))
register_scene(SceneSpec("pretrain_room", _pretrain_room, "random primitives for pretraining decoders (not for evaluation)",
                         evaluation=False))
