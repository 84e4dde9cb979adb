"""How a team completes the far part of its maps: by when it was first seen and by how many links
it must cross (a cause study, docs/results/fig7.md, "Fig. 7 with the authors' split";
``ramensim paper far-part``).

On a fixed communication graph the *far part* of a map is what only robots two or more links
away saw (docs/ALGORITHM.md section 5): what the map holds there crossed at least two lossy
links. :func:`analyse` splits that part two ways and gives per bin its share of the far part and
the team's completion ratio there (%, the share of ground-truth samples within
``evaluation.threshold_m`` of the map's culled mesh, pooled over the maps):
- by the time (s) one of those far robots first saw it, beside the same for each map's *own*
  part (what its own robot saw, by when it saw it) as the control: surface seen late is learnt
  late by its own robot too, but the far part must also travel;
- by hops: the fewest links between the map's robot and a robot that saw the sample (2, 3, ...).
The run's final ``mesh_<map>.ply`` files are scored as the run scores them (culled to the team's
views, ``evaluation.cull``). Outputs: ``far_part.json`` and ``.md``; :func:`compare` prints saved
team rows side by side, one line per run.
"""
from __future__ import annotations

import json
import logging
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ramensim.core.errors import InputError
from ramensim.paper.study import load_run

log = logging.getLogger(__name__)


def first_seen(seen_windows: Sequence[np.ndarray]) -> np.ndarray:
    """(n_robots, N) index of the first window in which each robot saw each sample, ``-1`` if
    never; ``seen_windows``: per window, the (n_robots, N) visibility from that window's poses."""
    first = np.full(seen_windows[0].shape, -1, dtype=np.int32)
    for k, seen in enumerate(seen_windows):
        first[(first < 0) & seen] = k
    return first


def earliest(first: np.ndarray, robots: np.ndarray) -> np.ndarray:
    """Per sample the earliest window in which any robot of the mask ``robots`` saw it (-1: none)."""
    sub = first[robots]
    if sub.size == 0:
        return np.full(first.shape[1], -1, dtype=np.int32)
    big = np.where(sub < 0, np.iinfo(np.int32).max, sub).min(axis=0)
    return np.where(big == np.iinfo(np.int32).max, -1, big).astype(np.int32)


def hops_from(neighbours: Sequence[Sequence[int]], start: Sequence[int]) -> np.ndarray:
    """(n_robots,) fewest links from any robot of ``start`` to each robot (``neighbours``: per
    robot, its graph neighbours); a robot not reached gets a large number."""
    import networkx as nx

    graph = nx.Graph((a, b) for a, nb in enumerate(neighbours) for b in nb)
    graph.add_nodes_from(range(len(neighbours)))
    dist = np.full(len(neighbours), 10 ** 6, dtype=np.int64)
    for robot, d in nx.multi_source_dijkstra_path_length(graph, set(start)).items():
        dist[robot] = d
    return dist


def fewest_hops(seen: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Per sample the fewest links to a robot that saw it (``seen``: (n_robots, N); -1: none saw it)."""
    d = np.where(seen, dist[:, None], 10 ** 6).min(axis=0)
    return np.where(d >= 10 ** 6, -1, d)


def binned(window: np.ndarray, part: np.ndarray, hit: np.ndarray, n_windows: int) -> list[dict[str, Any]]:
    """Per window: the samples of ``part`` first seen in it (count) and how many the map completes."""
    return [{"n": int((part & (window == k)).sum()), "hit": int((part & (window == k) & hit).sum())}
            for k in range(n_windows)]


def analyse(folder: Path, window_s: float, n_samples: int) -> dict[str, Any]:
    """Per map and pooled over the team, the far and own parts binned by first sight (windows of
    ``window_s`` s) and the far part by links, as sample counts (``n``) and completed samples
    (``hit``), from ``n_samples`` ground-truth and mesh samples; ValueError on a graph that
    changes with time (no far part)."""
    import trimesh
    from scipy.spatial import cKDTree

    from ramensim.evaluation.coverage import far_part, own_and_near
    from ramensim.evaluation.mesh import load_mesh

    run = load_run(folder)
    sc, result, world = run.scenario, run.result, run.world
    ev = run.evaluator()
    if ev.neighbours is None:
        raise ValueError("the communication graph changes with time (disk topology): no far part")
    T = float(result.sim_time_s)
    edges = list(np.arange(window_s, T, window_s)) + [T]
    poses = ev.poses_by_agent_until(T)
    counts = [[len(p) for p in ev.poses_by_agent_until(t)] for t in edges]
    every = np.concatenate(poses, axis=0)
    rng = np.random.default_rng(np.random.SeedSequence([sc.seed, 2027]))
    gt_pts = trimesh.sample.sample_surface(ev.culled_ground_truth(every), n_samples, seed=rng)[0]
    windows, prev = [], [0] * len(poses)
    for cnt in counts:
        part_poses = [poses[a][prev[a]:cnt[a]] for a in range(len(poses))]
        windows.append(ev.visible(gt_pts, part_poses))
        prev = cnt
    first = first_seen(windows)
    seen = first >= 0
    out: dict[str, Any] = {"run": str(folder), "method": sc.method, "robots": len(poses), "t_s": T,
                           "edges_s": [float(e) for e in edges], "threshold_m": ev.cfg.threshold_m, "maps": {}}
    for k, name in enumerate(result.per_agent):
        fed_by = run.fed_by(k)
        own, near = own_and_near(len(poses), fed_by, ev.neighbours)
        recon = ev.cull(load_mesh(folder / f"mesh_{name}.ply"), every)
        if len(recon.faces) == 0:
            hit = np.zeros(len(gt_pts), dtype=bool)
        else:
            pts = trimesh.sample.sample_surface(recon, n_samples, seed=rng)[0]
            hit = cKDTree(pts).query(gt_pts, workers=-1)[0] < ev.cfg.threshold_m
        far = far_part(seen, near)
        mine = seen[own].any(axis=0)
        hops = fewest_hops(seen, hops_from(ev.neighbours, fed_by))
        out["maps"][name] = {"far": binned(earliest(first, ~near), far, hit, len(edges)),
                             "own": binned(earliest(first, own), mine, hit, len(edges)),
                             "hops": binned(hops, far, hit, len(poses))}
    world.close()
    out["team"] = {p: [{"n": sum(m[p][i]["n"] for m in out["maps"].values()),
                        "hit": sum(m[p][i]["hit"] for m in out["maps"].values())} for i in range(size)]
                   for p, size in (("far", len(edges)), ("own", len(edges)), ("hops", len(poses)))}
    return out


def _pct(row: dict[str, int]) -> float:
    """The completion (%) of a bin: its samples completed over its samples (NaN when empty)."""
    return 100.0 * row["hit"] / row["n"] if row["n"] else math.nan


def markdown(res: dict[str, Any]) -> str:
    """:func:`analyse`'s team rows as Markdown: share (%) and completion (%) by first sight, then by links."""
    edges = [0.0] + res["edges_s"]
    team = res["team"]
    nf, no = sum(r["n"] for r in team["far"]), sum(r["n"] for r in team["own"])
    lines = [f"# {res['run']} ({res['method']}, {res['robots']} robots, t = {res['t_s']:g} s): completion by "
             "when the surface was first seen", "",
             "Pooled over the maps: the far part (seen only by robots ≥ 2 links away) by when one of them first "
             "saw it, and each map's own part by when its own robot first saw it; share of the part (%) and the "
             f"team's completion there (%, within {100 * res['threshold_m']:g} cm).", "",
             "| first seen (s) | far: share (%) | far: completion (%) | own: share (%) | own: completion (%) |",
             "|---|---:|---:|---:|---:|"]
    for i, (f, o) in enumerate(zip(team["far"], team["own"])):
        lines.append(f"| {edges[i]:g}-{edges[i + 1]:g} | {100 * f['n'] / nf if nf else math.nan:.1f} | "
                     f"{_pct(f):.1f} | {100 * o['n'] / no if no else math.nan:.1f} | {_pct(o):.1f} |")
    allf = {"n": nf, "hit": sum(r["hit"] for r in team["far"])}
    allo = {"n": no, "hit": sum(r["hit"] for r in team["own"])}
    lines.append(f"| all | 100 | {_pct(allf):.1f} | 100 | {_pct(allo):.1f} |")
    lines += ["", "The far part by the fewest links between the map's robot and a robot that saw it:", "",
              "| links | share of the far part (%) | completion (%) |", "|---|---:|---:|"]
    lines += [f"| {h} | {100 * r['n'] / nf if nf else math.nan:.1f} | {_pct(r):.1f} |"
              for h, r in enumerate(team["hops"]) if r["n"]]
    return "\n".join(lines) + "\n"


def compare(paths: Sequence[Path]) -> str:
    """One line per saved ``far_part.json``: the far part's completion (%) per window of first sight
    and per number of links; then one line per robot count, the runs' samples pooled (:func:`pool`)."""
    lines: list[str] = []
    loaded: list[dict[str, Any]] = []
    for path in paths:
        try:
            res = json.loads(path.read_text(encoding="utf-8"))
            edges = [0.0] + res["edges_s"]
            cells = [f"{edges[i]:g}-{edges[i + 1]:g} s: {_pct(r):.1f}" for i, r in enumerate(res["team"]["far"])]
            links = [f"{h} links: {_pct(r):.1f}" for h, r in enumerate(res["team"]["hops"]) if r["n"]]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{path}: not a far_part.json ({exc}); expected the file "
                             f"'ramensim paper far-part RUN --out DIR' writes.") from None
        lines.append(f"{res['run']} ({res['robots']} robots): far part's completion by first sight: "
                     + "; ".join(cells) + "; by links: " + "; ".join(links))
        loaded.append(res)
    for robots, pooled in pool(loaded).items():
        nf = sum(r["n"] for r in pooled["hops"])
        lines.append(f"pooled over the {pooled['runs']} run{'s' if pooled['runs'] != 1 else ''} with {robots} robots: "
                     f"far part's completion "
                     f"{_pct({'n': nf, 'hit': sum(r['hit'] for r in pooled['hops'])}):.1f} %; by first sight "
                     + "; ".join(f"{lo:g}-{hi:g} s: {100 * r['n'] / nf:.1f} % of it at {_pct(r):.1f}"
                                 for lo, hi, r in zip([0.0] + pooled["edges_s"], pooled["edges_s"], pooled["far"]))
                     + "; by links " + "; ".join(f"{h}: {100 * r['n'] / nf:.1f} % of it at {_pct(r):.1f}"
                                                 for h, r in enumerate(pooled["hops"]) if r["n"]))
    return "\n".join(lines) + "\n"


def pool(results: Sequence[dict[str, Any]]) -> dict[int, dict[str, Any]]:
    """The team rows of saved results summed per robot count (runs with the same windows only:
    a run whose windows differ from the first of its count is left out, with a warning)."""
    out: dict[int, dict[str, Any]] = {}
    for res in results:
        got = out.setdefault(res["robots"], {"runs": 0, "edges_s": res["edges_s"],
                                             **{p: [{"n": 0, "hit": 0} for _ in rows] for p, rows in res["team"].items()}})
        if got["edges_s"] != res["edges_s"]:
            log.warning("far_part: %s: other windows of first sight than the first run with %d robots; not pooled",
                        res["run"], res["robots"])
            continue
        got["runs"] += 1
        for p, rows in res["team"].items():
            for acc, r in zip(got[p], rows):
                acc["n"] += r["n"]
                acc["hit"] += r["hit"]
    return dict(sorted(out.items()))
