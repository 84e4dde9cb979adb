"""Culling a map's mesh late in a long run: the visibility test of every (subdivided) vertex
against every camera pose so far (docs/ALGORITHM.md section 5), point by point against the
clustered kernel (cubes of ``CLUSTER_M`` m skipped for the poses whose frustum misses them).

Needs a finished run folder with its meshes (``mesh_<agent>.ply``) and ``scenario.yaml``, e.g.
a 600-s house run or a point of the paper-horizon sweeps:

    ramensim run scenarios/house_3agents.yaml --set duration=600 --set recording.mode=off --out runs/house600
    PYTHONPATH=. python benchmarks/bench_cull_long.py runs/house600 [--at 570] [--repeats 2]
    PYTHONPATH=. python benchmarks/bench_cull_long.py RUN --meshes 3 --hints 0,8 [--repeats 3]
    PYTHONPATH=. python benchmarks/bench_cull_long.py RUN --meshes 3 --keyframes 5

Prints both times, their ratio, and checks the two masks are equal; poses are those every
robot took up to ``--at`` simulated seconds (default: the run's duration). ``--hints 0,8``
instead compares builds of the clustered kernel that try that many recent poses first
(``N_HINTS``; 0 = the poses in order only): CPU seconds of culling the meshes, builds
alternated, and their masks equal. ``--keyframes K`` instead scores each mesh (the run's metric
settings) culled to every pose and to every K-th pose of each robot, against the ground truth
culled to every pose and to the same K-th poses: the completion an approximation by keyframes
would report, and the culling's CPU seconds.
"""
from __future__ import annotations

import argparse
import logging
import os
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", help="a finished run folder with scenario.yaml and mesh_*.ply")
    ap.add_argument("--at", type=float, default=None, help="simulated time of the poses (s)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--meshes", type=int, default=1, help="how many of the run's meshes to cull (default 1)")
    ap.add_argument("--hints", default=None, help="compare kernel builds with these N_HINTS, e.g. 0,8")
    ap.add_argument("--keyframes", type=int, default=None, help="compare culling to every K-th pose")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    from ramensim.core.native import prefer_passive_openmp

    prefer_passive_openmp()
    from benchmarks._machine import machine_info
    from ramensim.config import load_scenario
    from ramensim.scoring import Evaluator
    from ramensim.evaluation.cull import CLUSTER_M, max_edge_length, subdivide, visible_points
    from ramensim.evaluation.mesh import load_mesh
    from ramensim.core.seeding import Seeds
    from ramensim.world.world import build_world

    run = Path(args.run)
    sc = load_scenario(run / "scenario.yaml")
    world = build_world(sc.world, sc.agents.count, sc.duration, Seeds(sc.seed).numpy)  # as ramensim.sim does
    ev = Evaluator.for_scenario(sc, world)
    t = sc.duration if args.at is None else args.at
    poses = ev.poses_until(t)
    cfg = sc.evaluation
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    if ev._depths is not None:  # the ground truth's depth image per pose, as a run keeps them
        for c2w in poses:
            ev._depths(c2w)
    print(f"{len(poses):,} depth images of the ground truth rendered in {time.perf_counter() - t0:.1f} s "
          f"(once per pose and run; not in the timings below)")
    if args.keyframes:
        compare_keyframes(sc, world, t, sorted(run.glob("mesh_*.ply"))[:args.meshes], args.keyframes)
        print(machine_info())
        return
    if args.hints:
        compare_hints(ev, poses, sorted(run.glob("mesh_*.ply"))[:args.meshes],
                      [int(h) for h in args.hints.split(",")], args.repeats)
        print(f"load average: {load0:.2f} at start, {os.getloadavg()[0]:.2f} at end")
        print(machine_info())
        return
    for mesh_path in sorted(run.glob("mesh_*.ply"))[:args.meshes]:
        mesh = load_mesh(mesh_path)
        if cfg.cull_max_edge_m is not None and max_edge_length(mesh) > cfg.cull_max_edge_m:
            mesh = subdivide(mesh, cfg.cull_max_edge_m)
        times, masks = {}, {}
        for name, cm in ((f"clusters of {CLUSTER_M} m", CLUSTER_M), ("per point", 0.0)):
            best = float("inf")
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                masks[name] = visible_points(mesh.vertices, poses, ev.camera, occluder=ev._depths,
                                             eps_m=cfg.occlusion_eps_m, stride=cfg.occlusion_stride_px,
                                             cluster_m=cm)
                best = min(best, time.perf_counter() - t0)
            times[name] = best
        a, b = masks.values()
        same = bool(np.array_equal(a, b))
        (n2, t2), (n1, t1) = times.items()
        print(f"{mesh_path.name}: {len(mesh.vertices):,} vertices after subdivision, {len(poses):,} poses "
              f"(t <= {t:.0f} s), {100 * a.mean():.1f} % seen; {n1} {t1:.2f} s, {n2} {t2:.2f} s: "
              f"{t1 / t2:.1f}x; masks equal: {same} (best of {args.repeats})")
        if not same:
            raise SystemExit("the two kernels disagree")
    print(f"load average: {load0:.2f} at start, {os.getloadavg()[0]:.2f} at end")
    print(machine_info())


def compare_hints(ev, poses: np.ndarray, mesh_paths: list[Path], hints: list[int], repeats: int) -> None:
    """CPU seconds of culling ``mesh_paths``' vertices with kernel builds of each N_HINTS, the builds
    alternated (forward, then backward) ``repeats`` times; the masks must be equal."""
    from ramensim.core.native import BASE_FLAGS, compile_shared, declare, with_march
    from ramensim.evaluation import _native
    from ramensim.evaluation.cull import visible_points
    from ramensim.evaluation.mesh import load_mesh

    libs = {}
    for h in hints:
        lib = compile_shared(_native.SOURCE, f"visibility_hints{h}", with_march(BASE_FLAGS), defines={"N_HINTS": h})
        declare(lib, _native.SIGNATURES)
        libs[h] = lib
    meshes = [np.asarray(load_mesh(p).vertices) for p in mesh_paths]
    cfg = ev.cfg
    cpu: dict[int, list[float]] = {h: [] for h in hints}
    masks: dict[int, list[np.ndarray]] = {}
    original = _native.get_lib
    try:
        for r in range(repeats):
            for h in (hints if r % 2 == 0 else hints[::-1]):
                _native.get_lib = lambda lib=libs[h]: lib
                c0 = time.process_time()
                got = [visible_points(v, poses, ev.camera, occluder=ev._depths, eps_m=cfg.occlusion_eps_m,
                                      stride=cfg.occlusion_stride_px) for v in meshes]
                cpu[h].append(time.process_time() - c0)
                masks.setdefault(h, got)
    finally:
        _native.get_lib = original
    first = masks[hints[0]]
    same = all(all(np.array_equal(a, b) for a, b in zip(first, masks[h])) for h in hints)
    print(f"{len(meshes)} meshes ({', '.join(f'{len(v):,}' for v in meshes)} vertices), {len(poses):,} poses, "
          f"{100 * np.mean([m.mean() for m in first]):.1f} % seen; masks equal across builds: {same}")
    for h in hints:
        print(f"  N_HINTS={h}: CPU s {', '.join(f'{x:.2f}' for x in cpu[h])} (median {np.median(cpu[h]):.2f})")
    if not same:
        raise SystemExit("the kernel builds disagree")


def compare_keyframes(sc, world, t: float, mesh_paths: list[Path], every: int) -> None:
    """Completion (%) of each mesh culled to all poses up to ``t`` and to every ``every``-th pose
    of each robot, against the ground truth culled to all poses and to those poses."""
    from ramensim.evaluation.mesh import load_mesh
    from ramensim.evaluation.metrics import mesh_metrics
    from ramensim.scoring import Evaluator

    ev = Evaluator.for_scenario(sc, world)
    by_agent = ev.poses_by_agent_until(t)
    every_pose = np.concatenate(by_agent)
    some = np.concatenate([p[::every] for p in by_agent])
    gt_all = ev.culled_ground_truth(every_pose)
    gt_some = Evaluator.for_scenario(sc, world).culled_ground_truth(some)
    cfg = sc.evaluation

    def completion(recon, gt) -> float:
        return mesh_metrics(recon, gt, n_samples=cfg.n_samples, threshold_m=cfg.threshold_m,
                            seed=ev._metric_seed())["completion_ratio_pct"]

    print(f"{len(every_pose):,} poses; every {every}-th: {len(some):,}")
    for path in mesh_paths:
        mesh = load_mesh(path)
        c0 = time.process_time()
        full = ev.cull(mesh, every_pose)
        c1 = time.process_time()
        part = ev.cull(mesh, some)
        c2 = time.process_time()
        base = completion(full, gt_all)
        print(f"{path.name}: completion {base:.3f} %; mesh culled to every {every}-th pose "
              f"{completion(part, gt_all) - base:+.3f} points; both to them {completion(part, gt_some) - base:+.3f} "
              f"points; culling CPU {c1 - c0:.2f} -> {c2 - c1:.2f} s")


if __name__ == "__main__":
    main()
