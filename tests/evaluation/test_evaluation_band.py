"""The periodic evaluations' narrow-band extraction (issue 71, item 3): on analytic SDFs it gives
the full grid's mesh exactly (the band holds every cell with a surface, and marching cubes reads
only those), it follows a surface that leaves the band between the coarse points (the band
grows until its edge agrees with the kept sign), it is used by periodic evaluations only, and a
setting that would make the final evaluation inexact is refused naming the key."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from pydantic import ValidationError

from ramensim.evaluation.config import EvalConfig
from ramensim.evaluation.mesh import NarrowBand, extract_mesh, grid_shape, narrow_band_grid
from ramensim.scoring import Evaluator

BOUNDS = np.array([[-1.0, -0.9, -0.8], [1.0, 0.95, 0.85]])
VOXEL = 0.03


def _sphere(p: np.ndarray) -> np.ndarray:
    return (np.linalg.norm(p - np.array([0.1, -0.05, 0.02]), axis=1) - 0.45).astype(np.float32)


def _with_rod(p: np.ndarray) -> np.ndarray:
    """The sphere and a rod of radius 0.03 m along z through it, its axis halfway between the
    coarse points of factor 4 (0.12 m): the rod's corners outside the sphere are all positive."""
    axis = BOUNDS[0, :2] + 0.12 * np.array([7, 6]) + 0.06
    rod = np.linalg.norm(p[:, :2] - axis, axis=1) - 0.03
    return np.minimum(_sphere(p), rod).astype(np.float32)


@pytest.mark.parametrize("fn,band", [(_sphere, NarrowBand(4, 0.0, 0)), (_sphere, NarrowBand(2, 0.03, 1)),
                                     (_with_rod, NarrowBand(4, 0.0, 0)), (_with_rod, NarrowBand(3, 0.03, 0))])
def test_narrow_band_gives_the_full_grid_mesh(fn, band):
    dense = extract_mesh(fn, BOUNDS, VOXEL)
    approx = extract_mesh(fn, BOUNDS, VOXEL, band=band)
    assert len(dense.faces) > 1000
    assert np.array_equal(dense.vertices, approx.vertices) and np.array_equal(dense.faces, approx.faces)


def test_the_band_grows_along_a_surface_that_leaves_it_and_queries_less():
    shape = grid_shape(BOUNDS, VOXEL)
    stats: dict[str, float] = {}
    grid = narrow_band_grid(_with_rod, None, BOUNDS[0], VOXEL, shape, NarrowBand(4, 0.0, 0), 65_536, stats=stats)
    assert stats["rounds"] > 2  # the rod is found cell by cell from the sphere outwards
    assert stats["band_points"] + stats["coarse_points"] < 0.5 * np.prod(shape)
    ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
    exact = _with_rod((BOUNDS[0] + ijk * VOXEL).astype(np.float32)).reshape(shape)
    assert np.array_equal(grid > 0, exact > 0)  # every sign as the full grid's


class _CountingMap:
    """An analytic map that records the grid shapes it was asked for."""

    def __init__(self) -> None:
        self.grids: list[tuple[int, int, int]] = []
        self.points = 0

    def sdf(self, p: np.ndarray) -> np.ndarray:
        self.points += len(p)
        return _sphere(np.asarray(p, dtype=np.float64))

    def sdf_and_color(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.sdf(p), np.full((len(p), 3), 0.5, np.float32)

    def sdf_grid(self, origin: np.ndarray, voxel: float, shape: tuple[int, int, int]) -> np.ndarray:
        self.grids.append(tuple(shape))
        ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
        return _sphere((origin + ijk * voxel).astype(np.float32)).reshape(shape)


def _world() -> SimpleNamespace:
    return SimpleNamespace(scene=None, n_agents=1, bounds=BOUNDS,
                           intrinsics=SimpleNamespace(fx=50, fy=50, cx=49.5, cy=49.5, width=100, height=100))


def test_only_periodic_evaluations_use_the_narrow_band():
    cfg = EvalConfig(voxel_m=VOXEL, periodic={"extraction": "narrow_band", "coarse_factor": 4})
    ev = Evaluator(cfg, _world())  # type: ignore[arg-type]
    assert ev.periodic_band == NarrowBand(4, 0.03, 0)
    assert EvalConfig(periodic={"extraction": "narrow_band"}).periodic.coarse_factor == NarrowBand().factor
    full = grid_shape(BOUNDS, VOXEL)
    m = _CountingMap()
    dense = ev.extract(m, [np.zeros((0, 4, 4))], [0])  # the final evaluation's call
    assert m.grids == [full] and m.points == len(dense.vertices)  # colours only
    m = _CountingMap()
    approx = ev.extract(m, [np.zeros((0, 4, 4))], [0], periodic=True)
    assert full not in m.grids and len(m.grids) == 1
    assert np.array_equal(dense.vertices, approx.vertices) and np.array_equal(dense.faces, approx.faces)
    assert Evaluator(EvalConfig(), _world()).periodic_band == NarrowBand()  # the default  # type: ignore[arg-type]
    dense_cfg = EvalConfig(voxel_m=VOXEL, periodic={"extraction": "dense"})
    assert Evaluator(dense_cfg, _world()).periodic_band is None  # type: ignore[arg-type]


@pytest.mark.parametrize("value", ["narrow_band", "coarse"])
def test_an_inexact_final_evaluation_is_refused_naming_the_key(value):
    with pytest.raises(ValidationError) as err:
        EvalConfig(extraction=value)
    text = str(err.value)
    assert "evaluation.extraction" in text and "final evaluation" in text
    assert "evaluation.periodic.extraction: narrow_band" in text
    assert EvalConfig(extraction="dense").extraction == "dense"
