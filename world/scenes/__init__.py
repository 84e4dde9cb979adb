"""Scenes: a coloured ground-truth triangle mesh and its bounds.

Built-in scenes are generated from a name and a seed (same name + seed = the same mesh):
``office``, ``living_room``, ``apartment`` (two rooms joined by a doorway; :mod:`.rooms`),
``house`` (six rooms in a 2 x 3 grid joined in a chain by one doorway each, see
:func:`house_layout`; :mod:`.house`), ``warehouse`` (shelving racks in a seeded aisle grid in
one hall, see :func:`warehouse_layout`; :mod:`.warehouse`) and ``pretrain_room`` (for
pretraining decoders only, never for evaluation). Each is declared once with
``register_scene`` (:mod:`.registry`), as a plugin's scene is (docs/EXTENDING.md). Each is
closed (floor, ceiling, walls as boxes with thickness) so every camera ray hits something; x
and y span the floor, z points up, the floor is at z = 0, units are metres. Any mesh file
(PLY/OBJ/GLB, ...) can be a scene too (:func:`load_mesh_scene`, :mod:`.meshfile`).
"""
from __future__ import annotations

from ramensim.world.scenes.registry import (Scene, SceneSpec, builtin_scene, get_scene, padded_bounds,
                                            register_scene, scene_names, unregister_scene)
from ramensim.world.scenes.rooms import SLAB_T, WALL_T, Room  # noqa: I001 - registers the single rooms first
from ramensim.world.scenes.house import (HOUSE_AISLE, HOUSE_CHAIN, HOUSE_DOOR_H, HOUSE_DOOR_W, HOUSE_KINDS,
                                         HouseDoor, HouseLayout, HouseRoom, house_layout)
from ramensim.world.scenes.warehouse import (WarehouseAisle, WarehouseLayout, WarehouseRack,
                                             warehouse_layout)
from ramensim.world.scenes.meshfile import load_mesh_scene


class _Builders(dict):
    """Name -> builder of every registered scene (read-only view kept for older callers)."""

    def _live(self) -> dict:
        from ramensim.world.scenes.registry import _REGISTRY

        return {n: s.build for n, s in _REGISTRY.items()}

    def __iter__(self):
        return iter(self._live())

    def __contains__(self, name: object) -> bool:
        return name in self._live()

    def __getitem__(self, name: str):
        return self._live()[name]

    def __len__(self) -> int:
        return len(self._live())

    def keys(self):
        return self._live().keys()


_BUILDERS = _Builders()

__all__ = [
    "HOUSE_AISLE", "HOUSE_CHAIN", "HOUSE_DOOR_H", "HOUSE_DOOR_W", "HOUSE_KINDS", "SLAB_T", "WALL_T", "HouseDoor",
    "HouseLayout", "HouseRoom", "Room", "Scene", "SceneSpec", "WarehouseAisle", "WarehouseLayout", "WarehouseRack",
    "builtin_scene", "get_scene", "house_layout", "load_mesh_scene", "padded_bounds", "register_scene", "scene_names",
    "unregister_scene", "warehouse_layout",
]
