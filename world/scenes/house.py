"""The built-in ``house``: six rooms in a 2 x 3 grid joined in a chain by one doorway each
(:func:`house_layout`), each furnished after its kind. Metres, z up, floor at z = 0.
Declared once, at the end (``register_scene``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ramensim.world import furniture as fu
from ramensim.world.furniture import MeshBuilder
from ramensim.world.scenes.registry import SceneSpec, _scene_rng, register_scene
from ramensim.world.scenes.rooms import SLAB_T, WALL_T, Room, _ceiling_lights, _jitter


# ----------------------------------------------------------------------------- the house
HOUSE_DOOR_W = 0.9   # doorway width (m)
HOUSE_DOOR_H = 2.1   # doorway height (m)
HOUSE_AISLE = 0.65   # free floor kept in front of every piece of furniture (m), so rooms stay walkable
HOUSE_KINDS = ("bedroom", "office", "kitchen", "living", "dining", "study")
# serpentine chain of the 2 x 3 grid: row 0 left -> right, then row 1 right -> left
HOUSE_CHAIN = ((0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (1, 0))


@dataclass(frozen=True)
class HouseRoom:
    """One room of the house: ``chain`` = its place in the serpentine chain (0..5), ``row``
    and ``col`` in the 2 x 3 grid, ``kind`` of furnishing and ``interior`` (x0, y0, x1, y1)
    = its free floor rectangle inside the walls (m)."""

    chain: int
    row: int
    col: int
    kind: str
    interior: tuple[float, float, float, float]

    @property
    def centre(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.interior
        return 0.5 * (x0 + x1), 0.5 * (y0 + y1)


@dataclass(frozen=True)
class HouseDoor:
    """A doorway between chain rooms ``rooms`` = (k, k + 1) through the wall ``axis`` = 'x'
    (a wall at constant x, between two columns) or 'y' (at constant y, between the rows) that
    spans ``wall`` = (lo, hi) across its thickness; the opening spans ``span`` = (lo, hi) along
    the wall (m), from the floor to HOUSE_DOOR_H."""

    rooms: tuple[int, int]
    axis: str
    wall: tuple[float, float]
    span: tuple[float, float]

    @property
    def centre(self) -> tuple[float, float]:
        c_wall, c_span = 0.5 * sum(self.wall), 0.5 * sum(self.span)
        return (c_wall, c_span) if self.axis == "x" else (c_span, c_wall)


@dataclass(frozen=True)
class HouseLayout:
    """Rooms (in chain order), doors (door k joins rooms k and k + 1), the interior size
    ``size`` = (lx, ly) inside the outer walls and the ceiling ``height`` (m)."""

    rooms: tuple[HouseRoom, ...]
    doors: tuple[HouseDoor, ...]
    size: tuple[float, float]
    height: float


def house_layout(seed: int = 0) -> HouseLayout:
    """The room and door layout of built-in scene ``house`` with ``seed`` (as built)."""
    return _house_layout(_scene_rng("house", seed))


def _house_layout(rng: np.random.Generator) -> HouseLayout:
    t = WALL_T
    widths = rng.uniform(3.5, 4.4, 3)   # interior sizes of the columns (x) and rows (y)
    depths = rng.uniform(3.5, 4.4, 2)
    h = float(rng.uniform(2.65, 2.8))
    xs = np.concatenate([[0.0], np.cumsum(widths + t)])  # column c: [xs[c], xs[c] + widths[c]]
    ys = np.concatenate([[0.0], np.cumsum(depths + t)])
    kinds = [HOUSE_KINDS[k] for k in rng.permutation(len(HOUSE_KINDS))]
    rooms = tuple(HouseRoom(k, r, c, kinds[k], (float(xs[c]), float(ys[r]), float(xs[c] + widths[c]),
                                                float(ys[r] + depths[r])))
                  for k, (r, c) in enumerate(HOUSE_CHAIN))
    doors = []
    half = 0.5 * HOUSE_DOOR_W
    # Doorways sit near a corner of their wall (0.3 to 0.6 m from it), as in most houses, so a
    # room is seen through a doorway mostly at a slant; which end of its wall each one takes
    # (0 = the lower coordinate) staggers a room's two doorways (middle rooms) or keeps them
    # away from the corner between them (corner rooms), so few lines pass through two doorways.
    ends = (1, 0, 1, 1, 0)
    for k in range(len(rooms) - 1):
        a, b = rooms[k], rooms[k + 1]
        if a.row == b.row:  # a wall at constant x between two columns
            c = min(a.col, b.col)
            wall = (float(xs[c] + widths[c]), float(xs[c + 1]))
            lo, hi = a.interior[1], a.interior[3]
            axis = "x"
        else:  # a wall at constant y between the rows
            wall = (float(ys[0] + depths[0]), float(ys[1]))
            lo, hi = a.interior[0], a.interior[2]
            axis = "y"
        gap = float(rng.uniform(0.3, 0.6))
        m = hi - gap - half if ends[k] else lo + gap + half
        doors.append(HouseDoor((k, k + 1), axis, wall, (m - half, m + half)))
    return HouseLayout(rooms, tuple(doors), (float(xs[-1] - t), float(ys[-1] - t)), h)


_HOUSE_PALETTE = {  # kind: (wall colour, two floor colours)
    "bedroom": ((0.82, 0.77, 0.9), [(0.76, 0.68, 0.58), (0.71, 0.63, 0.53)]),   # lilac, beige carpet
    "office": ((0.78, 0.83, 0.88), [(0.5, 0.5, 0.54), (0.43, 0.44, 0.48)]),    # grey-blue, grey
    "kitchen": ((0.95, 0.92, 0.68), [(0.9, 0.9, 0.88), (0.25, 0.25, 0.28)]),   # yellow, checker
    "living": ((0.94, 0.8, 0.68), [(0.6, 0.42, 0.26), (0.53, 0.36, 0.21)]),     # peach, oak
    "dining": ((0.72, 0.85, 0.7), [(0.73, 0.42, 0.3), (0.65, 0.37, 0.26)]),    # sage, terracotta
    "study": ((0.66, 0.8, 0.84), [(0.38, 0.27, 0.18), (0.33, 0.23, 0.15)]),    # teal, walnut
}


def _wall_run(b: MeshBuilder, normal: int, across: tuple[float, float], along: tuple[float, float],
              doors: list[tuple[float, float]], z1: float, colors: tuple, floors: tuple) -> None:
    """A straight wall from the slab bottoms to the ceiling top (z1), its thickness ``across``
    along axis ``normal`` (0 = a wall at constant x, 1 = at constant y) and its length
    ``along`` the other axis, cut by doorways ``doors`` (spans along it, HOUSE_DOOR_H high,
    with a lintel above and a threshold below floor level). ``colors`` = (side at the lower
    coordinate, side at the higher), likewise ``floors`` for the thresholds."""
    def box(a0: float, a1: float, za: float, zb: float, cols) -> None:
        lo, hi = [0.0, 0.0, za], [0.0, 0.0, zb]
        lo[normal], hi[normal] = across
        lo[1 - normal], hi[1 - normal] = a0, a1
        b.two_tone_box(lo, hi, normal, cols[0], cols[1], 0.02)

    a = along[0]
    for d0, d1 in sorted(doors):
        box(a, d0, -SLAB_T, z1, colors)
        box(d0, d1, HOUSE_DOOR_H, z1, colors)   # lintel
        box(d0, d1, -SLAB_T, 0.0, floors)       # threshold
        a = d1
    box(a, along[1], -SLAB_T, z1, colors)


def _house_shell(b: MeshBuilder, lay: HouseLayout, walls: list, floors: list) -> None:
    """Floors, ceilings and walls of the house: an outer wall of thickness WALL_T around
    [0, lx] x [0, ly], interior walls of that thickness between the rooms with the doorways of
    ``lay``; each side of a wall has the colour of the room it faces (``walls[k]`` for chain
    room k, ``floors[k]`` its two floor colours). Walls reach from the slab bottoms to the
    ceiling tops and floors/ceilings stop at the walls, so the shell is closed and no visible
    surface hides another a few centimetres behind it."""
    t, h = WALL_T, lay.height
    z1 = h + SLAB_T
    lx, ly = lay.size
    grid = {(r.row, r.col): r for r in lay.rooms}
    xs = sorted({r.interior[0] for r in lay.rooms})
    ys = sorted({r.interior[1] for r in lay.rooms})
    xe = sorted({r.interior[2] for r in lay.rooms})
    ye = sorted({r.interior[3] for r in lay.rooms})
    grey = (0.5, 0.5, 0.5)

    def doors_between(k0: int, k1: int) -> list[tuple[float, float]]:
        return [d.span for d in lay.doors if set(d.rooms) == {k0, k1}]

    for r in lay.rooms:  # outer walls, one run per room side on the outside of the house
        x0, y0, x1, y1 = r.interior
        c, k = walls[r.chain], r.chain
        if r.row == 0:
            _wall_run(b, 1, (-t, 0.0), (x0, x1), [], z1, (c, c), (floors[k][0],) * 2)
        if r.row == len(ys) - 1:
            _wall_run(b, 1, (ly, ly + t), (x0, x1), [], z1, (c, c), (floors[k][0],) * 2)
        if r.col == 0:
            _wall_run(b, 0, (-t, 0.0), (y0, y1), [], z1, (c, c), (floors[k][0],) * 2)
        if r.col == len(xs) - 1:
            _wall_run(b, 0, (lx, lx + t), (y0, y1), [], z1, (c, c), (floors[k][0],) * 2)
    for i in range(len(xs) - 1):  # interior walls at constant x, one run per row
        for j in range(len(ys)):
            lo, hi = grid[(j, i)], grid[(j, i + 1)]
            _wall_run(b, 0, (xe[i], xs[i + 1]), (ys[j], ye[j]), doors_between(lo.chain, hi.chain), z1,
                      (walls[lo.chain], walls[hi.chain]), (floors[lo.chain][0], floors[hi.chain][0]))
    for j in range(len(ys) - 1):  # interior walls at constant y, one run per column
        for i in range(len(xs)):
            lo, hi = grid[(j, i)], grid[(j + 1, i)]
            _wall_run(b, 1, (ye[j], ys[j + 1]), (xs[i], xe[i]), doors_between(lo.chain, hi.chain), z1,
                      (walls[lo.chain], walls[hi.chain]), (floors[lo.chain][0], floors[hi.chain][0]))
    # wall junctions and corners: the squares where the runs meet
    cx = [-t] + [xe[i] for i in range(len(xs) - 1)] + [lx]
    cy = [-t] + [ye[j] for j in range(len(ys) - 1)] + [ly]
    for x in cx:
        for y in cy:
            b.box([x, y, -SLAB_T], [x + t, y + t, z1], grey, 0.0)
    for r in lay.rooms:
        x0, y0, x1, y1 = r.interior
        b.tiled_floor(x0, x1, y0, y1, 0.0, 0.5, floors[r.chain], SLAB_T)
        b.box([x0, y0, h], [x1, y1, z1], (0.96, 0.96, 0.95), 0.01)


class _Furnisher:
    """Places furniture in one room so that the room stays walkable: every piece keeps an
    aisle of HOUSE_AISLE free in front of it and the doorways keep a free zone; pieces never
    overlap each other, an aisle or a doorway zone (aisles may overlap each other). ``spot``
    finds a place along a wall, ``fits`` tests and claims a footprint and its aisle."""

    def __init__(self, b: MeshBuilder, rng: np.random.Generator, lay: HouseLayout, room: HouseRoom) -> None:
        self.b, self.rng, self.room = b, rng, room
        x0, y0, x1, y1 = room.interior
        self.r = Room(b, x0, y0, x1, y1)
        self.solid: list[tuple[float, float, float, float]] = []
        self.keep: list[tuple[float, float, float, float]] = []
        self.door_walls: dict[str, list[tuple[float, float]]] = {"S": [], "N": [], "W": [], "E": []}
        self.tall: dict[str, list[tuple[float, float]]] = {"S": [], "N": [], "W": [], "E": []}
        for d in lay.doors:
            if room.chain not in d.rooms:
                continue
            s0, s1 = d.span[0] - 0.15, d.span[1] + 0.15
            if d.axis == "x":
                east = d.wall[0] >= x1 - 1e-9
                self.keep.append((x1 - 0.9, s0, x1, s1) if east else (x0, s0, x0 + 0.9, s1))
                self.door_walls["E" if east else "W"].append((d.span[0] - y0, d.span[1] - y0))
            else:
                north = d.wall[0] >= y1 - 1e-9
                self.keep.append((s0, y1 - 0.9, s1, y1) if north else (s0, y0, s1, y0 + 0.9))
                self.door_walls["N" if north else "S"].append((d.span[0] - x0, d.span[1] - x0))

    def length(self, wall: str) -> float:
        x0, y0, x1, y1 = self.room.interior
        return (x1 - x0) if wall in "NS" else (y1 - y0)

    def _inside(self, rect) -> bool:
        x0, y0, x1, y1 = self.room.interior
        return rect[0] >= x0 - 1e-9 and rect[1] >= y0 - 1e-9 and rect[2] <= x1 + 1e-9 and rect[3] <= y1 + 1e-9

    @staticmethod
    def _hits(rect, others) -> bool:
        a0, b0, a1, b1 = rect
        return any(a0 < c1 - 1e-9 and c0 < a1 - 1e-9 and b0 < d1 - 1e-9 and d0 < b1 - 1e-9
                   for c0, d0, c1, d1 in others)

    def fits(self, solid, aisle=None, claim: bool = True) -> bool:
        """Whether footprint ``solid`` (x0, y0, x1, y1) fits inside the room clear of other
        pieces, aisles and doorway zones, with its ``aisle`` (a rectangle, inside the room)
        clear of other pieces; claims both when ``claim``."""
        if not self._inside(solid) or self._hits(solid, self.solid + self.keep):
            return False
        if aisle is not None and (not self._inside(aisle) or self._hits(aisle, self.solid)):
            return False
        if claim:
            self.solid.append(tuple(solid))
            if aisle is not None:
                self.keep.append(tuple(aisle))
        return True

    def _rect(self, wall: str, x: float, y: float, w: float, d: float, front: float):
        if wall in "NS":
            r = [x, y, x + w, y + d]
        else:
            r = [x, y, x + d, y + w]
        k = {"N": 1, "S": 3, "W": 2, "E": 0}[wall]  # which coordinate grows into the room
        r[k] += front if k >= 2 else -front
        return tuple(r)

    def spot(self, walls: str, w: float, d: float, n: float = 0.0, front: float = 0.0,
             tall: bool = False):
        """A free place for a w x d footprint (plus ``front`` metres in front of it for what
        goes with it, e.g. a chair, and an aisle of HOUSE_AISLE) with its back against one of
        ``walls`` (tried in a random order): (wall, a, x, y, yaw) with ``a`` metres along the
        wall, or None when nothing fits."""
        order = list(walls)
        self.rng.shuffle(order)
        for wall in order:
            L = self.length(wall)
            if L - w < 0.1:
                continue
            cand = np.arange(0.05, L - w - 0.05 + 1e-9, 0.05)
            pref = float(self.rng.uniform(0.05, L - w - 0.05))
            for a in cand[np.argsort(np.abs(cand - pref), kind="stable")]:
                x, y, yaw = self.r.at(wall, float(a), w, d, n)
                if self.fits(self._rect(wall, x, y, w, d, front), self._rect(wall, x, y, w, d, front + HOUSE_AISLE)):
                    if tall:
                        self.tall[wall].append((float(a), float(a) + w))
                    return wall, float(a), x, y, yaw
        return None

    def picture(self, color, w: float = 0.9, z0: float = 1.3, hgt: float = 0.6) -> None:
        """A picture on a wall, clear of doorways and tall furniture."""
        order = list("NSEW")
        self.rng.shuffle(order)
        for wall in order:
            L = self.length(wall)
            if L - w < 0.6:
                continue
            a = float(self.rng.uniform(0.3, L - w - 0.3))
            blocked = self.door_walls[wall] + self.tall[wall]
            if all(a + w < s0 - 0.1 or a > s1 + 0.1 for s0, s1 in blocked):
                self.tall[wall].append((a, a + w))
                self.r.picture(wall, a, w, z0, hgt, color)
                return

    def centre_rect(self, w: float, d: float, mx: float, my: float, jitter: float = 0.6):
        """Lower-left corner of a w x d rectangle near the room centre that fits with ``mx`` m
        on its x sides and ``my`` on its y sides (chairs) and an aisle all round, or None."""
        cx, cy = self.room.centre
        A = HOUSE_AISLE
        for k in range(40):
            j = jitter * (k + 1) / 40
            x = cx - w / 2 + float(self.rng.uniform(-j, j))
            y = cy - d / 2 + float(self.rng.uniform(-j, j))
            solid = (x - mx, y - my, x + w + mx, y + d + my)
            if self.fits(solid, (solid[0] - A, solid[1] - A, solid[2] + A, solid[3] + A)):
                return x, y
        return None

    def corner_item(self, size: float):
        """Centre of a free size x size square in a room corner, or None."""
        x0, y0, x1, y1 = self.room.interior
        corners = [(x0 + 0.05, y0 + 0.05), (x1 - 0.05 - size, y0 + 0.05), (x0 + 0.05, y1 - 0.05 - size),
                   (x1 - 0.05 - size, y1 - 0.05 - size)]
        for k in self.rng.permutation(4):
            x, y = corners[k]
            if self.fits((x, y, x + size, y + size)):
                return x + size / 2, y + size / 2
        return None


def _dining_set(f: _Furnisher, w: float, d: float, top, chair_color, per_side: int) -> None:
    s = 0.45
    at = None
    while at is None and w > 0.7:
        at = f.centre_rect(w, d, 0.1, 0.12 + s)
        if at is None:
            w -= 0.4
    if at is None:
        return
    tx, ty = at
    fu.table(f.b, tx, ty, 0, w=w, d=d, h=0.75, top=top)
    for k in range(per_side):
        cx = tx + (k + 0.5) * w / per_side - s / 2
        fu.chair(f.b, cx, ty + d + 0.12, 0, color=chair_color, s=s)
        fu.chair(f.b, cx, ty - 0.12 - s, 2, color=chair_color, s=s)


def _furnish_bedroom(f: _Furnisher, rng: np.random.Generator) -> None:
    b = f.b
    p = f.spot("NSEW", 1.6, 2.0)
    if p:
        fu.bed(b, *p[2:], color=_jitter(rng, (0.8, 0.82, 0.92), 0.12))
        wall, a = p[0], p[1]
        q = f.r.at(wall, a + 1.65, 0.45, 0.4)  # nightstand beside the headboard
        if f.fits(f._rect(wall, q[0], q[1], 0.45, 0.4, 0.0), f._rect(wall, q[0], q[1], 0.45, 0.4, HOUSE_AISLE)):
            fu.cabinet(b, *q, w=0.45, d=0.4, h=0.55, color=_jitter(rng, (0.45, 0.3, 0.2)))
    p = f.spot("NSEW", 1.2, 0.6, tall=True)
    if p:
        fu.cabinet(b, *p[2:], w=1.2, d=0.6, h=2.0, color=_jitter(rng, (0.88, 0.84, 0.74)))  # wardrobe
    p = f.spot("NSEW", 1.0, 0.45)
    if p:
        fu.cabinet(b, *p[2:], w=1.0, d=0.45, h=0.8, color=_jitter(rng, (0.9, 0.9, 0.9)),
                   top=_jitter(rng, (0.5, 0.35, 0.25)))  # dresser
    c = f.corner_item(0.4)
    if c:
        fu.floor_lamp(b, *c, shade=_jitter(rng, (0.95, 0.85, 0.75)))
    cx, cy = f.room.centre
    b.box([cx - 0.8, cy - 0.6, 0.0], [cx + 0.8, cy + 0.6, 0.012], _jitter(rng, (0.55, 0.3, 0.5), 0.1), 0.06)
    f.picture(_jitter(rng, (0.6, 0.4, 0.8), 0.2), w=1.0)


def _furnish_office(f: _Furnisher, rng: np.random.Generator) -> None:
    b = f.b
    chair_c = _jitter(rng, (0.15, 0.25, 0.55))
    for _ in range(2):
        p = f.spot("NSEW", 1.4, 0.7, front=0.6)
        if p:
            f.r.desk_with_chair(p[0], p[1], rng, chair_c)
    p = f.spot("NSEW", 0.9, 0.32, tall=True)
    if p:
        fu.bookshelf(b, *p[2:], color=_jitter(rng, (0.85, 0.85, 0.82)), rng=rng)
    p = f.spot("NSEW", 1.2, 0.5)
    if p:
        fu.cabinet(b, *p[2:], w=1.2, d=0.5, h=1.1, color=_jitter(rng, (0.6, 0.62, 0.66)), top=(0.3, 0.3, 0.32))
    c = f.corner_item(0.5)
    if c:
        fu.plant(b, *c, size=0.5)
    # whiteboard: a wide white picture
    f.picture((0.98, 0.98, 0.98), w=1.4, z0=1.0, hgt=0.9)


def _furnish_kitchen(f: _Furnisher, rng: np.random.Generator) -> None:
    b = f.b
    for w in (min(2.8, f.length("N") - 0.4), 2.2, 1.6, 1.2):
        p = f.spot("NSEW", w, 0.6, tall=True)
        if p:
            wall, a, x, y, yaw = p
            fu.cabinet(b, x, y, yaw, w=w, d=0.6, h=0.9, color=_jitter(rng, (0.95, 0.95, 0.95), 0.03),
                       top=_jitter(rng, (0.2, 0.2, 0.22), 0.03))
            # wall cabinets above the counter (above head height)
            q = f.r.at(wall, a, w, 0.35)
            r = f._rect(wall, q[0], q[1], w, 0.35, 0.0)
            b.box([r[0], r[1], 1.55], [r[2], r[3], 2.2], _jitter(rng, (0.75, 0.55, 0.35), 0.05))
            k = f.r.at(wall, a + 0.4, 0.14, 0.14, n=0.2)
            b.cylinder((k[0] + 0.07, k[1] + 0.07), 0.93, 1.15, 0.07, (0.7, 0.7, 0.75))  # kettle
            break
    p = f.spot("NSEW", 0.7, 0.65, tall=True)
    if p:
        fu.cabinet(b, *p[2:], w=0.7, d=0.65, h=1.85, color=_jitter(rng, (0.8, 0.82, 0.85), 0.03))  # fridge
    _dining_set(f, 1.0, 0.7, _jitter(rng, (0.85, 0.75, 0.6)), _jitter(rng, (0.8, 0.3, 0.2)), 1)
    c = f.corner_item(0.4)
    if c:
        fu.plant(b, *c, size=0.4)
    f.picture(_jitter(rng, (0.9, 0.5, 0.2), 0.2), w=0.7, z0=1.4, hgt=0.5)


def _furnish_living(f: _Furnisher, rng: np.random.Generator) -> None:
    b = f.b
    sw, p = 2.0, None
    while p is None and sw > 1.1:
        p = f.spot("NSEW", sw, 0.9, front=0.9)
        sw -= 0.4
    if p:
        sw += 0.4
        wall, a, x, y, yaw = p
        fu.sofa(b, x, y, yaw, w=sw, d=0.9, color=_jitter(rng, (0.3, 0.45, 0.6), 0.1))
        # coffee table and rug in front of the sofa (inside the space claimed in front of it)
        q = f.r.at(wall, a + 0.5 * sw - 0.5, 1.0, 0.55, n=1.25)
        fu.table(b, *q, w=1.0, d=0.55, h=0.42, top=_jitter(rng, (0.3, 0.2, 0.12)))
        r = f._rect(wall, *f.r.at(wall, a - 0.1, sw + 0.2, 1.5, n=0.95)[:2], sw + 0.2, 1.5, 0.0)
        b.box([r[0], r[1], 0.0], [r[2], r[3], 0.012], _jitter(rng, (0.65, 0.2, 0.2), 0.1), 0.06)
        opposite = {"N": "S", "S": "N", "E": "W", "W": "E"}[wall]
        t = f.spot(opposite, 1.6, 0.4)
        if t:
            fu.tv_unit(b, *t[2:])
    p = f.spot("NSEW", 0.9, 0.85)
    if p:
        fu.sofa(b, *p[2:], w=0.9, d=0.85, color=_jitter(rng, (0.75, 0.55, 0.3), 0.1))  # armchair
    p = f.spot("NSEW", 0.9, 0.32, tall=True)
    if p:
        fu.bookshelf(b, *p[2:], color=_jitter(rng, (0.45, 0.3, 0.18)), rng=rng)
    for size in (0.5, 0.4):
        c = f.corner_item(size)
        if c:
            (fu.plant(b, *c, size=size) if size == 0.5 else fu.floor_lamp(b, *c))
    f.picture(_jitter(rng, (0.2, 0.5, 0.8), 0.2), w=1.2, z0=1.3, hgt=0.7)


def _furnish_dining(f: _Furnisher, rng: np.random.Generator) -> None:
    b = f.b
    _dining_set(f, 1.6, 0.9, _jitter(rng, (0.4, 0.26, 0.15)), _jitter(rng, (0.3, 0.2, 0.12)), 2)
    p = f.spot("NSEW", 1.6, 0.45)
    if p:
        fu.cabinet(b, *p[2:], w=1.6, d=0.45, h=0.85, color=_jitter(rng, (0.5, 0.33, 0.2)),
                   top=_jitter(rng, (0.3, 0.2, 0.12)))  # sideboard
    p = f.spot("NSEW", 1.0, 0.45, tall=True)
    if p:
        fu.cabinet(b, *p[2:], w=1.0, d=0.45, h=1.8, color=_jitter(rng, (0.92, 0.9, 0.85)))  # china cabinet
    for _ in range(2):
        c = f.corner_item(0.45)
        if c:
            fu.plant(b, *c, size=0.45, leaves=_jitter(rng, (0.2, 0.55, 0.2), 0.1))
    f.picture(_jitter(rng, (0.8, 0.7, 0.2), 0.2), w=1.0, z0=1.3, hgt=0.7)
    f.picture(_jitter(rng, (0.3, 0.6, 0.3), 0.2), w=0.7, z0=1.4, hgt=0.5)


def _furnish_study(f: _Furnisher, rng: np.random.Generator) -> None:
    b = f.b
    shelf_c = _jitter(rng, (0.35, 0.22, 0.12))
    p = f.spot("NSEW", 2.7, 0.32, tall=True)  # a wall of bookshelves
    if p:
        wall, a = p[0], p[1]
        for k in range(3):
            fu.bookshelf(b, *f.r.at(wall, a + 0.9 * k, 0.9, 0.32), color=shelf_c, rng=rng)
    p = f.spot("NSEW", 1.4, 0.7, front=0.6)
    if p:
        f.r.desk_with_chair(p[0], p[1], rng, _jitter(rng, (0.5, 0.15, 0.15)))
    p = f.spot("NSEW", 0.9, 0.85)
    if p:
        fu.sofa(b, *p[2:], w=0.9, d=0.85, color=_jitter(rng, (0.25, 0.4, 0.25), 0.1))  # reading chair
    c = f.corner_item(0.4)
    if c:
        fu.floor_lamp(b, *c, shade=_jitter(rng, (0.9, 0.9, 0.7)))
    at = f.centre_rect(0.6, 0.6, 0.0, 0.0)
    if at:
        fu.table(b, at[0], at[1], 0, w=0.6, d=0.6, h=0.5, top=_jitter(rng, (0.6, 0.5, 0.35)))
    f.picture(_jitter(rng, (0.7, 0.3, 0.3), 0.2), w=0.8, z0=1.4, hgt=0.6)


_FURNISH = {"bedroom": _furnish_bedroom, "office": _furnish_office, "kitchen": _furnish_kitchen,
            "living": _furnish_living, "dining": _furnish_dining, "study": _furnish_study}


def _house(rng: np.random.Generator) -> MeshBuilder:
    """Six rooms in a 2 x 3 grid (see :func:`house_layout`), joined in a serpentine chain by
    one doorway each; every room has its own colours, furniture and ceiling light."""
    lay = _house_layout(rng)
    b = MeshBuilder(rng)
    walls = [_jitter(rng, _HOUSE_PALETTE[r.kind][0], 0.04) for r in lay.rooms]
    floors = [[_jitter(rng, c, 0.03) for c in _HOUSE_PALETTE[r.kind][1]] for r in lay.rooms]
    _house_shell(b, lay, walls, floors)
    for room in lay.rooms:
        _FURNISH[room.kind](_Furnisher(b, rng, lay, room), rng)
        cx, cy = room.centre
        _ceiling_lights(b, [cx], [cy], lay.height)
    return b


register_scene(SceneSpec("house", _house, "six rooms in a 2 x 3 grid joined in a chain by one doorway each"))
