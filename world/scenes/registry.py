"""Built-in and plugin scenes, declared once each: a name and a builder (docs/EXTENDING.md).

A scene module ends with ``register_scene(SceneSpec(name=..., build=...))``: ``build(rng)``
returns a :class:`ramensim.world.furniture.MeshBuilder` (or a coloured ``trimesh.Trimesh``)
in metres, z up, the floor at z = 0, closed so that every camera ray hits something.
:func:`builtin_scene` is the entry point from a name: it draws the builder's generator from
the name and the seed (same name + seed = the same mesh) and pads the mesh's bounds. The
scenario key ``world.scene.name`` accepts every registered name; a plugin
(:mod:`ramensim.plugins`) registers its scenes the same way as the built-ins.
"""
from __future__ import annotations

import logging
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import trimesh

from ramensim.core.errors import InputError
from ramensim.core.registry import Registry

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Scene:
    """A ground-truth scene: ``mesh`` with per-vertex or per-face colours, ``bounds`` (2, 3)
    = [[xmin, ymin, zmin], [xmax, ymax, zmax]] in metres, padded around the mesh."""

    name: str
    mesh: trimesh.Trimesh
    bounds: np.ndarray

    def export(self, path: str | Path) -> Path:
        """Write the mesh with its colours (PLY by the file's suffix)."""
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        self.mesh.export(p)
        return p


def padded_bounds(mesh: trimesh.Trimesh, pad: float = 0.1) -> np.ndarray:
    """Axis-aligned bounds of ``mesh`` grown by ``pad`` metres on every side, shape (2, 3)."""
    b = np.asarray(mesh.bounds, dtype=np.float64).copy()
    b[0] -= pad
    b[1] += pad
    return b


@dataclass(frozen=True)
class SceneSpec:
    """A scene as the scenario and the world see it."""

    name: str
    """The scenario's ``world.scene.name`` value."""
    build: Callable[[np.random.Generator], Any]
    """``build(rng) -> MeshBuilder | trimesh.Trimesh``: the coloured closed mesh in metres
    (z up, floor at z = 0), deterministic for the state of ``rng``."""
    description: str = ""
    """One line for the docs and ``ramensim schema``."""
    evaluation: bool = True
    """False for a scene meant only for pretraining decoders (``pretrain_room``)."""


_REGISTRY: Registry = Registry("scene", "scene")
"""Name -> spec. The built-ins register when ``ramensim.world.scenes`` is imported (its
``__init__`` imports their modules), so any import of this module sees them."""


def register_scene(spec: SceneSpec) -> SceneSpec:
    """Declare ``spec`` under ``spec.name``; a name taken by another declaration (a built-in
    scene's included) is an error."""
    return _REGISTRY.declare(spec)


def unregister_scene(name: str) -> None:
    """Remove a scene (tests that register a temporary one)."""
    _REGISTRY.withdraw(name)


def scene_names() -> tuple[str, ...]:
    """Every registered scene, in registration order."""
    return _REGISTRY.names()


def get_scene(name: str) -> SceneSpec:
    """The spec of ``name``; ValueError naming the registered scenes (and the closest one)."""
    return _REGISTRY.lookup(name)  # "did you mean" regardless of case: 'LIVINGROOM' -> 'living_room'


def builtin_scene(name: str, seed: int = 0) -> Scene:
    """Generate the registered scene ``name`` from ``seed`` (deterministic)."""
    try:
        spec = get_scene(name)
    except ValueError as exc:
        raise InputError(" ".join(str(exc).split())) from None
    built = spec.build(_scene_rng(name, seed))
    mesh = built.mesh() if callable(getattr(built, "mesh", None)) else built
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(f"scene {name!r} (built by {getattr(spec.build, '__module__', '?')}): its builder returned "
                         f"{type(built).__name__} with no triangle faces; expected a MeshBuilder or a trimesh.Trimesh.")
    log.debug("built-in scene %s (seed %d): %d vertices, %d faces", name, seed, len(mesh.vertices), len(mesh.faces))
    return Scene(name=name, mesh=mesh, bounds=padded_bounds(mesh, 0.1))


def _scene_rng(name: str, seed: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), _stable(name)])))


def _stable(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))
