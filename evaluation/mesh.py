"""Meshes from a signed distance function: uniform grid + marching cubes (docs/ALGORITHM.md section 5).

The paper (section V) reconstructs each agent's mesh "by querying the neural implicit maps
within a uniform voxel grid and applying the marching cubes algorithm"; this module does
that for any callable, so it serves analytic SDFs in tests and neural maps alike (the
query cost is then the map's). Also: PLY export and loading a mesh file.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import trimesh
from skimage.measure import marching_cubes

from ramensim.core.files import atomic_write_bytes

log = logging.getLogger(__name__)

PointFn = Callable[[np.ndarray], Any]
"""Takes (N, 3) float32 world points in metres, returns an array-like (numpy or torch)."""


def to_numpy(x: Any) -> np.ndarray:
    """Array-like or torch tensor (detached, moved to CPU) -> numpy array, without importing torch."""
    if hasattr(x, "detach"):
        x = x.detach()
    if hasattr(x, "cpu"):
        x = x.cpu()
    if hasattr(x, "numpy"):
        x = x.numpy()
    return np.asarray(x)


def grid_shape(bounds: np.ndarray, voxel_m: float) -> tuple[int, int, int]:
    """Number of grid points per axis covering ``bounds`` (2, 3) m at spacing ``voxel_m`` m.

    The grid starts at ``bounds[0]`` and has ``ceil(extent / voxel) + 1`` points per axis,
    so it reaches at least ``bounds[1]`` (it may overshoot by less than one voxel).
    """
    extent = bounds[1] - bounds[0]
    n = np.ceil(extent / voxel_m - 1e-9).astype(np.int64) + 1
    return tuple(int(max(v, 2)) for v in n)  # type: ignore[return-value]


def _check_bounds(bounds: Any, voxel_m: float) -> np.ndarray:
    b = np.asarray(bounds, dtype=np.float64)
    if b.shape != (2, 3) or not np.all(np.isfinite(b)):
        raise ValueError(f"extract_mesh: bounds must be a finite (2, 3) array [[xmin, ymin, zmin], "
                         f"[xmax, ymax, zmax]] in metres, got {np.asarray(bounds).tolist()!r}.")
    if np.any(b[1] <= b[0]):
        raise ValueError(f"extract_mesh: bounds {b.tolist()} have max <= min on some axis; expected "
                         f"min < max on x, y and z (metres).")
    if not (np.isfinite(voxel_m) and voxel_m > 0):
        raise ValueError(f"extract_mesh: voxel_m = {voxel_m!r} is not a positive number of metres.")
    return b


def _eval_on_grid(fn: PointFn, origin: np.ndarray, voxel_m: float, shape: tuple[int, int, int],
                  chunk: int, out_dtype: type, name: str) -> np.ndarray:
    """Evaluate a scalar point function on every grid point, ``chunk`` points at a time."""
    total = shape[0] * shape[1] * shape[2]
    out = np.empty(total, dtype=out_dtype)
    origin32 = origin.astype(np.float64)
    for start in range(0, total, chunk):
        stop = min(start + chunk, total)
        ijk = np.unravel_index(np.arange(start, stop, dtype=np.int64), shape)
        pts = (origin32 + np.stack(ijk, axis=1) * voxel_m).astype(np.float32)
        val = to_numpy(fn(pts)).reshape(-1)
        if val.shape[0] != stop - start:
            raise ValueError(f"extract_mesh: {name} returned {val.shape[0]} values for "
                             f"{stop - start} points; expected one value per point.")
        out[start:stop] = val
    return out.reshape(shape)


def _cell_mask(observed: np.ndarray) -> np.ndarray:
    """(nx-1, ny-1, nz-1) cells whose 8 corner grid points are all observed."""
    o = observed
    return (o[:-1, :-1, :-1] & o[1:, :-1, :-1] & o[:-1, 1:, :-1] & o[:-1, :-1, 1:]
            & o[1:, 1:, :-1] & o[1:, :-1, 1:] & o[:-1, 1:, 1:] & o[1:, 1:, 1:])


def _colors(color_fn: PointFn, verts: np.ndarray, chunk: int) -> np.ndarray:
    """RGBA uint8 vertex colours from ``color_fn`` (rgb in [0, 1], clipped)."""
    rgba = np.full((len(verts), 4), 255, dtype=np.uint8)
    for start in range(0, len(verts), chunk):
        pts = verts[start:start + chunk].astype(np.float32)
        rgb = to_numpy(color_fn(pts)).astype(np.float64).reshape(len(pts), -1)
        if rgb.shape[1] < 3:
            raise ValueError(f"extract_mesh: color_fn returned shape {rgb.shape}; expected (N, 3) "
                             f"rgb values in [0, 1].")
        rgb = np.nan_to_num(rgb[:, :3], nan=0.0, posinf=1.0, neginf=0.0)
        rgba[start:start + len(pts), :3] = np.rint(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)
    return rgba


def empty_mesh() -> trimesh.Trimesh:
    """A mesh with no vertices and no faces (the answer for a map holding no surface)."""
    return trimesh.Trimesh(vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), dtype=np.int64),
                           process=False)


def add_time(times: dict[str, float] | None, stage: str, t0: float) -> float:
    """Add the wall-clock seconds since ``t0`` (``time.perf_counter()``) to ``times[stage]``
    (when ``times`` is a dict) and return now, the next stage's ``t0``. The evaluation's
    per-stage costs (``Evaluator`` records them per evaluation); figures, never results."""
    now = time.perf_counter()
    if times is not None:
        times[stage] = times.get(stage, 0.0) + (now - t0)
    return now


GridFn = Callable[[np.ndarray, float, tuple[int, int, int]], Any]
"""Takes (origin (3,) m, voxel_m, shape), returns the SDF on that grid as an array of ``shape``."""


@dataclass(frozen=True)
class NarrowBand:
    """Coarse-to-fine extraction (an approximation, for periodic evaluations only): the SDF on a
    grid ``factor`` times coarser (points ``origin + factor * c * voxel_m``), then on the fine grid
    only inside the coarse cells near the level set: a sign change across the cell's corners or a
    corner within ``band_m`` (m) of the level (or a non-finite one), grown by ``dilate`` cells in
    every direction, then grown again wherever a fine cell just outside the band would see a
    sign change (the surface leaves the band through a face), until none does. Every other fine
    grid point keeps its coarse cell's sign (the value ``level +- factor * voxel_m``), so
    marching cubes gives no surface there and, inside the band, the surface of the full grid
    (the SDF at the band's points is the point query's). What it misses: surface wholly inside
    coarse cells whose corners all lie on one side and beyond ``band_m`` (thin sheets, small
    closed blobs between the coarse points)."""

    factor: int = 2
    band_m: float = 0.03
    dilate: int = 0


def _up(a: np.ndarray, factor: int, shape: tuple[int, ...]) -> np.ndarray:
    """Coarse per-cell (or per-point) array -> fine, index ``i`` taking coarse ``i // factor``."""
    ix = [np.arange(n) // factor for n in shape]
    return a[np.ix_(*ix)]


def _points_of_cells(cells: np.ndarray) -> np.ndarray:
    """(nx, ny, nz) points touched by the (nx-1, ny-1, nz-1) cells marked in ``cells``."""
    nx, ny, nz = cells.shape
    pts = np.zeros((nx + 1, ny + 1, nz + 1), dtype=bool)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                pts[dx:dx + nx, dy:dy + ny, dz:dz + nz] |= cells
    return pts


def _sign_change_cells(pos: np.ndarray) -> np.ndarray:
    """(nx-1, ny-1, nz-1) cells whose 8 corners are not all on one side (``pos``: above the level)."""
    any_ = np.zeros(tuple(n - 1 for n in pos.shape), dtype=bool)
    all_ = np.ones_like(any_)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                c = pos[dx:dx + any_.shape[0], dy:dy + any_.shape[1], dz:dz + any_.shape[2]]
                any_ |= c
                all_ &= c
    return any_ & ~all_


RegionFn = Callable[[np.ndarray, float, tuple[int, int, int]], np.ndarray]
"""Takes (origin (3,) m, cell_m, cells (nx, ny, nz)), returns a boolean array of ``cells``: the
cells ``origin + [i, i + 1] * cell_m`` (closed boxes) in which a surface may be kept."""


def narrow_band_grid(sdf_fn: PointFn, grid_fn: GridFn | None, origin: np.ndarray, voxel_m: float,
                     shape: tuple[int, int, int], band: NarrowBand, chunk: int, level: float = 0.0,
                     stats: dict[str, float] | None = None, region: RegionFn | None = None) -> np.ndarray:
    """The fine grid's SDF as :class:`NarrowBand` approximates it (float32, ``shape``): exact (the
    point query ``sdf_fn`` at the grid's points) inside the band, the coarse cell's sign
    (``level +- factor * voxel_m``) outside. ``stats`` (optional dict) gets ``band_points``
    (fine points queried), ``coarse_points`` and ``rounds`` (band growths).

    ``region`` (optional): which coarse cells may hold a surface that is kept (e.g. those some
    camera may have seen, when the mesh is culled to the cameras' views afterwards). Cells
    outside it are never refined nor grown into: their fine points keep the coarse sign, so
    the SDF is not queried there and any surface made there lies inside those cells (the
    caller's to drop). Inside the region the values are those without ``region`` for the same
    refined cells."""
    from scipy.ndimage import binary_dilation

    f = int(band.factor)
    cshape = tuple((n - 1 + f - 1) // f + 1 for n in shape)  # coarse point c at fine index c * f
    if grid_fn is not None:
        coarse = np.asarray(to_numpy(grid_fn(origin, voxel_m * f, cshape)), dtype=np.float32)
    else:
        coarse = _eval_on_grid(sdf_fn, origin, voxel_m * f, cshape, chunk, np.float32, "sdf_fn")
    finite = np.isfinite(coarse)
    hi = np.where(finite, coarse, np.inf) >= level - band.band_m   # some corner at or above level - band
    lo = np.where(finite, coarse, -np.inf) <= level + band.band_m  # some corner at or below level + band
    # a cell is refined when some corner is <= level + band and some corner is >= level - band
    cells = ~_cell_mask(~lo) & ~_cell_mask(~hi)
    kept = None
    if region is not None:
        kept = np.asarray(region(np.asarray(origin, dtype=np.float64), voxel_m * f, cells.shape), dtype=bool)
        if kept.shape != cells.shape:
            raise ValueError(f"narrow_band_grid: region returned shape {kept.shape}; expected the coarse "
                             f"cells' {cells.shape}.")
        cells &= kept
    if band.dilate > 0 and cells.any():
        cells = binary_dilation(cells, structure=np.ones((3, 3, 3), bool), iterations=band.dilate)
        if kept is not None:
            cells &= kept
    fill = np.float32(f * voxel_m)
    sdf = np.where(_up(coarse > level, f, shape), np.float32(level) + fill,
                   np.float32(level) - fill).astype(np.float32)
    fine_kept = None if kept is None else _up(kept, f, tuple(n - 1 for n in shape))
    done = np.zeros(shape, dtype=bool)
    axes = [(origin[a] + np.arange(shape[a], dtype=np.int64) * voxel_m).astype(np.float32) for a in range(3)]
    rounds = 0
    while True:
        rounds += 1
        fine_cells = _up(cells, f, tuple(n - 1 for n in shape))
        todo = np.flatnonzero(_points_of_cells(fine_cells) & ~done)
        if len(todo) == 0:
            break
        step = max(int(chunk), 1) * 16
        for s in range(0, len(todo), step):
            ids = todo[s:s + step]
            i, j, k = np.unravel_index(ids, shape)
            pts = np.stack([axes[0][i], axes[1][j], axes[2][k]], axis=1)
            val = to_numpy(sdf_fn(pts)).reshape(-1)
            if val.shape[0] != len(ids):
                raise ValueError(f"extract_mesh: sdf_fn returned {val.shape[0]} values for {len(ids)} points; "
                                 f"expected one value per point.")
            sdf.reshape(-1)[ids] = val
        done.reshape(-1)[todo] = True
        # fine cells outside the band with a sign change: the surface leaves the band there
        leak = _sign_change_cells(sdf > level) & ~fine_cells
        if fine_kept is not None:
            leak &= fine_kept
        if not leak.any():
            break
        li, lj, lk = np.nonzero(leak)
        cells[li // f, lj // f, lk // f] = True
    if stats is not None:
        stats["band_points"] = stats.get("band_points", 0) + int(done.sum())
        stats["coarse_points"] = stats.get("coarse_points", 0) + int(coarse.size)
        stats["rounds"] = stats.get("rounds", 0) + rounds
    return sdf


def extract_mesh(sdf_fn: PointFn, bounds: Any, voxel_m: float, color_fn: PointFn | None = None,
                 mask_fn: PointFn | None = None, chunk: int = 65_536,
                 level: float = 0.0, grid_fn: GridFn | None = None,
                 times: dict[str, float] | None = None, band: NarrowBand | None = None,
                 region: RegionFn | None = None) -> trimesh.Trimesh:
    """Mesh of the zero level set of ``sdf_fn`` inside ``bounds`` (paper section V).

    ``sdf_fn`` maps (N, 3) float32 world points (m) to N signed distances (m, negative
    inside; numpy or torch); it is queried on a uniform grid with spacing ``voxel_m`` (m)
    starting at ``bounds[0]`` (see :func:`grid_shape`), ``chunk`` points at a time, so peak
    extra memory is O(chunk) besides the float32 grid itself. Marching cubes (Lewiner,
    scikit-image) runs at ``level``; faces are wound so that normals point outwards
    (towards positive SDF). Vertex colours come from ``color_fn`` ((N, 3) rgb in [0, 1] ->
    uint8). ``mask_fn`` maps points to booleans (True = observed); a grid cell produces
    faces only if all 8 of its corners are observed. Non-finite SDF values mark their
    cells unobserved. No zero crossing -> an empty mesh (0 faces), never an exception.
    ``grid_fn`` (optional) gives the SDF on the whole grid at once instead of ``sdf_fn`` point
    by point (a map that can share work between grid points, e.g. ``NeuralMap.sdf_grid``).
    ``times`` (optional dict): wall-clock seconds added per stage, ``sdf_grid`` (the SDF on the
    grid), ``mask`` (``mask_fn`` on the grid), ``marching_cubes`` (with the observed-cell
    filter and the mesh's assembly) and ``colours`` (``color_fn`` at the vertices).
    ``band`` (optional, an approximation for periodic evaluations only): the SDF on the full grid
    only near the surface (:class:`NarrowBand`, :func:`narrow_band_grid`); None = every grid point.
    ``region`` (with ``band`` only): the coarse cells where a surface may be kept
    (:func:`narrow_band_grid`); outside them the SDF is not queried (the coarse sign is kept).
    """
    t0 = time.perf_counter()
    b = _check_bounds(bounds, voxel_m)
    chunk = max(int(chunk), 1)
    shape = grid_shape(b, voxel_m)
    origin = b[0]
    if band is not None:
        sdf = narrow_band_grid(sdf_fn, grid_fn, origin, voxel_m, shape, band, chunk, level, region=region)
    elif grid_fn is not None:
        sdf = np.asarray(to_numpy(grid_fn(origin, voxel_m, shape)), dtype=np.float32)
        if sdf.shape != shape:
            raise ValueError(f"extract_mesh: grid_fn returned shape {sdf.shape}; expected the grid's {shape}.")
    else:
        sdf = _eval_on_grid(sdf_fn, origin, voxel_m, shape, chunk, np.float32, "sdf_fn")
    t0 = add_time(times, "sdf_grid", t0)
    finite = np.isfinite(sdf)
    observed = None
    if mask_fn is not None:
        observed = _eval_on_grid(mask_fn, origin, voxel_m, shape, chunk, bool, "mask_fn")
        t0 = add_time(times, "mask", t0)
    if not finite.all():
        log.warning("extract_mesh: %d of %d SDF values are not finite; their cells produce no faces",
                    int((~finite).sum()), sdf.size)
        observed = finite if observed is None else (observed & finite)
        sdf[~finite] = np.float32(np.nanmax(np.where(finite, np.abs(sdf), 0.0)) + 1.0)
    if observed is not None and not observed.any():
        return empty_mesh()
    values = sdf if observed is None else sdf[observed]
    if values.size == 0 or not (values.min() < level < values.max()):
        return empty_mesh()
    try:
        verts, faces, _normals, _vals = marching_cubes(sdf, level=level, spacing=(voxel_m,) * 3)
    except (ValueError, RuntimeError):  # no surface at this level
        add_time(times, "marching_cubes", t0)
        return empty_mesh()
    if observed is not None:
        cells = _cell_mask(observed)
        centroid = verts[faces].mean(axis=1) / voxel_m
        cidx = np.clip(np.floor(centroid).astype(np.int64), 0, np.array(cells.shape) - 1)
        faces = faces[cells[cidx[:, 0], cidx[:, 1], cidx[:, 2]]]
        if len(faces) == 0:
            add_time(times, "marching_cubes", t0)
            return empty_mesh()
    verts = verts.astype(np.float64) + origin
    mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    if observed is not None:
        mesh.remove_unreferenced_vertices()
    t0 = add_time(times, "marching_cubes", t0)
    if color_fn is not None:
        mesh.visual.vertex_colors = _colors(color_fn, np.asarray(mesh.vertices), chunk)
        add_time(times, "colours", t0)
    return mesh


def export_ply(mesh: trimesh.Trimesh, path: str | Path) -> Path:
    """Write ``mesh`` (with vertex colours if any) as binary PLY, atomically (a temp file
    renamed: never a torn file; on a full disk ``WriteFailed`` names the file and its size);
    creates parent folders."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(p, trimesh.exchange.ply.export_ply(mesh, encoding="binary"))
    return p


def load_mesh(path: str | Path) -> trimesh.Trimesh:
    """Read a triangle mesh file (PLY, OBJ, STL, GLB, ...); scenes are concatenated.

    A file with no vertices and no faces loads as an empty mesh (an empty map is a valid
    result; the metrics then say why they are NaN). Raises FileNotFoundError for a missing
    file and ValueError (one paragraph naming the file) for one that is unreadable or holds
    points without faces.
    """
    p = Path(path)
    if p.is_dir():
        plys = sorted(x.name for x in p.glob("*.ply"))[:4]
        raise ValueError(f"{p}: is a folder; expected a triangle mesh file (.ply, .obj, .stl, .glb)"
                         + (f", e.g. one of the meshes in it: {', '.join(plys)}" if plys else "") + ".")
    if not p.is_file():
        raise FileNotFoundError(f"{p}: mesh file not found; expected a triangle mesh (.ply, .obj, "
                                f".stl, .glb).")
    try:
        loaded = trimesh.load(p, process=False)
    except Exception as exc:  # trimesh raises many types for corrupt files
        raise ValueError(f"{p}: cannot be read as a mesh ({type(exc).__name__}: {exc}); expected a "
                         f"triangle mesh file such as binary or ASCII PLY.") from None
    if isinstance(loaded, trimesh.Scene):
        parts = list(loaded.dump()) if loaded.geometry else []
        meshes = [g for g in parts if isinstance(g, trimesh.Trimesh)]
        if parts and not meshes:
            raise ValueError(f"{p}: holds {', '.join(sorted({type(g).__name__ for g in parts}))}, no "
                             f"triangle mesh; expected a file with faces (not a point cloud).")
        loaded = trimesh.util.concatenate(meshes) if meshes else empty_mesh()
    if not isinstance(loaded, trimesh.Trimesh):
        raise ValueError(f"{p}: holds a {type(loaded).__name__}, not a triangle mesh; expected a "
                         f"file with faces (e.g. PLY with a face element), not a point cloud.")
    if len(loaded.faces) == 0 and len(loaded.vertices) > 0:
        raise ValueError(f"{p}: holds {len(loaded.vertices)} points but no faces (a point cloud); "
                         f"expected a triangle mesh.")
    return loaded
