"""The built-in ``warehouse``: a seeded aisle grid in a closed hall, a scene family of another
kind than the house (:mod:`.house`). Metres, z up, floor at z = 0. Declared once, at the end
(``register_scene``).

The hall's interior is [0, lx] x [0, ly] x [0, height] (:func:`warehouse_layout`), about the
house's size (9.4-10.3 m by 8-10.5 m, 3.0-3.3 m high). Shelving racks run along x: a single
rack against each long wall (y = 0 and y = ly) and 2 or 3 double racks (back to back, a panel
between the halves) between them, with a long aisle between neighbouring racks (3 or 4
aisles). Along the west end wall (x = 0) lies a staging area with a dock door and loaded
pallets on the floor; most seeds have a back cross-aisle along the east end wall (the others
dead-end aisles) and a middle cross-aisle that cuts the double racks in two (the wall racks
run on). Every rack has decks at the same heights, bays between its uprights
and goods (cartons, plastic crates, a few drums) of seeded sizes and colours on every deck.

What the seed changes: the number of aisles and their widths, the racks' depth, bay width,
number of decks and deck spacing, the hall's length (and so its size) and height, the widths
of the staging area and the cross-aisles, whether there is a back and a middle cross-aisle,
where the middle one is, the dock door's place, the pallets, the goods on every deck and
every colour. Every random draw comes from the generator given to the builder, so the same
seed gives the same mesh.

The hall is one open space, so the walls do not cut it into rooms for the tour of split
'chunks' (:mod:`ramensim.world.trajectories.tour`) as they cut the house: the mesh declares
the long aisles as those rooms (``mesh.metadata[TOUR_ROOMS]``; every other walkable cell
joins the aisle nearest to it), so the tour walks the aisles one after the other, each from
end to end, and the robots' chunks are cut where the tour leaves an aisle.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from ramensim.world.furniture import MeshBuilder
from ramensim.world.scenes.registry import SceneSpec, _scene_rng, register_scene
from ramensim.world.scenes.rooms import SLAB_T, WALL_T, _jitter
from ramensim.world.trajectories.tour import TOUR_ROOMS

WAREHOUSE_AISLE_W = {3: (1.4, 1.8), 4: (1.3, 1.5)}   # width of a long aisle, by the number of aisles (m)
WAREHOUSE_RACK_D = {3: (0.5, 0.65), 4: (0.45, 0.55)}  # depth of a single rack, by the number of aisles (m)
WAREHOUSE_CROSS_W = (1.25, 1.5)      # width of the middle cross-aisle (m)
WAREHOUSE_LENGTH = (9.4, 10.3)       # the hall's length lx (m): sight lines stay within a 10 m depth range
WAREHOUSE_MIN_SEGMENT = 2.4          # shortest run of a double rack beside the middle cross-aisle (m)
PALLET = (0.8, 1.2, 0.14)            # a pallet's size along x, along y, and height (m)
_POST = 0.08                         # rack uprights: square posts of this side (m)
_BEAM_H = 0.1                        # height of a deck's front beam (m)
_DECK_T = 0.03                       # thickness of a deck (m)


@dataclass(frozen=True)
class WarehouseRack:
    """One straight run of shelving: footprint ``rect`` (x0, y0, x1, y1) m, ``faces`` = the
    sides that face an aisle and hold goods ('N' = towards +y, 'S' = towards -y, 'NS' for a
    double rack) and ``bays``, the number of bays between its uprights along x."""

    rect: tuple[float, float, float, float]
    faces: str
    bays: int


@dataclass(frozen=True)
class WarehouseAisle:
    """A strip of free floor ``rect`` (x0, y0, x1, y1) m: ``axis`` 'x' for a long aisle between
    two racks (it runs along x), 'y' for the staging area or a cross-aisle (they run along y,
    across the hall)."""

    rect: tuple[float, float, float, float]
    axis: str

    @property
    def centre(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.rect
        return 0.5 * (x0 + x1), 0.5 * (y0 + y1)


@dataclass(frozen=True)
class WarehouseLayout:
    """The hall's interior ``size`` = (lx, ly) and ceiling ``height`` (m); ``decks``: the heights
    of the racks' decks (m, lowest first); ``racks``; ``aisles``: the long aisles (by y) and
    ``cross``: the aisles across them, west to east (the staging area, the middle cross-aisle
    if any, the back cross-aisle if any); ``pallets``: footprints (x0, y0, x1, y1) m of the pallets on the floor;
    ``door``: the dock door's span (y0, y1) m on the west wall."""

    size: tuple[float, float]
    height: float
    decks: tuple[float, ...]
    racks: tuple[WarehouseRack, ...]
    aisles: tuple[WarehouseAisle, ...]
    cross: tuple[WarehouseAisle, ...]
    pallets: tuple[tuple[float, float, float, float], ...]
    door: tuple[float, float]


def warehouse_layout(seed: int = 0) -> WarehouseLayout:
    """The layout of built-in scene ``warehouse`` with ``seed`` (as built)."""
    return _warehouse_layout(_scene_rng("warehouse", seed))


def _warehouse_layout(rng: np.random.Generator) -> WarehouseLayout:
    n = int(rng.integers(3, 5))                       # long aisles
    widths = rng.uniform(*WAREHOUSE_AISLE_W[n], n)
    d1 = float(rng.uniform(*WAREHOUSE_RACK_D[n]))     # depth of a single rack
    d2 = 2.0 * d1 + 0.1                               # a double rack: two back to back, 10 cm between
    ly = 2.0 * d1 + float(widths.sum()) + (n - 1) * d2
    lx = float(rng.uniform(*WAREHOUSE_LENGTH))
    height = float(rng.uniform(3.0, 3.3))
    n_decks = int(rng.integers(4, 6))
    spacing = float(rng.uniform(0.5, 0.6) if n_decks == 4 else rng.uniform(0.45, 0.52))  # top deck <= 2.2 m
    decks = tuple(0.1 + k * spacing for k in range(n_decks))
    bay_w = float(rng.uniform(1.0, 1.35))
    front = PALLET[0] + 0.1 + float(rng.uniform(1.4, 1.7))   # staging area: a row of pallets, then a walkway
    back = float(rng.uniform(1.1, 1.4)) if rng.random() < 0.7 else 0.05  # back cross-aisle, or dead-end aisles
    run0, run1 = front, lx - back
    # a middle cross-aisle (most seeds) cuts the double racks in two, between the wall racks
    cw = float(rng.uniform(*WAREHOUSE_CROSS_W))
    split = float(rng.uniform(0.0, 1.0))
    cross = [WarehouseAisle((0.0, 0.0, run0, ly), "y")]
    segments = [(run0, run1)]
    if rng.random() < 0.65 and run1 - run0 - cw >= 2 * WAREHOUSE_MIN_SEGMENT:
        xc = run0 + WAREHOUSE_MIN_SEGMENT + split * (run1 - run0 - cw - 2 * WAREHOUSE_MIN_SEGMENT)
        cross.append(WarehouseAisle((xc, d1, xc + cw, ly - d1), "y"))
        segments = [(run0, xc), (xc + cw, run1)]
    if back > 0.5:
        cross.append(WarehouseAisle((run1, 0.0, lx, ly), "y"))

    def bays(x0: float, x1: float) -> int:
        return max(1, int(round((x1 - x0) / bay_w)))

    racks = [WarehouseRack((run0, 0.0, run1, d1), "N", bays(run0, run1))]
    aisles = []
    y = d1
    for a in range(n):
        aisles.append(WarehouseAisle((run0, y, run1, y + float(widths[a])), "x"))
        y += float(widths[a])
        if a < n - 1:
            racks.extend(WarehouseRack((s0, y, s1, y + d2), "NS", bays(s0, s1)) for s0, s1 in segments)
            y += d2
    racks.append(WarehouseRack((run0, ly - d1, run1, ly), "S", bays(run0, run1)))
    # the dock door on the west wall, and a row of places for pallets against that wall on
    # either side of it, of which 2 or more (as many as there are places, at most) hold one
    door_w = float(rng.uniform(2.2, 2.6))
    d0 = float(rng.uniform(0.4, ly - door_w - 0.4))
    door = (d0, d0 + door_w)
    places = []
    for lo, hi in ((0.1, door[0] - 0.1), (door[1] + 0.1, ly - 0.1)):
        y = lo + float(rng.uniform(0.0, 0.3))
        while y + PALLET[1] <= hi:
            places.append((0.05, y, 0.05 + PALLET[0], y + PALLET[1]))
            y += PALLET[1] + float(rng.uniform(0.1, 0.3))
    taken = rng.permutation(len(places))[:int(rng.integers(min(2, len(places)), len(places) + 1))]
    pallets = tuple(places[k] for k in sorted(taken))
    return WarehouseLayout((lx, ly), height, decks, tuple(racks), tuple(aisles), tuple(cross), pallets, door)


# ----------------------------------------------------------------------------- the mesh
_POSTS = ((0.16, 0.3, 0.62), (0.35, 0.37, 0.4), (0.15, 0.42, 0.3))   # upright colours: blue, grey, green
_BEAMS = ((0.93, 0.45, 0.1), (0.95, 0.75, 0.1), (0.8, 0.15, 0.12))   # beam colours: orange, yellow, red
_CRATES = ((0.15, 0.35, 0.75), (0.8, 0.2, 0.15), (0.2, 0.6, 0.3), (0.95, 0.8, 0.15), (0.55, 0.55, 0.6))
_CARTON = (0.66, 0.5, 0.32)


def _shell(b: MeshBuilder, rng: np.random.Generator, lay: WarehouseLayout) -> None:
    """Floor, ceiling and walls of the hall, closed as the rooms' shell is (walls from the slab
    bottoms to the ceiling top, floor and ceiling inside the walls); the walls have a darker
    band up to 1.2 m, the west wall a dock door, the ceiling a light strip over every aisle and
    the floor yellow lines along the aisles' edges."""
    t, (lx, ly), h = WALL_T, lay.size, lay.height
    z0, z1 = -SLAB_T, h + SLAB_T
    upper, lower = _jitter(rng, (0.86, 0.86, 0.82), 0.04), _jitter(rng, (0.45, 0.5, 0.55), 0.08)
    for lo, hi in (([-t, -t], [lx + t, 0.0]), ([-t, ly], [lx + t, ly + t]), ([-t, 0.0], [0.0, ly]),
                   ([lx, 0.0], [lx + t, ly])):
        b.box([*lo, z0], [*hi, 1.2], lower)
        b.box([*lo, 1.2], [*hi, z1], upper)
    b.tiled_floor(0.0, lx, 0.0, ly, 0.0, 0.5, [_jitter(rng, (0.6, 0.6, 0.58), 0.03),
                                                _jitter(rng, (0.52, 0.53, 0.52), 0.03)], SLAB_T)
    b.box([0.0, 0.0, h], [lx, ly, z1], (0.9, 0.9, 0.88), 0.01)
    y0, y1 = lay.door  # a roller door: slats of alternating shade, 3 cm proud of the west wall
    slat = _jitter(rng, (0.7, 0.72, 0.75), 0.08)
    top = min(2.7, h - 0.3)
    for j, z in enumerate(np.arange(0.0, top - 1e-9, 0.25)):
        b.box([0.0, y0, z], [0.03, y1, min(z + 0.25, top)], tuple(np.clip(np.asarray(slat) - 0.08 * (j % 2), 0, 1)))
    yellow = (0.95, 0.8, 0.1)
    for a in lay.aisles:
        ax0, ay0, ax1, ay1 = a.rect
        for yy in (ay0 + 0.05, ay1 - 0.13):
            b.box([ax0, yy, 0.0], [ax1, yy + 0.08, 0.008], yellow, 0.02)
        b.box([ax0 + 0.4, 0.5 * (ay0 + ay1) - 0.12, h - 0.05], [ax1 - 0.4, 0.5 * (ay0 + ay1) + 0.12, h],
              (0.98, 0.98, 0.95), 0.0)
    sx = lay.cross[0].rect[2]
    b.box([sx - 0.13, 0.0, 0.0], [sx - 0.05, ly, 0.008], yellow, 0.02)


def _rack(b: MeshBuilder, rng: np.random.Generator, lay: WarehouseLayout, rack: WarehouseRack,
          post, beam, panel, crates, fill: float) -> None:
    """Uprights at every bay's ends (front and back), a deck with a front beam on every aisle
    side at every deck height, a back panel in a double rack, goods on every deck of every bay
    facing an aisle, and a yellow end guard at each end."""
    x0, y0, x1, y1 = rack.rect
    top = lay.decks[-1] + 0.1
    xs = np.linspace(x0, x1, rack.bays + 1)
    for x in xs:
        xa, xb = max(x0, x - _POST / 2), min(x1, x + _POST / 2)
        b.box([xa, y0, 0.0], [xb, y0 + _POST, top], post)
        b.box([xa, y1 - _POST, 0.0], [xb, y1, top], post)
    if len(rack.faces) == 2:  # a double rack: a back panel between its halves, as high as the uprights
        ym = 0.5 * (y0 + y1)
        b.box([x0, ym - 0.01, 0.0], [x1, ym + 0.01, top], panel)
    for z in lay.decks:
        b.box([x0, y0, z], [x1, y1, z + _DECK_T], (0.55, 0.55, 0.55))
        for f in rack.faces:
            ya, yb = (y1 - 0.05, y1) if f == "N" else (y0, y0 + 0.05)
            b.box([x0, ya, z + _DECK_T - _BEAM_H], [x1, yb, z + _DECK_T], beam)
    for xa in (x0 - 0.06, x1):  # end guards against forklifts, where an end faces the floor
        if xa + 0.06 < lay.size[0] - 0.01:
            b.box([xa, y0 + 0.02, 0.0], [xa + 0.06, y1 - 0.02, 0.3], (0.95, 0.8, 0.1))
    depth = (y1 - y0) if len(rack.faces) == 1 else 0.5 * (y1 - y0 - 0.1)
    for k, z in enumerate(lay.decks):
        clear = (lay.decks[k + 1] if k + 1 < len(lay.decks) else lay.height - 0.3) - z - _DECK_T - 0.1
        clear = min(clear, lay.decks[1] - lay.decks[0] - _DECK_T - 0.1)
        for f in rack.faces:
            for bx0, bx1 in zip(xs[:-1], xs[1:]):
                _goods(b, rng, bx0 + _POST / 2 + 0.04, bx1 - _POST / 2 - 0.04, f, y0, y1, depth,
                       z + _DECK_T, clear, crates, fill)


def _goods(b: MeshBuilder, rng: np.random.Generator, xa: float, xb: float, face: str, y0: float, y1: float,
           depth: float, z: float, clear: float, crates, fill: float) -> None:
    """Goods side by side on one deck of one bay, set back 4 cm from the aisle side ``face``:
    cartons (60 %), plastic crates (35 %) or a drum, each of seeded width, depth and height,
    ``fill`` = the chance that a place holds something."""
    x = xa
    while True:
        w = float(rng.uniform(0.3, 0.65))
        if x + w > xb:
            return
        if rng.random() < fill:
            d = float(rng.uniform(0.5, 1.0)) * (depth - 0.08)
            hh = float(rng.uniform(0.4, 1.0)) * clear
            ya, yb = (y1 - 0.04 - d, y1 - 0.04) if face == "N" else (y0 + 0.04, y0 + 0.04 + d)
            kind = rng.random()
            if kind < 0.6:
                b.box([x, ya, z], [x + w, yb, z + hh], _jitter(rng, _CARTON, 0.07))
            elif kind < 0.95:
                b.box([x, ya, z], [x + w, yb, z + hh], crates[int(rng.integers(len(crates)))])
            else:
                r = 0.5 * min(w, d)
                b.cylinder((x + 0.5 * w, 0.5 * (ya + yb)), z, z + hh, r, _jitter(rng, (0.2, 0.3, 0.6), 0.2), 10)
        x += w + float(rng.uniform(0.02, 0.1))


def _pallet(b: MeshBuilder, rng: np.random.Generator, rect) -> None:
    """A wooden pallet with one to three layers of cartons on it."""
    x0, y0, x1, y1 = rect
    hp = PALLET[2]
    b.box([x0, y0, 0.0], [x1, y1, hp], _jitter(rng, (0.72, 0.58, 0.4), 0.05))
    z = hp
    for _ in range(int(rng.integers(1, 4))):
        hh = float(rng.uniform(0.3, 0.5))
        m = float(rng.uniform(0.0, 0.06))
        b.box([x0 + m, y0 + m, z], [x1 - m, y1 - m, z + hh], _jitter(rng, _CARTON, 0.07))
        z += hh
    b.footprint(x0, y0, x1, y1)


def _warehouse(rng: np.random.Generator) -> trimesh.Trimesh:
    """The hall of :func:`warehouse_layout`: shell, racks with their goods, pallets; the mesh
    declares the long aisles as the rooms of the tour (``metadata[TOUR_ROOMS]``, see above)."""
    lay = _warehouse_layout(rng)
    b = MeshBuilder(rng)
    _shell(b, rng, lay)
    post = _jitter(rng, _POSTS[int(rng.integers(len(_POSTS)))], 0.04)
    beam = _jitter(rng, _BEAMS[int(rng.integers(len(_BEAMS)))], 0.04)
    panel = _jitter(rng, (0.75, 0.76, 0.78), 0.06)
    for rack in lay.racks:
        crates = [_jitter(rng, _CRATES[k], 0.05) for k in rng.choice(len(_CRATES), 2, replace=False)]
        _rack(b, rng, lay, rack, post, beam, panel, crates, float(rng.uniform(0.6, 0.95)))
        b.footprint(*rack.rect)
    for p in lay.pallets:
        _pallet(b, rng, p)
    mesh = b.mesh()
    mesh.metadata[TOUR_ROOMS] = [a.rect for a in lay.aisles]
    return mesh


register_scene(SceneSpec("warehouse", _warehouse, "a hall of shelving racks in a seeded aisle grid, with "
                                                  "cross-aisles, a staging area and pallets"))
