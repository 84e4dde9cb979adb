"""Score a finished run's final meshes against the views of earlier times (a cause analysis,
docs/RESULTS.md, "Why local gets worse with time").

A map's periodic scores change for two reasons: the map changes, and the region the metrics
look at grows (both meshes are culled to what the robots' cameras saw up to the evaluation's
time, docs/ALGORITHM.md section 5). This script holds the map fixed, at the run's final
``mesh_<map>.ply``, and scores it with the cameras' poses up to each time ``t`` -- the team's
(as the run scores it) and, with ``--own``, also only the map's own robots' (the ground truth
and the mesh culled to what the map itself saw) -- beside the run's own timeline at ``t``. If
the fixed map's score follows the timeline, the growing region explains the change; if it
stays at its final value, the map changed.

    python tools/rescore_over_time.py RUN_FOLDER [--at 30 60 ...] [--own] [--out DIR]

Writes ``rescore.json`` and ``rescore.md`` into ``--out`` (default: print only).
"""
from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from _cause import load_run, write_outputs

log = logging.getLogger("rescore_over_time")

KEYS = ("artifacts_cm", "completion_ratio_pct", "holes_cm")


def rescore(folder: Path, times: list[float], own: bool) -> dict[str, Any]:
    """``{"run", "maps": {name: [{"t", "timeline": {...}, "team": {...}, "own": {...}}]}}``."""
    from ramensim.evaluation.mesh import load_mesh

    run = load_run(folder)
    # one evaluator per view set: each keeps its own incremental ground-truth culling
    team_ev, own_ev = run.evaluator(), run.evaluator()
    timeline = {(row["t"], row["agent"]): row for row in run.result.model_dump().get("timeline", [])}
    out: dict[str, Any] = {"run": str(folder), "method": run.scenario.method, "maps": {}}
    for k, name in enumerate(run.result.per_agent):
        mesh = load_mesh(folder / f"mesh_{name}.ply")
        fed_by = run.fed_by(k)
        rows = []
        for t in times:
            poses = team_ev.poses_by_agent_until(t)
            row: dict[str, Any] = {"t": t, "timeline": {key: timeline.get((t, k), {}).get(key) for key in KEYS}}
            team = team_ev.score_mesh(mesh, poses, fed_by)
            row["team"] = {key: team.get(key) for key in KEYS}
            if own:
                mine = [p if a in fed_by else p[:0] for a, p in enumerate(poses)]
                row["own"] = {key: v for key, v in own_ev.score_mesh(mesh, mine, fed_by).items() if key in KEYS}
            rows.append(row)
            log.info("%s t=%g: timeline %s, team %s%s", name, t, row["timeline"]["artifacts_cm"],
                     row["team"]["artifacts_cm"], f", own {row['own']['artifacts_cm']}" if own else "")
        out["maps"][name] = rows
    run.world.close()
    return out


def _cell(v: Any) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.1f}"


def markdown(res: dict[str, Any]) -> str:
    """One table per map: artifacts and completion of the timeline and of the fixed final mesh."""
    lines = [f"# {res['run']} ({res['method']}): the final mesh scored with the views up to t", ""]
    for name, rows in res["maps"].items():
        own = "own" in rows[0]
        head = ["t (s)", "timeline artifacts (cm)", "final mesh, team views: artifacts (cm)"]
        head += ["final mesh, own views: artifacts (cm)"] if own else []
        head += ["timeline completion (%)", "final mesh, team views: completion (%)"]
        head += ["final mesh, own views: completion (%)"] if own else []
        lines += [f"## {name}", "", "| " + " | ".join(head) + " |", "|" + "---:|" * len(head)]
        for r in rows:
            cells = [f"{r['t']:g}", _cell(r["timeline"]["artifacts_cm"]), _cell(r["team"]["artifacts_cm"])]
            cells += [_cell(r["own"]["artifacts_cm"])] if own else []
            cells += [_cell(r["timeline"]["completion_ratio_pct"]), _cell(r["team"]["completion_ratio_pct"])]
            cells += [_cell(r["own"]["completion_ratio_pct"])] if own else []
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="a finished run folder with mesh_<map>.ply")
    ap.add_argument("--at", type=float, nargs="+", default=None, help="times (s); default the run's evaluations")
    ap.add_argument("--own", action="store_true", help="also score with the map's own robots' views only")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    times = args.at
    if times is None:
        from ramensim.core.results import RunResult
        times = sorted({float(r["t"]) for r in RunResult.read(args.run / "metrics.json").model_dump().get("timeline", [])})
    res = rescore(args.run, [float(t) for t in times], args.own)
    write_outputs(args.out, "rescore", res, markdown(res))


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
