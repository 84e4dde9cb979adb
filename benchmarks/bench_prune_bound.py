"""How much of a periodic evaluation's grid a visibility-pruned extraction could skip (issue 27,
"mesh extraction pruned to blocks some camera saw").

The metrics score a map's mesh after culling it to what the cameras saw (a face is kept when
one of its vertices is seen, eq. of docs/ALGORITHM.md section 5), so an extraction that
queries the SDF only in blocks some camera may see, and leaves the rest out, could give the
same culled mesh. This script measures the most such a pruning could save: the evaluation
grid (the world's bounds at ``evaluation.voxel_m``) is cut into cubes of ``--cube`` x
``--cube`` x ``--cube`` cells; a cube that holds a grid point seen by some pose up to time t
(the metrics' own frustum + occlusion test, :func:`ramensim.evaluation.cull.visible_points`,
every ``--stride``-th grid point per axis) cannot be skipped by any rule based on what the
cameras saw. The printed share of such cubes is a lower bound on what a pruned extraction
must still query; one minus it bounds the saving from above.

Poses come from a finished run folder's scenario (its world and trajectories are rebuilt from
the scenario's seed, as ``ramensim eval --run`` does).

Run from the repository root:
    PYTHONPATH=. python benchmarks/bench_prune_bound.py RUN_FOLDER [--at 30 300 570]
        [--cube 8] [--stride 2]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks._machine import machine_info


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="a finished run folder (its scenario.yaml)")
    ap.add_argument("--at", type=float, nargs="+", default=[30.0, 300.0, 570.0], help="simulated times (s)")
    ap.add_argument("--cube", type=int, default=8, help="cube edge in grid cells")
    ap.add_argument("--stride", type=int, default=2, help="test every stride-th grid point per axis")
    args = ap.parse_args()

    from ramensim.config import load_scenario
    from ramensim.core.seeding import Seeds
    from ramensim.evaluation.cull import visible_points
    from ramensim.evaluation.mesh import grid_shape
    from ramensim.scoring import Evaluator
    from ramensim.world import build_world

    sc = load_scenario(args.run / "scenario.yaml")
    n = sc.agents.count
    world = build_world(sc.world, n, sc.duration, Seeds(sc.seed).numpy, base_dir=args.run)
    ev = Evaluator.for_scenario(sc, world)
    bounds = np.asarray(world.bounds, dtype=np.float64)
    voxel = sc.evaluation.voxel_m
    shape = grid_shape(bounds, voxel)
    idx = [np.arange(0, shape[d], args.stride) for d in range(3)]
    ijk = np.stack(np.meshgrid(*idx, indexing="ij"), axis=-1).reshape(-1, 3)
    pts = bounds[0] + ijk * voxel
    cube = np.minimum(ijk // args.cube, (np.array(shape) - 2) // args.cube)  # the last point closes the last cell
    dims = cube.max(axis=0) + 1
    key = (cube[:, 0] * dims[1] + cube[:, 1]) * dims[2] + cube[:, 2]
    print(machine_info())
    print(f"{args.run}: grid {shape[0]} x {shape[1]} x {shape[2]} = {np.prod(shape) / 1e6:.2f} M points at "
          f"{voxel * 100:g} cm; {int(np.prod(dims))} cubes of {args.cube}^3 cells; {len(pts) / 1e6:.2f} M points tested "
          f"(stride {args.stride}); cull {sc.evaluation.cull}, eps {sc.evaluation.occlusion_eps_m} m")
    for t in args.at:
        poses = ev.poses_until(t)
        t0 = time.perf_counter()
        seen = visible_points(pts, poses, ev.camera, occluder=ev._depths, eps_m=sc.evaluation.occlusion_eps_m,
                              stride=sc.evaluation.occlusion_stride_px)
        needed = np.zeros(int(np.prod(dims)), dtype=bool)
        needed[key[seen]] = True
        print(f"t = {t:g} s: {len(poses)} poses; grid points seen {100 * seen.mean():.1f} %; cubes holding a seen "
              f"point {100 * needed.mean():.1f} % (a pruned extraction skips at most {100 * (1 - needed.mean()):.1f} %)"
              f"  [{time.perf_counter() - t0:.1f} s]", flush=True)


if __name__ == "__main__":
    main()
