"""The periodic evaluations' narrow-band extraction against the exact one (issue 71, item 3):
each map of a run scored twice at the same simulated times, with the full grid (the final
evaluation's protocol) and with ``evaluation.periodic.extraction: narrow_band``, and the
difference of every metric per robot; plus, per snapshot, whether ``NeuralMap.sdf_grid`` equals
the point query on the grid's points bit for bit (torch.equal) and the extraction's wall time.

Run from the repository root (one simulation per scenario and method, evaluated at the given
times after it ran; recording off):

    PYTHONPATH=. python benchmarks/bench_eval_band.py [--scenario scenarios/house_3agents.yaml]
        [--method ramen --method dinno --method local] [--times 15 60] [--set KEY=VALUE ...]
        [--band 4,0.03,0 --band 2,0.03,0,0 ...] [--noise 0.3] [--identity] [--json out.jsonl]

``--band F,M,D[,S[,V]]``: a narrow band of coarse factor F, band_m M (m), dilate D, skip_unseen S
(1: refine only blocks some camera may have seen, the default; 0: everywhere) and the periodic
grid spacing V (m; default the final's ``evaluation.voxel_m``) (repeatable; default the
setting's defaults). ``--noise S``: also score, at each time, the first map with N(0, S)
noise added to its table (a map gone wrong: surface everywhere).

Wall-clock figures vary with the machine and its load; no test checks them.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

KEYS = ("completion_ratio_pct", "artifacts_cm", "holes_cm", "n_faces_mesh")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="scenarios/office_3agents.yaml")
    ap.add_argument("--method", action="append", default=None)
    ap.add_argument("--times", type=float, nargs="+", default=[10.0, 40.0])
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--band", action="append", default=None, metavar="F,M,D[,S[,V]]")
    ap.add_argument("--noise", type=float, default=0.0)
    ap.add_argument("--identity", action="store_true", help="also compare sdf_grid with the point query (slow)")
    ap.add_argument("--json", default=None, help="append one JSON line per snapshot and map")
    args = ap.parse_args()

    import numpy as np

    import torch

    from ramensim.config import load_scenario
    from ramensim.evaluation.config import PeriodicExtraction
    from ramensim.scoring import Evaluator
    from ramensim.sim import build_simulation

    path = Path(args.scenario)
    times = sorted(args.times)
    bands = []
    for text in args.band or [None]:
        if text is None:
            d = PeriodicExtraction()
            bands.append((d.coarse_factor, d.band_m, d.dilate, int(d.skip_unseen), d.voxel_m))
        else:
            f, m, d, *rest = text.split(",")
            bands.append((int(f), float(m), int(d), int(rest[0]) if rest else int(PeriodicExtraction().skip_unseen),
                          float(rest[1]) if len(rest) > 1 else None))
    for method in args.method or ["ramen", "dinno", "local"]:
        sc = load_scenario(path, ["recording.mode=off", f"method={method}", f"duration={times[-1]:g}",
                                  "evaluation.every_s=null", *args.overrides])
        sim = build_simulation(sc, path.parent)
        snaps = []
        t_sim = time.perf_counter()
        for t in times:
            sim.env.run(until=t)
            sim.engine.drain()
            maps = [(k, m.frozen_copy(), sim.fed_by(k)) for k, m in enumerate(sim.maps)
                    if sim.processes[k].diverged is None and sim.processes[k].rounds > 0]
            if args.noise > 0 and maps:
                k, m, fed = maps[0]
                bad = m.frozen_copy()
                with torch.no_grad():
                    bad.theta.add_(torch.randn(bad.theta.shape, generator=torch.Generator().manual_seed(0)) * args.noise)
                maps.append((f"{k}+noise", bad, fed))
            snaps.append((t, maps))
        t_sim = time.perf_counter() - t_sim
        print(f"{sc.name} {method}: simulated {times[-1]:g} s in {t_sim:.1f} s", flush=True)
        ev = Evaluator.for_scenario(sc, sim.world)
        for t, maps in snaps:
            poses = ev.poses_by_agent_until(t)
            items = [(m, fed, None) for _, m, fed in maps]
            t0, dense_times = time.perf_counter(), {}
            dense = ev.score_all(items, poses, times=dense_times)
            t_dense = time.perf_counter() - t0
            for factor, band_m, dilate, skip, voxel in bands:
                ev.cfg = sc.evaluation.model_copy(update={"periodic": PeriodicExtraction(
                    extraction="narrow_band", coarse_factor=factor, band_m=band_m, dilate=dilate,
                    skip_unseen=bool(skip), voxel_m=voxel)})
                t0, band_times = time.perf_counter(), {}
                band = ev.score_all(items, poses, times=band_times, periodic=True)
                t_band = time.perf_counter() - t0
                for (k, m, _), d, b in zip(maps, dense, band):
                    rec = {"scenario": sc.name, "method": method, "t": t, "agent": k, "band_setting": [factor, band_m, dilate, skip, voxel],
                           "dense": {key: d.get(key) for key in KEYS}, "band": {key: b.get(key) for key in KEYS}}
                    dc, bc = d.get("completion_ratio_pct"), b.get("completion_ratio_pct")
                    rec["d_completion"] = (bc - dc) if isinstance(dc, float) and isinstance(bc, float) else None
                    if args.identity and k == maps[0][0] and (factor, band_m, dilate, skip, voxel) == bands[0]:
                        from ramensim.evaluation.mesh import grid_shape
                        bnd = np.asarray(sim.world.bounds, dtype=np.float64)
                        shape = grid_shape(bnd, sc.evaluation.voxel_m)
                        g = m.sdf_grid(bnd[0], sc.evaluation.voxel_m, shape)
                        ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
                        ref = m.sdf((bnd[0] + ijk * sc.evaluation.voxel_m).astype(np.float32))
                        rec["sdf_grid_equal"] = bool(torch.equal(torch.from_numpy(g.reshape(-1)), torch.from_numpy(ref)))
                        rec["grid_points"] = int(g.size)
                    print(json.dumps(rec), flush=True)
                    if args.json:
                        with open(args.json, "a") as fh:
                            fh.write(json.dumps(rec) + "\n")
                stages = ", ".join(f"{k} {dense_times.get(k, 0):.2f} -> {v:.2f}" for k, v in band_times.items())
                print(f"  t={t:g} band {factor},{band_m:g},{dilate},{skip},{voxel}: dense {t_dense:.1f} s, narrow band "
                      f"{t_band:.1f} s (per stage, dense -> band: {stages}); max |d completion| "
                      + str(max((abs(bb['completion_ratio_pct'] - dd['completion_ratio_pct'])
                                 for dd, bb in zip(dense, band)
                                 if isinstance(dd.get('completion_ratio_pct'), float)
                                 and math.isfinite(dd['completion_ratio_pct'])), default=None)), flush=True)
        sim.engine.close()
        sim.world.close()


if __name__ == "__main__":
    main()
