"""Scoring agents' maps during and after a run with the paper's metrics (section V):
mesh from the map's SDF, culling of both meshes to what the robots' cameras saw, then
Artifacts / Holes / Completion ratio against the scene's ground truth."""
from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
import trimesh

from ramensim.core.results import METRIC_KEYS
from ramensim.evaluation.config import EvalConfig
from ramensim.evaluation.coverage import area, far_part, own_and_near, seen_by_agent
from ramensim.evaluation.cull import (OccluderDepths, PinholeCamera, SeenBlocks, TestedPoses, cull_mesh,
                                      cull_to_views, max_edge_length, subdivide, visible_points)
from ramensim.evaluation.mesh import NarrowBand, RegionFn, add_time, export_ply, extract_mesh
from ramensim.evaluation.metrics import GroundTruthSamples, mesh_metrics
from ramensim.world import World

log = logging.getLogger(__name__)

MASK_CELL_M = 0.1
"""Cell (m) of the observed-space grid of ``evaluation.mask_unobserved``: coarse, so that the
test costs (bounds / 0.1 m)^3 points x frames, not a point per marching-cubes voxel."""

STAGES = ("sdf_grid", "mask", "marching_cubes", "colours", "export", "mesh_cull", "gt_cull", "sampling",
          "distances", "coverage", "unseen_part")
"""The stages of an evaluation whose wall-clock seconds :class:`Evaluator` records, in the
order they run: per map the SDF on the grid, the observation mask (``mask_unobserved``),
marching cubes, vertex colours, the PLY (periodic evaluations), culling the map's mesh; once
per evaluation culling the ground truth (team coverage included); per map the metric samples
on both meshes (the ground truth's, with their KD-tree, once per culled ground truth), the
nearest-neighbour distances, which robots saw each ground-truth sample (coverage) and the own /
unseen / far parts' figures."""


class Evaluator:
    """Evaluates maps of one run's world according to ``cfg`` (an EvalConfig).

    ``neighbours``: per robot, its neighbours on the communication graph, for the far-part
    metrics (:func:`ramensim.evaluation.coverage.far_part`); None when the graph changes with
    time (a disk topology): those metrics are then left out with ``far_reason``."""

    def __init__(self, cfg: EvalConfig, world: World, seed: int = 0,
                 start_delays: list[float] | None = None,
                 neighbours: Sequence[Sequence[int]] | None = None) -> None:
        self.cfg = cfg
        self.world = world
        self.seed = seed
        self.neighbours = None if neighbours is None else [sorted(int(j) for j in nb) for nb in neighbours]
        self.start_delays = start_delays or [0.0] * world.n_agents
        K = world.intrinsics
        self.camera = PinholeCamera.of(K, cfg.near_m, cfg.far_m)
        self._seen_cache: tuple[tuple, np.ndarray] | None = None
        # the ground truth's depth images per pose, shared by every visibility test of the run
        self._depths = (OccluderDepths(world.scene.mesh, self.camera, cfg.occlusion_stride_px)
                        if world.scene is not None and cfg.cull == "frustum_occlusion" else None)
        # incremental culling of the (subdivided) ground truth: which of its vertices the poses
        # tested so far saw; the mask only grows as poses are added
        self._gt_dense: trimesh.Trimesh | None = None
        self._gt_vertex_seen: np.ndarray | None = None
        self._gt_poses = TestedPoses()
        self._gt_culled: trimesh.Trimesh | None = None
        self._gt_seen_count = -1
        # the culled ground truth's metric samples and their KD-tree, for every map scored
        # against that same culled mesh (one team's evaluation, or later ones that saw no more)
        self._gt_reference: GroundTruthSamples | None = None
        self._mask_depths: OccluderDepths | None = None
        # periodic evaluations: the blocks of the narrow band's coarse grid some pose may see
        # (made here, not on first use: a team's maps are extracted on several threads at once)
        self._seen_blocks = SeenBlocks(self.camera, self._depths, cfg.occlusion_eps_m)
        self.stage_records: list[dict[str, Any]] = []
        """One record per evaluation (:meth:`record_evaluation`): its wall-clock cost per stage."""
        self.periodic_taken = 0
        """Periodic evaluations sampled so far (:meth:`periodic_sample`)."""

    @classmethod
    def for_scenario(cls, sc: Any, world: World) -> "Evaluator":
        """The evaluator of a run of scenario ``sc`` in its built ``world``: its evaluation
        settings, seed, robots' start delays and, on a fixed graph, each robot's neighbours."""
        from ramensim.channels.topology import Topology

        n = sc.agents.count
        topology = Topology(sc.topology, n, position=world.position)
        neighbours = None if topology.dynamic else [topology.neighbours(a) for a in range(n)]
        return cls(sc.evaluation, world, seed=sc.seed, start_delays=[sc.agents.start_delay(a) for a in range(n)],
                   neighbours=neighbours)

    @property
    def can_score(self) -> bool:
        """False when the world has no ground-truth mesh (a dataset without one)."""
        return self.world.scene is not None

    def poses_by_agent_until(self, t: float) -> list[np.ndarray]:
        """Per robot, the camera-to-world poses (N_a, 4, 4) of the frames it took up to ``t`` (s)."""
        return [np.asarray([c2w for (tt, c2w) in self.world.frames_for(a) if tt + self.start_delays[a] <= t],
                           dtype=np.float64).reshape(-1, 4, 4) for a in range(self.world.n_agents)]

    def poses_until(self, t: float) -> np.ndarray:
        """Camera-to-world poses (N, 4, 4) of every frame any robot took up to ``t`` (s)."""
        return np.concatenate(self.poses_by_agent_until(t), axis=0)

    def team_coverage_pct(self, poses: np.ndarray, times: dict[str, float] | None = None) -> float:
        """Share (%) of the whole ground-truth surface (area) that any robot saw: the area of
        the culled ground truth over the area of the full one (NaN without ground truth).
        ``times``: wall-clock seconds added to its ``gt_cull`` stage (:data:`STAGES`)."""
        if not self.can_score or self.cfg.cull == "none":
            return math.nan
        t0 = time.perf_counter()
        full = area(self.world.scene.mesh)
        culled = area(self._culled_gt(poses))
        add_time(times, "gt_cull", t0)
        return 100.0 * culled / full if full > 0 else math.nan

    def periodic_sample(self, live: Sequence[int]) -> list[int]:
        """The maps (of ``live``, in map order) the next periodic evaluation scores: all of them,
        or with ``evaluation.periodic.robots`` = n a window of n maps that starts n maps further on
        at every periodic evaluation and wraps around (a robot is scored every ceil(len / n)
        evaluations, one in turn); counts the evaluation."""
        live = list(live)
        n = self.cfg.periodic.robots
        taken, self.periodic_taken = self.periodic_taken, self.periodic_taken + 1
        if n is None or n >= len(live):
            return live
        start = (taken * n) % len(live)
        chosen = {live[(start + i) % len(live)] for i in range(n)}
        return [k for k in live if k in chosen]

    def record_evaluation(self, t: float, times: dict[str, float], wall_s: float, maps: int,
                          final: bool = False) -> dict[str, Any]:
        """Keep (:attr:`stage_records`) and return the cost record of one evaluation taken at
        simulated time ``t`` (s) of ``maps`` maps: ``wall_s`` (s, the whole evaluation) and
        ``stage_s``, the wall-clock seconds of each stage of :data:`STAGES` that ran, summed
        over the maps (the meshes are extracted on several threads at once, so the per-map
        stages can add up to more than ``wall_s``); ``final`` for the run's last evaluation.
        Wall-clock figures: not reproducible, never part of the results."""
        record = {"t": float(t), "final": bool(final), "maps": int(maps), "wall_s": round(float(wall_s), 4),
                  "stage_s": {k: round(float(times[k]), 4) for k in STAGES if k in times}}
        self.stage_records.append(record)
        return record

    def _seen(self, points: np.ndarray, poses_by_agent: list[np.ndarray]) -> np.ndarray:
        """(n_robots, N) visibility of ground-truth samples, cached for the same samples."""
        key = (len(points), sum(len(p) for p in poses_by_agent), points[:1].tobytes(), points[-1:].tobytes())
        if self._seen_cache is None or self._seen_cache[0] != key:
            seen = seen_by_agent(points, poses_by_agent, self.camera, occluder=self._depths,
                                 eps_m=self.cfg.occlusion_eps_m, stride=self.cfg.occlusion_stride_px)
            self._seen_cache = (key, seen)
        return self._seen_cache[1]

    def seen(self, points: np.ndarray, poses_by_agent: list[np.ndarray]) -> np.ndarray:
        """(n_robots, N) visibility of the ground-truth samples ``points`` ((N, 3), m) from each
        robot's poses, as the far-part metrics test it (``evaluation.cull``'s frustum and occlusion
        test); cached for the same samples and number of poses."""
        return self._seen(points, poses_by_agent)

    def visible(self, points: np.ndarray, poses_by_agent: list[np.ndarray]) -> np.ndarray:
        """(n_robots, N) visibility of ``points`` ((N, 3), m) from each robot's poses by the same
        test as :meth:`seen`, uncached (e.g. for the poses of one window of time at a time)."""
        return seen_by_agent(points, poses_by_agent, self.camera, occluder=self._depths,
                             eps_m=self.cfg.occlusion_eps_m, stride=self.cfg.occlusion_stride_px)

    def culled_ground_truth(self, poses: np.ndarray) -> trimesh.Trimesh:
        """The ground-truth mesh culled to what the camera-to-world ``poses`` ((N, 4, 4)) saw,
        as a map is scored against it (the whole mesh without culling or poses)."""
        return self._culled_gt(poses)

    def cull(self, mesh: trimesh.Trimesh, poses: np.ndarray) -> trimesh.Trimesh:
        """``mesh`` culled to what the camera-to-world ``poses`` ((N, 4, 4)) saw, as a map's mesh
        is culled before it is scored (unchanged without culling or poses)."""
        return self._cull(mesh, poses)

    def observed_fn(self, poses: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """``evaluation.mask_unobserved``: a function of (N, 3) points (m) -> True where some
        frame of ``poses`` observed the space, the NICE-SLAM / Co-SLAM "mask of unobserved
        regions": a cell of a :data:`MASK_CELL_M` grid over the world bounds is observed when its
        centre lies inside a frame's frustum (the camera's near and far planes) and no deeper
        than that frame's depth image (rendered from the scene the camera images, as the
        sensor saw it) plus ``occlusion_eps_m`` and half the cell's diagonal; the observed cells
        are dilated by one cell so that a seen surface at a cell's edge is never cut. A map's
        surface beyond everything its cameras saw (inside walls, behind furniture, outside the
        rooms) then produces no faces."""
        from scipy.ndimage import binary_dilation

        from ramensim.evaluation.mesh import grid_shape

        b = np.asarray(self.world.bounds, dtype=np.float64)
        shape = grid_shape(b, MASK_CELL_M)
        axes = [b[0, i] + MASK_CELL_M * (np.arange(shape[i]) + 0.5) for i in range(3)]
        centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        if self.world.scene is not None and self._mask_depths is None:
            self._mask_depths = self._depths or OccluderDepths(self.world.scene.mesh, self.camera,
                                                               self.cfg.occlusion_stride_px)
        seen = visible_points(centres, poses, self.camera, occluder=self._mask_depths,
                              eps_m=self.cfg.occlusion_eps_m + 0.5 * math.sqrt(3) * MASK_CELL_M,
                              stride=self.cfg.occlusion_stride_px) if len(poses) else np.zeros(len(centres), bool)
        grid = binary_dilation(seen.reshape(shape), iterations=1)
        top = np.array(shape) - 1

        def observed(points: np.ndarray) -> np.ndarray:
            idx = np.floor((np.asarray(points, dtype=np.float64) - b[0]) / MASK_CELL_M).astype(np.int64)
            idx = np.clip(idx, 0, top)
            return grid[idx[:, 0], idx[:, 1], idx[:, 2]]
        return observed

    @property
    def periodic_band(self) -> NarrowBand | None:
        """The periodic evaluations' coarse-to-fine extraction (``evaluation.periodic``), or None
        when they extract densely as the final evaluation always does."""
        p = self.cfg.periodic
        if p.extraction != "narrow_band":
            return None
        return NarrowBand(factor=p.coarse_factor, band_m=p.band_m, dilate=p.dilate)

    def periodic_region(self, poses: np.ndarray) -> RegionFn | None:
        """The coarse cells a periodic evaluation's narrow band refines, given every robot's
        ``poses`` so far ((N, 4, 4)): those some pose may see (:class:`SeenBlocks`, kept across
        evaluations), as the map's mesh is culled to those poses afterwards; None (every cell)
        without ``evaluation.periodic.skip_unseen``, a narrow band, culling or poses."""
        p = self.cfg.periodic
        if p.extraction != "narrow_band" or not p.skip_unseen or self.cfg.cull == "none" or len(poses) == 0:
            return None
        if self._seen_blocks.eps_m != self.cfg.occlusion_eps_m:  # settings replaced since (benchmarks)
            self._seen_blocks = SeenBlocks(self.camera, self._depths, self.cfg.occlusion_eps_m)
        blocks = self._seen_blocks
        return lambda origin, cell_m, shape: blocks.cells(origin, cell_m, shape, poses)

    def mesh_of(self, neural_map: Any, voxel_m: float | None = None,
                poses: np.ndarray | None = None, times: dict[str, float] | None = None,
                band: NarrowBand | None = None, region: RegionFn | None = None,
                colours: bool = True) -> trimesh.Trimesh:
        """Marching-cubes mesh of a map's SDF (level 0) over the world bounds, coloured by
        its colour decoder; ``voxel_m`` in metres (default the config's). With
        ``evaluation.mask_unobserved`` and the ``poses`` of the frames that fed the map, cells
        those frames never observed produce no faces (:meth:`observed_fn`). ``times``: wall-clock
        seconds added per stage (:func:`ramensim.evaluation.mesh.extract_mesh`). ``band``: a
        coarse-to-fine extraction (:class:`ramensim.evaluation.mesh.NarrowBand`; periodic
        evaluations only), None = the SDF on every grid point; ``region``: the band's coarse cells
        that may keep a surface (:meth:`periodic_region`). ``colours``: False leaves the vertices
        uncoloured (no metric reads colours; a mesh neither saved nor kept needs none)."""
        def sdf_fn(p: np.ndarray) -> np.ndarray:  # the grid needs no colours (a map's sdf() skips them)
            return neural_map.sdf(p) if hasattr(neural_map, "sdf") else neural_map.sdf_and_color(p)[0]

        def color_fn(p: np.ndarray) -> np.ndarray:
            return neural_map.sdf_and_color(p)[1]

        mask_fn = self.observed_fn(poses) if self.cfg.mask_unobserved and poses is not None else None
        return extract_mesh(sdf_fn, self.world.bounds, voxel_m or self.cfg.voxel_m,
                            color_fn=color_fn if colours else None,
                            mask_fn=mask_fn, chunk=self.cfg.chunk_points,
                            grid_fn=getattr(neural_map, "sdf_grid", None), times=times, band=band,
                            region=region if band is not None else None)

    def nan_metrics(self, reason: str) -> dict[str, Any]:
        out: dict[str, Any] = {k: math.nan for k in METRIC_KEYS}
        out["reason"] = reason
        return out

    def _culled_gt(self, poses: np.ndarray) -> trimesh.Trimesh:
        """The ground truth culled to what ``poses`` saw. Visibility is an OR over poses, so
        only poses not tested at an earlier evaluation are tested, on the vertices still unseen."""
        assert self.world.scene is not None
        gt = self.world.scene.mesh
        if self.cfg.cull == "none" or len(poses) == 0:
            return gt
        if self._gt_dense is None:
            edge = self.cfg.cull_max_edge_m
            self._gt_dense = subdivide(gt, edge) if edge is not None and max_edge_length(gt) > edge else gt
            self._gt_vertex_seen = np.zeros(len(self._gt_dense.vertices), dtype=bool)
        assert self._gt_vertex_seen is not None
        restart, new, keys = self._gt_poses.untested(poses)
        if restart:  # fewer poses than before: start again
            self._gt_vertex_seen[:] = False
            self._gt_culled = None
        if new or self._gt_culled is None:
            todo = np.flatnonzero(~self._gt_vertex_seen)
            if new and len(todo):
                hit = visible_points(self._gt_dense.vertices[todo], poses[new], self.camera, occluder=self._depths,
                                     eps_m=self.cfg.occlusion_eps_m, stride=self.cfg.occlusion_stride_px)
                self._gt_vertex_seen[todo[hit]] = True
            self._gt_poses.add(keys[i] for i in new)
            count = int(self._gt_vertex_seen.sum())
            if self._gt_culled is None or count != self._gt_seen_count:  # the mask only grows: same count, same mask
                self._gt_culled = cull_mesh(self._gt_dense, self._gt_vertex_seen)
                self._gt_seen_count = count
        return self._gt_culled

    def _metric_seed(self) -> np.random.SeedSequence:
        """The seed of every map's metric samples (the run's seed and ``evaluation.seed``)."""
        return np.random.SeedSequence([self.seed, self.cfg.seed])

    def _reference(self, gt: trimesh.Trimesh) -> GroundTruthSamples:
        """The metric samples of the (culled) ground truth ``gt`` and their KD-tree, prepared
        once per distinct culled mesh (:class:`ramensim.evaluation.metrics.GroundTruthSamples`):
        every map of an evaluation, and later evaluations whose poses saw nothing new, reuse them."""
        ref = self._gt_reference
        if ref is None or ref.mesh is not gt:
            ref = self._gt_reference = GroundTruthSamples(gt, self.cfg.n_samples, self._metric_seed())
        return ref

    def _cull(self, mesh: trimesh.Trimesh, poses: np.ndarray) -> trimesh.Trimesh:
        if self.cfg.cull == "none" or len(poses) == 0:
            return mesh
        return cull_to_views(mesh, poses, self.camera, occluder=self._depths, eps_m=self.cfg.occlusion_eps_m,
                             stride=self.cfg.occlusion_stride_px, max_edge_m=self.cfg.cull_max_edge_m)

    def extract(self, neural_map: Any, poses_by_agent: list[np.ndarray], fed_by: Sequence[int],
                times: dict[str, float] | None = None, periodic: bool = False,
                colours: bool = True) -> trimesh.Trimesh:
        """The mesh :meth:`score` scores for a map fed by robots ``fed_by``: it reads only the map
        (and, with ``evaluation.mask_unobserved``, the observation mask of those robots' poses),
        so the maps of a team can be extracted on several threads at once (each with its own
        ``times``). ``periodic``: a periodic evaluation's extraction (``evaluation.periodic``,
        :attr:`periodic_band`); else the exact one, every grid point. ``colours``: as
        :meth:`mesh_of`'s."""
        fed = [poses_by_agent[a] for a in fed_by if 0 <= a < len(poses_by_agent)]
        region = self.periodic_region(np.concatenate(poses_by_agent, axis=0)) if periodic and poses_by_agent else None
        return self.mesh_of(neural_map, voxel_m=self.cfg.periodic.voxel_m if periodic else None,
                            poses=np.concatenate(fed, axis=0) if fed else np.zeros((0, 4, 4)),
                            times=times, band=self.periodic_band if periodic else None, region=region,
                            colours=colours)

    def score_all(self, items: Sequence[tuple[Any, Sequence[int], Path | None]], poses_by_agent: list[np.ndarray],
                  run: Callable[[Callable[[Any], Any], list[Any]], list[Any]] | None = None,
                  on_mesh: Callable[[int, trimesh.Trimesh], None] | None = None,
                  at_once: int | None = None, times: dict[str, float] | None = None,
                  periodic: bool = False, overlap: bool = False) -> list[dict[str, Any]]:
        """:meth:`score` of several maps ``(map, fed_by, mesh_path)``: their meshes extracted by
        ``run(fn, items)`` (a parallel map, e.g. the team engine's workers; default in turn),
        ``at_once`` maps at a time (default all), then culled and scored in order on this thread
        (the culling caches are shared) and let go before the next maps' meshes are extracted,
        so a team's evaluation holds ``at_once`` meshes, not one per robot. The same results as
        scoring each map in turn. ``times``: wall-clock seconds added per stage (:data:`STAGES`),
        summed over the maps. ``periodic``: a periodic evaluation (:meth:`extract`'s); the final
        one passes False and is always extracted on the full grid. ``overlap`` (with ``run``):
        the next ``at_once`` maps are extracted while this thread scores the previous ones, so
        ``run``'s workers do not wait for the serial culling and metrics (the final evaluation
        of a team, when nothing else runs); at most two chunks' meshes are held, and the
        results are the same (extraction reads only the map, and the scoring order is kept)."""
        if self.cfg.mask_unobserved and self.world.scene is not None and self._mask_depths is None:
            self._mask_depths = self._depths or OccluderDepths(self.world.scene.mesh, self.camera,
                                                               self.cfg.occlusion_stride_px)
        items = list(items)
        step = max(1, at_once or len(items))
        chunks = [items[start:start + step] for start in range(0, len(items), step)]
        each = run or (lambda fn, xs: [fn(x) for x in xs])
        band = {"periodic": True} if periodic else {}  # the final's call as it always was
        # vertex colours only for a mesh that is saved or handed on (no metric reads them)
        coloured = on_mesh is not None

        def extract(chunk: list) -> tuple[list[dict[str, float]], list[trimesh.Trimesh]]:
            own: list[dict[str, float]] = [{} for _ in chunk]  # one per thread: merged by the scorer
            meshes = each(lambda job: self.extract(job[0][0], poses_by_agent, job[0][1], times=job[1],
                                                   colours=coloured or (job[0][2] is not None
                                                                        and self.cfg.export_mesh), **band),
                          list(zip(chunk, own)))
            return own, meshes

        ahead = None
        if overlap and run is not None and len(chunks) > 1:
            from concurrent.futures import ThreadPoolExecutor
            ahead = ThreadPoolExecutor(1, thread_name_prefix="ramensim-extract")
        out: list[dict[str, Any]] = []
        try:
            pending = ahead.submit(extract, chunks[0]) if ahead is not None else None
            for c, chunk in enumerate(chunks):
                own, meshes = pending.result() if pending is not None else extract(chunk)
                pending = (ahead.submit(extract, chunks[c + 1])
                           if ahead is not None and c + 1 < len(chunks) else None)
                for stage_s in own:
                    for k, v in stage_s.items():
                        if times is not None:
                            times[k] = times.get(k, 0.0) + v
                for i, ((_, fed_by, mesh_path), mesh) in enumerate(zip(chunk, meshes), c * step):
                    out.append(self.score(None, poses_by_agent, fed_by, mesh_path=mesh_path,
                                          on_mesh=(lambda m, i=i: on_mesh(i, m)) if on_mesh else None, mesh=mesh,
                                          times=times))
                del meshes, mesh  # nothing of this chunk outlives it
        finally:
            if ahead is not None:
                ahead.shutdown(wait=True)
        return out

    def score(self, neural_map: Any, poses_by_agent: list[np.ndarray], fed_by: Sequence[int],
              mesh_path: Path | None = None,
              on_mesh: Callable[[trimesh.Trimesh], None] | None = None,
              mesh: trimesh.Trimesh | None = None, times: dict[str, float] | None = None) -> dict[str, Any]:
        """Extract, optionally save (PLY), cull and score one map fed by the cameras of robots
        ``fed_by`` (one robot, or all of them for the centralised learner), given every
        robot's poses so far. Adds the coverage metrics of :mod:`ramensim.evaluation.coverage`:
        ``own_coverage_pct``, ``completion_own_pct``/``holes_own_cm`` on what the map's own
        cameras saw, ``completion_unseen_pct``/``holes_unseen_cm`` on what only teammates saw
        (``unseen_share_pct`` of the evaluated surface; None with ``unseen_reason`` when that
        part is empty), and ``completion_far_pct``/``holes_far_cm`` on what only robots beyond
        the map's graph neighbours saw (``far_share_pct``; None with ``far_reason`` when that
        part is empty or the graph changes with time). Never raises on a bad map: an empty or non-finite mesh gives NaN
        metrics with a ``reason``. With ``evaluation.mask_unobserved`` the mesh keeps only what
        the frames of ``fed_by`` observed (:meth:`observed_fn`). ``mesh``: the map's mesh when
        already extracted (:meth:`extract`; ``neural_map`` is then not read). ``times``: wall-clock
        seconds added per stage (:data:`STAGES`)."""
        if mesh is None:
            mesh = self.extract(neural_map, poses_by_agent, fed_by, times=times,
                                colours=on_mesh is not None or (mesh_path is not None and self.cfg.export_mesh))
        if on_mesh is not None:
            on_mesh(mesh)
        if mesh_path is not None and self.cfg.export_mesh:
            t0 = time.perf_counter()
            try:  # atomic; a file that cannot be written (a full disk) never stops the scoring
                export_ply(mesh, mesh_path)
            except OSError as exc:
                log.error("mesh not saved: %s", exc)
            add_time(times, "export", t0)
        return self.score_mesh(mesh, poses_by_agent, fed_by, times=times)

    def score_mesh(self, mesh: trimesh.Trimesh, poses_by_agent: list[np.ndarray],
                   fed_by: Sequence[int], times: dict[str, float] | None = None) -> dict[str, Any]:
        """:meth:`score` of an extracted (uncut) mesh in metres, e.g. a run's saved
        ``mesh_<map>.ply`` (``ramensim eval --run``). ``times``: wall-clock seconds added per
        stage (:data:`STAGES`)."""
        if not self.can_score:
            return self.nan_metrics("the world has no ground-truth mesh to compare against")
        t0 = time.perf_counter()
        poses = np.concatenate(poses_by_agent, axis=0)
        gt = self._culled_gt(poses)
        t0 = add_time(times, "gt_cull", t0)
        recon = self._cull(mesh, poses)
        add_time(times, "mesh_cull", t0)
        own, near = own_and_near(len(poses_by_agent), fed_by, self.neighbours)
        stage_s: dict[str, float] = {}

        def parts(points: np.ndarray) -> dict[str, np.ndarray]:
            t1 = time.perf_counter()
            seen = self._seen(points, poses_by_agent)
            add_time(stage_s, "coverage", t1)
            mine = seen[own].any(axis=0)
            out = {"own": mine, "unseen": seen[~own].any(axis=0) & ~mine}
            if near is not None:
                out["far"] = far_part(seen, near)
            return out

        t1 = time.perf_counter()
        reference = self._reference(gt)
        add_time(stage_s, "sampling", t1)
        result = mesh_metrics(recon, gt, n_samples=self.cfg.n_samples, threshold_m=self.cfg.threshold_m,
                              seed=self._metric_seed(), gt_parts=parts, times=stage_s, reference=reference)
        if times is not None:  # the parts' figures without the visibility test inside them
            stage_s["unseen_part"] = stage_s.pop("parts", 0.0) - stage_s.get("coverage", 0.0)
            for k, v in stage_s.items():
                times[k] = times.get(k, 0.0) + v
        result["n_faces_mesh"] = int(len(mesh.faces))
        if result.get("reason"):
            log.warning("metrics: %s", result["reason"])
            return result
        out = {k: v for k, v in result.items() if not k.startswith(("share_pct_", "completion_ratio_pct_",
                                                                     "holes_cm_"))}
        out["own_coverage_pct"] = result["share_pct_own"]
        out["completion_own_pct"] = result["completion_ratio_pct_own"]
        out["holes_own_cm"] = result["holes_cm_own"]
        out["unseen_share_pct"] = result["share_pct_unseen"]
        out["completion_unseen_pct"] = result["completion_ratio_pct_unseen"]
        out["holes_unseen_cm"] = result["holes_cm_unseen"]
        if not result["share_pct_unseen"] > 0:
            out["unseen_reason"] = ("no teammate saw ground truth that this map's cameras did not"
                                    if (~own).any() else "a single learner fed by every camera has no unseen part")
        if near is None:
            out["far_reason"] = "the communication graph changes with time (disk topology): no fixed neighbours"
        else:
            out["far_share_pct"] = result["share_pct_far"]
            out["completion_far_pct"] = result["completion_ratio_pct_far"]
            out["holes_far_cm"] = result["holes_cm_far"]
            if not result["share_pct_far"] > 0:
                out["far_reason"] = ("every robot is this map's own or a neighbour on the communication graph"
                                     if near.all() else "no robot beyond the neighbours saw ground truth that they did not")
        return out
