"""Where one map's SDF on the evaluation grid goes (issue 27): ``NeuralMap.sdf_grid`` on the
scenario's world bounds at ``evaluation.voxel_m``, split into the hash-grid encoding, the
decoder's SDF-only pass and the rest (building each chunk's normalised points and OneBlob
codes from the per-axis values, copying the result out). This query is most of a periodic
evaluation's cost (docs/BENCHMARKS.md, "A paper-horizon run"); marching cubes on the result
is timed by ``bench_long_run.py`` inside a real run.

The table is the map's initial one with seeded N(0, 0.3) noise added, so every level holds
values of a trained map's size; the kernels' cost does not depend on the values.

Run from the repository root:
    PYTHONPATH=. python benchmarks/bench_extract.py [--threads 1] [--repeats 3]
        [--scenario scenarios/house_3agents.yaml] [--set KEY=VALUE ...]
"""
from __future__ import annotations

import argparse
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch

from benchmarks._machine import machine_info


def _timed(store: dict[str, float], key: str, fn):
    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            store[key] += time.perf_counter() - t0
    return wrapper


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="scenarios/house_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--threads", type=int, default=1, help="threads of the map's kernels (a sweep worker's run: 1)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--batches", default=None, metavar="N,M,...",
                    help="compare sdf_grid batch sizes (points; neural_map.GRID_BATCH), alternated, in CPU seconds")
    args = ap.parse_args()

    from ramensim.agents.map import neural_map
    from ramensim.agents.map.decoders import Decoders
    from ramensim.config import load_scenario
    from ramensim.evaluation.mesh import grid_shape
    from ramensim.sim import build_simulation

    torch.set_num_threads(args.threads)
    path = Path(args.scenario)
    sc = load_scenario(path, ["recording.mode=off", f"map.threads={args.threads}", *args.overrides])
    sim = build_simulation(sc, path.parent)
    m = sim.maps[0]
    with torch.no_grad():
        m.theta.add_(torch.randn(m.theta.shape, generator=torch.Generator().manual_seed(0)).to(m.theta.device) * 0.3)
    bounds = np.asarray(sim.world.bounds, dtype=np.float64)
    voxel = sc.evaluation.voxel_m
    shape = grid_shape(bounds, voxel)
    n = int(np.prod(shape))

    parts: dict[str, float] = defaultdict(float)
    neural_map.encode = _timed(parts, "hash-grid encoding", neural_map.encode)
    Decoders.fused_sdf = _timed(parts, "decoder (SDF only)", Decoders.fused_sdf)
    print(machine_info())
    print(f"{sc.name}: grid {shape[0]} x {shape[1]} x {shape[2]} = {n / 1e6:.2f} M points at {voxel * 100:g} cm, "
          f"{m.spec.n_levels} levels of 2^{m.spec.log2_T}, {args.threads} thread(s)")
    if args.batches:
        compare_batches(m, bounds[0], voxel, shape, [int(b) for b in args.batches.split(",")], args.repeats)
        return
    totals = []
    for r in range(args.repeats):
        parts.clear()
        t0 = time.perf_counter()
        m.sdf_grid(bounds[0], voxel, shape)
        total = time.perf_counter() - t0
        totals.append(total)
        rest = total - sum(parts.values())
        cells = "  ".join(f"{k} {v:.2f} s ({100 * v / total:.0f} %)" for k, v in parts.items())
        print(f"repeat {r + 1}: sdf_grid {total:.2f} s ({n / total / 1e6:.2f} M points/s)  {cells}  "
              f"rest {rest:.2f} s ({100 * rest / total:.0f} %)")
    print(f"median sdf_grid {float(np.median(totals)):.2f} s")


def compare_batches(m, origin, voxel: float, shape, batches: list[int], repeats: int) -> None:
    """``sdf_grid`` with each batch size in turn (order reversed every other round), CPU seconds
    of this process (the kernels run on this thread), and whether the grids are equal."""
    from ramensim.agents.map import neural_map

    cpu: dict[int, list[float]] = {b: [] for b in batches}
    grids = {}
    for r in range(repeats):
        for b in (batches if r % 2 == 0 else batches[::-1]):
            neural_map.GRID_BATCH = b
            t0 = time.process_time()
            grids[b] = m.sdf_grid(origin, voxel, shape)
            cpu[b].append(time.process_time() - t0)
    first = grids[batches[0]]
    for b in batches:
        print(f"batch {b}: sdf_grid CPU {float(np.median(cpu[b])):.2f} s (median of {repeats}: "
              + ", ".join(f"{x:.2f}" for x in cpu[b]) + f"); equal to batch {batches[0]}'s: "
              f"{np.array_equal(grids[b], first)}")


if __name__ == "__main__":
    main()
