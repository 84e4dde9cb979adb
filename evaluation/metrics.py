"""The paper's 3-D metrics (section V; docs/ALGORITHM.md section 5, NICE-SLAM protocol).

Sample points uniformly (by area) on the reconstruction and on the ground truth, then with
a KD-tree:

- **Artifacts** (cm): mean distance from reconstruction samples to the nearest ground-truth
  sample (NICE-SLAM's "accuracy"). Lower is better.
- **Holes** (cm): mean distance from ground-truth samples to the nearest reconstruction
  sample (NICE-SLAM's "completion"). Lower is better.
- **Completion ratio** (%): share of ground-truth samples whose nearest reconstruction
  sample is closer than the threshold (5 cm). The paper's primary metric.

Because both sides are point samples, two identical meshes score about
``0.5 * sqrt(area / n_samples)`` rather than exactly 0 (about 1 mm for 1 m^2 and 200,000
samples); that floor is part of the protocol.
"""
from __future__ import annotations

import logging
import math
import time
from typing import Any, Callable, Mapping

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from ramensim.evaluation.mesh import add_time

log = logging.getLogger(__name__)



class _Surface:
    """A mesh's triangles prepared once for checks and area-uniform sampling (float64, m)."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        self.vertices = np.asarray(mesh.vertices, dtype=np.float64)
        self.faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        self.used = np.zeros(len(self.vertices), dtype=bool)
        self.used[self.faces.ravel()] = True
        self._cdf: np.ndarray | None = None

    def cdf(self) -> np.ndarray:
        """Cumulative triangle areas (m^2)."""
        if self._cdf is None:
            v, f = self.vertices, self.faces
            a = v[f[:, 0]]
            e1 = v[f[:, 1]] - a
            e2 = v[f[:, 2]] - a
            cx = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
            cy = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
            cz = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
            self._cdf = np.cumsum(0.5 * np.sqrt(cx * cx + cy * cy + cz * cz))
        return self._cdf

    @staticmethod
    def draws(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The uniforms :meth:`sample` takes from ``rng`` for ``n`` points, in the order it takes
        them (face, then the two barycentric draws): what a sample of any mesh consumes, so
        that drawing them and throwing them away leaves ``rng`` where a sample would."""
        return rng.random(n), rng.random(n), rng.random(n)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """See :func:`sample_surface`."""
        cdf = self.cdf()
        if len(cdf) == 0 or not np.isfinite(cdf[-1]) or cdf[-1] <= 0:
            raise ValueError("sample_surface: the mesh has no triangle of positive area.")
        u, r1, r2 = self.draws(n, rng)
        # sorted uniforms make the inverse-CDF lookup cache friendly; the set of points is the same
        face = np.minimum(np.searchsorted(cdf, np.sort(u) * cdf[-1], side="right"), len(cdf) - 1)
        r1 = np.sqrt(r1)
        tri = self.vertices[self.faces[face]]
        a = tri[:, 0]
        return a + (r1 * (1.0 - r2))[:, None] * (tri[:, 1] - a) + (r1 * r2)[:, None] * (tri[:, 2] - a)

    def problem(self, name: str) -> str | None:
        """A sentence saying why this mesh cannot be scored, or None if it can."""
        if len(self.faces) == 0 or len(self.vertices) == 0:
            return (f"the {name} mesh is empty ({len(self.vertices)} vertices, {len(self.faces)} faces); "
                    f"expected a surface with at least one triangle (an empty map, or culling removed "
                    f"everything).")
        bad = int((~np.isfinite(self.vertices[self.used]).all(axis=1)).sum())
        if bad:
            return (f"the {name} mesh has {bad} vertices with NaN or infinite coordinates; expected "
                    f"finite coordinates in metres (a diverged map?).")
        if not self.cdf()[-1] > 0.0:
            return f"the {name} mesh has zero surface area; expected at least one non-degenerate triangle."
        return None

    def diagonal(self) -> float:
        """Length (m) of the bounding-box diagonal of the vertices that faces use."""
        v = self.vertices[self.used]
        return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


def sample_surface(mesh: trimesh.Trimesh, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points (n, 3) m drawn uniformly by area on ``mesh``'s triangles with ``rng``.

    Faces are picked with probability proportional to area (inverse CDF of the cumulative
    areas), then a point uniformly inside the triangle (a, b, c) as
    a + sqrt(r1)(1 - r2)(b - a) + sqrt(r1) r2 (c - a), r1, r2 ~ U[0, 1).
    Raises ValueError if the mesh has no area.
    """
    return _Surface(mesh).sample(n, rng)


def _seed_key(seed: Any) -> tuple:
    """What identifies the stream of a seed (an int or a ``numpy.random.SeedSequence``)."""
    if isinstance(seed, np.random.SeedSequence):
        return ("seq", seed.entropy, tuple(seed.spawn_key), seed.pool_size)
    if isinstance(seed, (int, np.integer)):
        return ("int", int(seed))
    raise ValueError(f"GroundTruthSamples: seed {seed!r}; expected an int or a numpy.random.SeedSequence "
                     f"(a Generator's position is not known in advance).")


class GroundTruthSamples:
    """A ground-truth mesh's part of :func:`mesh_metrics`, prepared once for every reconstruction
    scored against it with the same ``n_samples`` and ``seed``: its checks, its bounding-box
    diagonal (m), its ``n_samples`` area-uniform samples (m), drawn from ``seed``'s generator
    after the reconstruction's (whose draws do not depend on the mesh, :meth:`_Surface.draws`),
    and their KD-tree. :func:`mesh_metrics` with ``reference=`` gives the same result, bit for
    bit, as without it, and a team's evaluation samples the ground truth and builds its tree
    once instead of once per map. ``seed``: an int or a ``numpy.random.SeedSequence``."""

    def __init__(self, gt: trimesh.Trimesh, n_samples: int, seed: int | np.random.SeedSequence = 0) -> None:
        self.mesh = gt
        self.n_samples = int(n_samples)
        self.seed_key = _seed_key(seed)
        self.n_faces = int(len(gt.faces))
        surf = _Surface(gt)
        self.problem = surf.problem("ground-truth")
        self.diagonal = math.nan
        self.points: np.ndarray | None = None
        self.tree: cKDTree | None = None
        if self.problem is None:
            self.diagonal = surf.diagonal()
            rng = np.random.default_rng(seed)
            _Surface.draws(self.n_samples, rng)  # where the reconstruction's samples come from
            self.points = surf.sample(self.n_samples, rng)
            self.tree = cKDTree(self.points)
        self.memo: dict[Any, Any] = {}
        """Whatever a caller derives from the samples alone (e.g. which robots saw each)."""


def _nan_result(reason: str, n_faces_recon: int, n_faces_gt: int, threshold_m: float) -> dict[str, Any]:
    log.warning("metrics not computed: %s", reason)
    return {"artifacts_cm": math.nan, "holes_cm": math.nan, "completion_ratio_pct": math.nan,
            "n_samples_recon": 0, "n_samples_gt": 0, "n_faces_recon": n_faces_recon,
            "n_faces_gt": n_faces_gt, "threshold_m": threshold_m, "reason": reason}


def mesh_metrics(recon: trimesh.Trimesh, gt: trimesh.Trimesh, n_samples: int = 200_000,
                 threshold_m: float = 0.05, seed: int | np.random.Generator = 0,
                 max_scale_ratio: float = 30.0, workers: int = -1,
                 gt_parts: Callable[[np.ndarray], Mapping[str, np.ndarray]] | None = None,
                 times: dict[str, float] | None = None,
                 reference: GroundTruthSamples | None = None) -> dict[str, Any]:
    """Artifacts (cm), Holes (cm) and Completion ratio (%) of ``recon`` against ``gt`` (paper
    section V), both in metres, from ``n_samples`` area-uniform samples on each mesh.

    ``seed`` is an int or a ``numpy.random.Generator``; the reconstruction is sampled first,
    then the ground truth, from the same generator. Completion counts ground-truth samples
    strictly closer than ``threshold_m`` (m).

    Returns ``{"artifacts_cm", "holes_cm", "completion_ratio_pct", "n_samples_recon",
    "n_samples_gt", "n_faces_recon", "n_faces_gt", "threshold_m", "reason"}``. ``reason`` is
    None on success. If a mesh is empty, has non-finite vertices or no area, or the two
    bounding-box diagonals differ by more than ``max_scale_ratio`` (meshes in different
    units: cm or mm against m), the three metrics are NaN and ``reason`` says why in one
    sentence; nothing is raised.

    ``gt_parts(points)`` (optional) maps the ground-truth samples (N, 3) to named boolean
    masks; for each part ``name`` the result adds ``share_pct_<name>`` (% of the samples in
    the part), ``completion_ratio_pct_<name>`` and ``holes_cm_<name>`` restricted to it (NaN
    for an empty part).

    ``times`` (optional dict): wall-clock seconds added per stage, ``sampling`` (the checks and
    both meshes' samples), ``distances`` (the two KD-trees and their nearest-neighbour queries)
    and ``parts`` (``gt_parts`` and the per-part figures).

    ``reference`` (optional): ``gt`` prepared by :class:`GroundTruthSamples` with the same
    ``n_samples`` and ``seed`` (then an int or a SeedSequence): the same result, without
    sampling ``gt`` and building its tree again.
    """
    t0 = time.perf_counter()
    n_faces_recon, n_faces_gt = int(len(recon.faces)), int(len(gt.faces))
    if not (isinstance(n_samples, (int, np.integer)) and n_samples >= 1):
        raise ValueError(f"mesh_metrics: n_samples = {n_samples!r}; expected a positive integer.")
    if not (np.isfinite(threshold_m) and threshold_m > 0):
        raise ValueError(f"mesh_metrics: threshold_m = {threshold_m!r}; expected a positive distance in metres.")
    if reference is not None and (reference.mesh is not gt or reference.n_samples != int(n_samples)
                                  or reference.seed_key != _seed_key(seed)):
        raise ValueError("mesh_metrics: reference was prepared for another ground-truth mesh, n_samples or "
                         "seed; expected GroundTruthSamples(gt, n_samples, seed) of this call's arguments.")
    surf_recon = _Surface(recon)
    surf_gt = _Surface(gt) if reference is None else None
    problem = surf_recon.problem("reconstructed")
    if problem is None:
        problem = surf_gt.problem("ground-truth") if surf_gt is not None else reference.problem
    if problem is not None:
        return _nan_result(problem, n_faces_recon, n_faces_gt, threshold_m)
    d_recon = surf_recon.diagonal()
    d_gt = surf_gt.diagonal() if surf_gt is not None else reference.diagonal
    ratio = max(d_recon, d_gt) / max(min(d_recon, d_gt), 1e-300)
    if ratio > max_scale_ratio:
        return _nan_result(
            f"the bounding-box diagonals differ {ratio:.0f}-fold (reconstruction {d_recon:.4g}, ground "
            f"truth {d_gt:.4g}); the meshes look like they are in different units (m against cm or "
            f"mm) -- expected both in metres (ratio at most {max_scale_ratio:g}).",
            n_faces_recon, n_faces_gt, threshold_m)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    p_recon = surf_recon.sample(int(n_samples), rng)
    if reference is None:
        p_gt = surf_gt.sample(int(n_samples), rng)
        tree_gt = None
    else:
        p_gt, tree_gt = reference.points, reference.tree
    t0 = add_time(times, "sampling", t0)
    dist_r2g, _ = (tree_gt if tree_gt is not None else cKDTree(p_gt)).query(p_recon, k=1, workers=workers)
    dist_g2r, _ = cKDTree(p_recon).query(p_gt, k=1, workers=workers)
    t0 = add_time(times, "distances", t0)
    parts: dict[str, float] = {}
    for name, mask in (gt_parts(p_gt) if gt_parts is not None else {}).items():
        mask = np.asarray(mask, dtype=bool)
        sub = dist_g2r[mask]
        parts[f"share_pct_{name}"] = float(mask.mean() * 100.0)
        parts[f"completion_ratio_pct_{name}"] = float(np.mean(sub < threshold_m) * 100.0) if len(sub) else math.nan
        parts[f"holes_cm_{name}"] = float(np.mean(sub) * 100.0) if len(sub) else math.nan
    add_time(times, "parts", t0)
    return {
        **parts,
        "artifacts_cm": float(np.mean(dist_r2g) * 100.0),
        "holes_cm": float(np.mean(dist_g2r) * 100.0),
        "completion_ratio_pct": float(np.mean(dist_g2r < threshold_m) * 100.0),
        "n_samples_recon": int(len(p_recon)),
        "n_samples_gt": int(len(p_gt)),
        "n_faces_recon": n_faces_recon,
        "n_faces_gt": n_faces_gt,
        "threshold_m": float(threshold_m),
        "reason": None,
    }
