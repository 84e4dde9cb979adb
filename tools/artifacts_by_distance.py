"""Where a map's artifacts lie relative to what its own robots saw (a cause analysis,
docs/RESULTS.md, "Why local gets worse with time").

The run's final ``mesh_<map>.ply`` is culled to the team's views at the run's end, as the run
scores it (docs/ALGORITHM.md section 5), and sampled area-uniformly; each sample gets its error
(distance to the ground truth, m: the Artifacts metric's term) and its distance to the
ground-truth surface the map's own robots saw (the ground truth culled to their views). The
table bins the samples by the second distance: the share of the kept mesh in each bin, the
share of it farther than ``--bad`` from the ground truth, and its mean error.

    python tools/artifacts_by_distance.py RUN_FOLDER [--samples 200000] [--bad 0.05] [--out DIR]

Writes ``artifacts_by_distance.json`` and ``.md`` into ``--out`` (default: print only).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from _cause import load_run, write_outputs

BINS_M = (0.0, 0.1, 0.5, 1.0, 2.0, 4.0, np.inf)
"""Edges (m) of the distance bins."""


def analyse(folder: Path, n_samples: int, bad_m: float) -> dict[str, Any]:
    """Per map: areas (m^2) and one row per distance bin (share %, bad %, mean error cm)."""
    import trimesh
    from scipy.spatial import cKDTree

    from ramensim.evaluation.mesh import load_mesh

    run = load_run(folder)
    sc, result, world = run.scenario, run.result, run.world
    team_ev = run.evaluator()
    poses = team_ev.poses_by_agent_until(result.sim_time_s)
    every = np.concatenate(poses, axis=0)
    rng = np.random.default_rng(np.random.SeedSequence([sc.seed, 2026]))
    gt_full = world.scene.mesh
    gt_tree = cKDTree(trimesh.sample.sample_surface(gt_full, 2 * n_samples, seed=rng)[0])
    out: dict[str, Any] = {"run": str(folder), "method": sc.method, "t_s": result.sim_time_s, "bad_m": bad_m,
                           "bins_m": [float(b) for b in BINS_M], "maps": {}}
    for k, name in enumerate(result.per_agent):
        fed_by = run.fed_by(k)
        recon = team_ev._cull(load_mesh(folder / f"mesh_{name}.ply"), every)
        own_ev = run.evaluator()  # its own ground-truth culling
        own_gt = own_ev._culled_gt(np.concatenate([poses[a] for a in fed_by], axis=0))
        own_tree = cKDTree(trimesh.sample.sample_surface(own_gt, n_samples, seed=rng)[0])
        pts = trimesh.sample.sample_surface(recon, n_samples, seed=rng)[0]
        err = gt_tree.query(pts, workers=-1)[0]
        dist = own_tree.query(pts, workers=-1)[0]
        rows = []
        for lo, hi in zip(BINS_M[:-1], BINS_M[1:]):
            m = (dist >= lo) & (dist < hi)
            rows.append({"from_m": lo, "to_m": hi, "share_pct": 100.0 * float(m.mean()),
                         "bad_pct": 100.0 * float((err[m] > bad_m).mean()) if m.any() else None,
                         "mean_error_cm": 100.0 * float(err[m].mean()) if m.any() else None})
        out["maps"][name] = {"kept_area_m2": float(recon.area), "own_seen_gt_area_m2": float(own_gt.area),
                             "team_seen_gt_area_m2": float(team_ev._culled_gt(every).area),
                             "mean_error_cm": 100.0 * float(err.mean()),
                             "bad_pct": 100.0 * float((err > bad_m).mean()), "bins": rows}
    world.close()
    return out


def markdown(res: dict[str, Any]) -> str:
    lines = [f"# {res['run']} ({res['method']}, t = {res['t_s']:g} s): the kept mesh by distance to what the "
             f"map's own robots saw", "",
             "| map | distance to own-seen surface (m) | share of kept mesh (%) | farther than "
             f"{100 * res['bad_m']:g} cm from the ground truth (%) | mean error (cm) |", "|---|---|---:|---:|---:|"]
    for name, m in res["maps"].items():
        for r in m["bins"]:
            hi = "inf" if not np.isfinite(r["to_m"]) else f"{r['to_m']:g}"
            bad = "-" if r["bad_pct"] is None else f"{r['bad_pct']:.1f}"
            err = "-" if r["mean_error_cm"] is None else f"{r['mean_error_cm']:.1f}"
            lines.append(f"| {name} | {r['from_m']:g}-{hi} | {r['share_pct']:.1f} | {bad} | {err} |")
        lines.append(f"| {name} | all (kept {m['kept_area_m2']:.0f} m^2; ground truth seen by the team "
                     f"{m['team_seen_gt_area_m2']:.0f}, by the map's robots {m['own_seen_gt_area_m2']:.0f}) | 100 | "
                     f"{m['bad_pct']:.1f} | {m['mean_error_cm']:.1f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="a finished run folder with mesh_<map>.ply")
    ap.add_argument("--samples", type=int, default=200_000)
    ap.add_argument("--bad", type=float, default=0.05, help="error (m) above which a sample counts as bad")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    res = analyse(args.run, args.samples, args.bad)
    write_outputs(args.out, "artifacts_by_distance", res, markdown(res))


if __name__ == "__main__":
    main()
