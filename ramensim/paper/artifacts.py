"""Where a map's artifacts lie relative to what its own robots saw (a cause study,
docs/results/causes.md, "Why local gets worse with time"; ``ramensim paper artifacts``).

The run's final ``mesh_<map>.ply`` is culled to the team's views at the run's end, as the run
scores it (docs/ALGORITHM.md section 5), and sampled area-uniformly; each sample gets its error
(distance to the ground truth, m: the Artifacts metric's term) and its distance to the
ground-truth surface the map's own robots saw (the ground truth culled to their views). The
table bins the samples by the second distance: the share of the kept mesh in each bin, the
share of it farther than ``bad_m`` from the ground truth, and its mean error.

On a fixed communication graph a second table splits the same samples by the part of the
ground truth their nearest ground-truth sample lies in (scoring's parts, docs/ALGORITHM.md
section 5): seen by the map's own robot(s); seen by a graph neighbour but not by them; the
*far part*, seen only by robots two or more links away; seen by no robot. Outputs:
``artifacts_by_distance.json`` and ``.md``, both ending with the team's row per part (the maps'
samples pooled: what docs/results/causes.md tabulates); :func:`compare` prints those team rows of
saved outputs side by side, one line per run.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ramensim.core.errors import InputError
from ramensim.paper.study import load_run

BINS_M = (0.0, 0.1, 0.5, 1.0, 2.0, 4.0, np.inf)
"""Edges (m) of the distance bins."""

PARTS = ("own", "neighbour", "far", "unseen by all")
"""The ground-truth parts of the second table, in its order."""


def _row(mask: np.ndarray, err: np.ndarray, bad_m: float) -> dict[str, Any]:
    """Share (%) of the samples in ``mask``, the share of those farther than ``bad_m`` (m)
    from the ground truth (%) and their mean error (cm); None where the mask is empty."""
    return {"share_pct": 100.0 * float(mask.mean()),
            "bad_pct": 100.0 * float((err[mask] > bad_m).mean()) if mask.any() else None,
            "mean_error_cm": 100.0 * float(err[mask].mean()) if mask.any() else None}


def gt_parts(seen: np.ndarray, fed_by: list[int], neighbours: list[list[int]]) -> np.ndarray:
    """Index into :data:`PARTS` of each ground-truth sample, for the map fed by ``fed_by``.

    ``seen``: (n_robots, N) visibility of the samples; ``neighbours``: per robot, its graph
    neighbours. Own beats neighbour beats far; a sample no robot saw is "unseen by all"."""
    from ramensim.evaluation.coverage import far_part, own_and_near

    own, near = own_and_near(seen.shape[0], fed_by, neighbours)
    part = np.full(seen.shape[1], 3, dtype=np.int8)
    part[far_part(seen, near)] = 2
    part[seen[near & ~own].any(axis=0)] = 1
    part[seen[own].any(axis=0)] = 0
    return part


def team_parts(maps: dict[str, Any]) -> list[dict[str, Any]]:
    """The team's row per part of :data:`PARTS`: the mean over the maps of each map's share of
    its kept mesh (%), and the mean error (cm) of all the team's samples in the part (every map
    has the same number of samples, so each map's mean weighted by its share; None where no map
    has any). Empty without parts (no fixed graph)."""
    if not maps or any("parts" not in m for m in maps.values()):
        return []
    rows = []
    for i, part in enumerate(PARTS):
        own = [m["parts"][i] for m in maps.values()]
        with_err = [r for r in own if r["mean_error_cm"] is not None]
        weight = sum(r["share_pct"] for r in with_err)
        err = sum(r["share_pct"] * r["mean_error_cm"] for r in with_err) / weight if weight > 0 else None
        rows.append({"part": part, "share_pct": float(np.mean([r["share_pct"] for r in own])),
                     "mean_error_cm": None if err is None else float(err)})
    return rows


def team(res: dict[str, Any]) -> dict[str, Any]:
    """The team's means over the maps: mean error (cm) of the whole kept mesh and, on a fixed
    graph, :func:`team_parts`."""
    maps = res["maps"]
    return {"mean_error_cm": float(np.mean([m["mean_error_cm"] for m in maps.values()])),
            "kept_area_m2": float(np.mean([m["kept_area_m2"] for m in maps.values()])),
            "parts": team_parts(maps)}


def analyse(folder: Path, n_samples: int, bad_m: float) -> dict[str, Any]:
    """Per map: areas (m^2), one row per distance bin and, on a fixed communication graph, one
    per part of :data:`PARTS` (share %, bad %, mean error cm)."""
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
    gt_pts = trimesh.sample.sample_surface(gt_full, 2 * n_samples, seed=rng)[0]
    gt_tree = cKDTree(gt_pts)
    seen = team_ev.seen(gt_pts, poses) if team_ev.neighbours is not None else None
    out: dict[str, Any] = {"run": str(folder), "method": sc.method, "t_s": result.sim_time_s, "bad_m": bad_m,
                           "bins_m": [float(b) for b in BINS_M], "maps": {}}
    for k, name in enumerate(result.per_agent):
        fed_by = run.fed_by(k)
        recon = team_ev.cull(load_mesh(folder / f"mesh_{name}.ply"), every)
        own_ev = run.evaluator()  # its own ground-truth culling
        own_gt = own_ev.culled_ground_truth(np.concatenate([poses[a] for a in fed_by], axis=0))
        own_tree = cKDTree(trimesh.sample.sample_surface(own_gt, n_samples, seed=rng)[0])
        pts = trimesh.sample.sample_surface(recon, n_samples, seed=rng)[0]
        err, nearest = gt_tree.query(pts, workers=-1)
        dist = own_tree.query(pts, workers=-1)[0]
        rows = [{"from_m": lo, "to_m": hi, **_row((dist >= lo) & (dist < hi), err, bad_m)}
                for lo, hi in zip(BINS_M[:-1], BINS_M[1:])]
        out["maps"][name] = {"kept_area_m2": float(recon.area), "own_seen_gt_area_m2": float(own_gt.area),
                             "team_seen_gt_area_m2": float(team_ev.culled_ground_truth(every).area),
                             "mean_error_cm": 100.0 * float(err.mean()),
                             "bad_pct": 100.0 * float((err > bad_m).mean()), "bins": rows}
        if seen is not None:
            part = gt_parts(seen, fed_by, team_ev.neighbours)[nearest]
            out["maps"][name]["parts"] = [{"part": p, **_row(part == i, err, bad_m)} for i, p in enumerate(PARTS)]
    world.close()
    out["team"] = team(out)
    return out


def markdown(res: dict[str, Any]) -> str:
    """:func:`analyse`'s tables as Markdown: per map by distance bin (m), by part, then the team's rows."""
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
    with_parts = [(name, m["parts"]) for name, m in res["maps"].items() if "parts" in m]
    if with_parts:
        lines += ["", "The same samples by the part of the ground truth nearest to them (own robot(s), a graph "
                  "neighbour, the far part beyond the neighbours, no robot):", "",
                  "| map | part | share of kept mesh (%) | farther than "
                  f"{100 * res['bad_m']:g} cm from the ground truth (%) | mean error (cm) |", "|---|---|---:|---:|---:|"]
        for name, parts in with_parts:
            for r in parts:
                bad = "-" if r["bad_pct"] is None else f"{r['bad_pct']:.1f}"
                lines.append(f"| {name} | {r['part']} | {r['share_pct']:.1f} | {bad} | {_cm(r['mean_error_cm'])} |")
    t = team(res)
    lines += ["", f"Team (means over the {len(res['maps'])} maps): mean error {t['mean_error_cm']:.2f} cm, "
              f"kept {t['kept_area_m2']:.0f} m^2 per map."]
    if t["parts"]:
        lines += ["", "| part | share of kept mesh (%) | mean error (cm) |", "|---|---:|---:|"]
        lines += [f"| {r['part']} | {r['share_pct']:.1f} | {_cm(r['mean_error_cm'])} |" for r in t["parts"]]
    return "\n".join(lines) + "\n"


def _cm(v: float | None) -> str:
    """A mean error (cm) to two decimals, "-" for None (no samples)."""
    return "-" if v is None else f"{v:.2f}"


def compare(paths: list[Path]) -> str:
    """One line per saved ``artifacts_by_distance.json``: the team's mean error per part (cm;
    :func:`team_parts`) with the part's share of the kept mesh (%), and over the whole kept
    mesh; :class:`InputError` naming a file that is not such an output."""
    import json

    lines = ["| run | method | " + " | ".join(f"{p} (cm, share %)" for p in PARTS) + " | all (cm) |",
             "|---|---|" + "---:|" * (len(PARTS) + 1)]
    for path in paths:
        try:
            res = json.loads(path.read_text())
            t = team(res)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{path}: not an artifacts_by_distance.json ({exc}); expected the file "
                             f"'ramensim paper artifacts RUN --out DIR' writes.") from None
        cells = [f"{_cm(r['mean_error_cm'])} ({r['share_pct']:.0f})" for r in t["parts"]] or ["-"] * len(PARTS)
        lines.append(f"| {res.get('run', path)} | {res.get('method', '?')} | " + " | ".join(cells)
                     + f" | {t['mean_error_cm']:.2f} |")
    return "\n".join(lines) + "\n"
