"""Any mesh file (PLY, OBJ, GLB, ...) as a scene, colours kept (``world.scene.kind: mesh``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from ramensim.core.errors import InputError
from ramensim.world.scenes.registry import Scene, padded_bounds


def load_mesh_scene(path: str | Path, bounds=None, default_color=(0.7, 0.7, 0.7), up_axis: str = "z",
                    padding: float = 0.1) -> Scene:
    """Load a mesh file (PLY, OBJ, GLB, ...) as a scene.

    Vertex or face colours are kept; textures are sampled to vertex colours; a mesh with no
    colours gets ``default_color`` (RGB in [0, 1]). Multi-mesh files (GLB scenes) are
    merged. ``up_axis='y'`` rotates +y to +z. ``bounds`` (2, 3) in metres overrides the
    mesh's bounding box padded by ``padding`` metres. Raises InputError naming the file if it
    is missing, unreadable, or has no faces.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: mesh file not found; expected a PLY/OBJ/GLB file for world.scene.path.")
    try:
        loaded = trimesh.load(p, process=False)
    except Exception as exc:  # trimesh raises many kinds of errors for bad files
        raise InputError(f"{p}: cannot be read as a mesh ({type(exc).__name__}: {exc}); expected a "
                         f"PLY, OBJ or GLB triangle mesh.") from None
    if isinstance(loaded, trimesh.Scene):
        geoms = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)] if loaded.geometry else []
        mesh = _merge_colored(geoms, default_color) if geoms else None
    elif isinstance(loaded, trimesh.Trimesh):
        mesh = loaded
    else:
        mesh = None
    if mesh is None or len(mesh.faces) == 0:
        raise InputError(f"{p}: the file has no triangle faces (a point cloud or an empty mesh?); "
                         f"a scene needs a triangle mesh.")
    mesh = _with_colors(mesh, default_color)
    if up_axis == "y":
        mesh.apply_transform(np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float))
    if not np.all(np.isfinite(mesh.vertices)):
        raise InputError(f"{p}: the mesh has NaN or infinite vertex coordinates; expected finite "
                         f"coordinates in metres.")
    if bounds is None:
        b = padded_bounds(mesh, padding)
    else:
        b = np.asarray(bounds, dtype=np.float64)
        if b.shape != (2, 3) or np.any(b[0] >= b[1]):
            raise InputError(f"{p}: bounds {bounds} are not [[xmin, ymin, zmin], [xmax, ymax, zmax]] "
                             f"with every min below its max.")
    return Scene(name=p.stem, mesh=mesh, bounds=b)


def _with_colors(mesh: trimesh.Trimesh, default_color) -> trimesh.Trimesh:
    """Return a mesh whose visual is vertex or face colours (textures -> vertex colours)."""
    kind = mesh.visual.kind
    if kind == "texture":
        try:
            mesh.visual = mesh.visual.to_color()
            kind = mesh.visual.kind
        except Exception:  # a broken texture: fall back to the default colour
            kind = None
    if kind not in ("vertex", "face"):
        rgba = np.array([*(np.round(np.asarray(default_color) * 255)), 255], dtype=np.uint8)
        mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.tile(rgba, (len(mesh.vertices), 1)))
    return mesh


def _merge_colored(geoms: list[trimesh.Trimesh], default_color) -> trimesh.Trimesh:
    parts = []
    for g in geoms:
        g = _with_colors(g.copy(), default_color)
        if g.visual.kind == "face":
            g.visual = trimesh.visual.ColorVisuals(g, vertex_colors=g.visual.vertex_colors)
        parts.append(g)
    return trimesh.util.concatenate(parts)
