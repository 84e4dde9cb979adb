"""A finished run's final meshes scored against the views of earlier times (a cause study,
docs/results/causes.md, "Why local gets worse with time"; ``ramensim paper rescore``).

A map's periodic scores change for two reasons: the map changes, and the region the metrics
look at grows (both meshes are culled to what the robots' cameras saw up to the evaluation's
time, docs/ALGORITHM.md section 5). This holds the map fixed, at the run's final
``mesh_<map>.ply``, and scores it with the cameras' poses up to each time ``t`` -- the team's
(as the run scores it) and, with ``own``, also only the map's own robots' (the ground truth and
the mesh culled to what the map itself saw) -- beside the run's own timeline at ``t``. If the
fixed map's score follows the timeline, the growing region explains the change; if it stays at
its final value, the map changed. Outputs: ``rescore.json`` and ``rescore.md``.
"""
from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from ramensim.paper.study import load_run

log = logging.getLogger(__name__)

KEYS = ("artifacts_cm", "completion_ratio_pct", "holes_cm")
"""The scores compared: artifacts (cm), completion ratio (%), holes (cm)."""


def evaluation_times(folder: Path) -> list[float]:
    """The simulated times (s) at which the run in ``folder`` evaluated its maps (its timeline)."""
    from ramensim.core.results import RunResult

    return sorted({float(r["t"]) for r in RunResult.read(folder / "metrics.json").model_dump().get("timeline", [])})


def rescore(folder: Path, times: list[float], own: bool) -> dict[str, Any]:
    """Per map and time ``t`` (s): the run's timeline scores at ``t`` and the final mesh's scores
    with the team's views up to ``t`` (and, with ``own``, its own robots' views only);
    ``{"run", "method", "maps": {name: [{"t", "timeline": {...}, "team": {...}, "own": {...}}]}}``
    with the :data:`KEYS` in each."""
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
    """A score to one decimal, "-" where there is none."""
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.1f}"


def markdown(res: dict[str, Any]) -> str:
    """One table per map: artifacts (cm) and completion (%) of the timeline and of the fixed final mesh."""
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
