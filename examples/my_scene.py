"""A scene in one file (docs/EXTENDING.md, part 3): two rooms side by side, joined by a
doorway, with a table and a shelf. Metres, z up, floor at z = 0, closed on every side.

Use it with ``world.scene.name: two_rooms`` in a scenario that loads this file.
"""
from __future__ import annotations

import numpy as np

from ramensim.world import furniture as fu
from ramensim.world.furniture import MeshBuilder
from ramensim.world.scenes import SceneSpec, register_scene
from ramensim.world.scenes.rooms import room_shell


def two_rooms(rng: np.random.Generator) -> MeshBuilder:
    """Floor 8 x 4 m, 2.6 m high, a wall at x = 4 m with a 1 m doorway; the same ``rng``
    state gives the same mesh (colours are jittered from it)."""
    b = MeshBuilder(rng)
    lx, ly, h = 8.0, 4.0, 2.6
    room_shell(b, rng, lx, ly, h, wall_color=(0.85, 0.82, 0.75), floor_colors=[(0.55, 0.4, 0.3), (0.6, 0.45, 0.33)],
               ceiling_color=(0.95, 0.95, 0.95), inner_x=4.0, door=(1.5, 2.5), floor_colors_b=[(0.5, 0.5, 0.55)] * 2)
    fu.table(b, 1.2, 1.2, 0, w=1.4, d=0.8, h=0.75, top=(0.6, 0.4, 0.25))
    fu.bookshelf(b, 6.5, 3.55, 0, color=(0.8, 0.8, 0.78), rng=rng)
    return b


register_scene(SceneSpec("two_rooms", two_rooms, "two 4 x 4 m rooms joined by a doorway (examples/my_scene.py)"))
