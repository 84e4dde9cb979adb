"""Known answers of the paper's metrics (docs/ALGORITHM.md section 5)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from ramensim.evaluation.metrics import mesh_metrics, sample_surface

N = 20_000  # 1 m^2 plane: nearest-sample floor ~ 0.5 * sqrt(1 / N) = 3.5 mm


def plane(size: float = 1.0, z: float = 0.0, subdiv: int = 2) -> trimesh.Trimesh:
    """A size x size square in the plane z (metres), triangulated."""
    m = trimesh.creation.box(extents=(size, size, 1.0))
    top = m.faces[m.face_normals[:, 2] > 0.5]
    sq = trimesh.Trimesh(m.vertices, top, process=True)
    sq.remove_unreferenced_vertices()
    sq.vertices[:, 2] = z
    for _ in range(subdiv):
        sq = sq.subdivide()
    return sq


def test_sample_surface_is_on_the_mesh_and_area_uniform():
    rng = np.random.default_rng(0)
    wide = plane(1.0)
    wide.vertices[:, 0] *= 2.0
    big = trimesh.util.concatenate([plane(1.0), wide.apply_translation((5.0, 0.0, 0.0))])
    pts = sample_surface(big, 30_000, rng)  # areas 1 and 2 m^2
    assert np.allclose(pts[:, 2], 0.0)
    frac_big = np.mean(pts[:, 0] > 2.0)
    assert abs(frac_big - 2 / 3) < 0.02
    assert np.all(np.abs(pts[pts[:, 0] < 2.0, :2]) <= 0.5 + 1e-9)


def test_sampling_is_seeded():
    m = plane()
    a = sample_surface(m, 100, np.random.default_rng(3))
    b = sample_surface(m, 100, np.random.default_rng(3))
    assert np.array_equal(a, b)
    r1 = mesh_metrics(m, plane(z=0.02), n_samples=N, seed=7)
    r2 = mesh_metrics(m, plane(z=0.02), n_samples=N, seed=7)
    assert r1 == r2


def test_mesh_against_itself():
    m = plane()
    r = mesh_metrics(m, m, n_samples=N, seed=0)
    assert r["reason"] is None
    assert r["artifacts_cm"] < 0.6 and r["holes_cm"] < 0.6  # sampling floor only
    assert r["completion_ratio_pct"] == 100.0
    assert r["n_samples_recon"] == N and r["n_samples_gt"] == N


def test_shift_3cm_gives_3cm_both_ways_and_full_completion():
    r = mesh_metrics(plane(z=0.03), plane(), n_samples=N, seed=1)
    assert r["artifacts_cm"] == pytest.approx(3.0, abs=0.1)
    assert r["holes_cm"] == pytest.approx(3.0, abs=0.1)
    assert r["completion_ratio_pct"] == 100.0


def test_shift_10cm_gives_no_completion():
    r = mesh_metrics(plane(z=0.10), plane(), n_samples=N, seed=2)
    assert r["artifacts_cm"] == pytest.approx(10.0, abs=0.1)
    assert r["completion_ratio_pct"] < 1.0


def test_threshold_is_respected():
    r = mesh_metrics(plane(z=0.10), plane(), n_samples=N, seed=2, threshold_m=0.2)
    assert r["completion_ratio_pct"] == 100.0


def test_half_mesh_against_whole():
    whole = plane(subdiv=3)
    centres = whole.triangles_center
    half = whole.submesh([np.flatnonzero(centres[:, 0] < 0.0)], append=True)
    r = mesh_metrics(half, whole, n_samples=N, seed=4)
    assert r["completion_ratio_pct"] == pytest.approx(50.0 + 100 * 0.05 / 1.0, abs=2.0)  # + 5 cm strip
    assert r["artifacts_cm"] < 0.6
    assert r["holes_cm"] > 10.0  # missing half is on average 25 cm away


def test_empty_mesh_gives_nan_and_reason():
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int))
    r = mesh_metrics(empty, plane(), n_samples=N)
    assert math.isnan(r["artifacts_cm"]) and math.isnan(r["completion_ratio_pct"])
    assert "reconstructed mesh is empty" in r["reason"]
    r = mesh_metrics(plane(), empty, n_samples=N)
    assert "ground-truth mesh is empty" in r["reason"]


def test_nan_vertices_give_nan_and_reason():
    bad = plane()
    v = bad.vertices.copy()
    v[0] = np.nan
    bad = trimesh.Trimesh(v, bad.faces, process=False)
    r = mesh_metrics(bad, plane(), n_samples=N)
    assert math.isnan(r["holes_cm"])
    assert "NaN or infinite" in r["reason"]


@pytest.mark.parametrize("scale", [100.0, 1000.0, 0.001])
def test_different_units_give_nan_and_reason(scale):
    other = plane()
    other.apply_scale(scale)
    r = mesh_metrics(other, plane(), n_samples=N)
    assert math.isnan(r["artifacts_cm"])
    assert "different units" in r["reason"]


def test_zero_area_mesh():
    degenerate = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    r = mesh_metrics(degenerate, plane(), n_samples=N)
    assert "zero surface area" in r["reason"]
