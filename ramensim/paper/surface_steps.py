"""Why a completion curve dips: the evaluated surface grows in steps (a cause study,
docs/results/fig7.md; ``ramensim paper surface-steps``).

With ``evaluation.cull: frustum_occlusion`` the ground truth a map is scored against at time t is
the surface some robot's camera has seen by t (docs/ALGORITHM.md, "Culling"), so the surface
grows in jumps when a robot enters a new room; its fresh part is not learnt yet, and the team's
completion ratio (%) falls until training catches up. This reads every finished run of an
archived sweep (``runs/*/metrics.json``, its ``timeline``) and compares, between consecutive
evaluations, the change of the team's completion (mean over robots, points) with the change of
the team coverage (``team_coverage_pct``: the seen part of the house, points): the Pearson
correlation over all steps, and the mean change of completion at the steps where the seen
surface grew by at least ``jump`` points against the other steps.
"""
from __future__ import annotations

import json
import logging
import math
from collections import defaultdict
from pathlib import Path
from statistics import StatisticsError, correlation, fmean, pstdev
from typing import Sequence

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)


def run_steps(metrics: dict, until: float = math.inf) -> list[tuple[float, float, float]]:
    """(t, change of team coverage, change of team completion) between consecutive evaluations of
    one run's ``timeline`` up to ``until`` s (points; completion: the mean over the robots)."""
    by: dict[float, list[dict]] = defaultdict(list)
    for e in metrics.get("timeline") or []:
        if isinstance(e, dict) and isinstance(e.get("t"), (int, float)) and e["t"] <= until:
            by[float(e["t"])].append(e)
    from ramensim.evaluation.summary import finite_mean

    rows = []
    for t in sorted(by):
        comp = finite_mean(e.get("completion_ratio_pct") for e in by[t])
        cov = finite_mean([by[t][0].get("team_coverage_pct")])
        if math.isfinite(comp) and math.isfinite(cov):
            rows.append((t, cov, comp))
    return [(b[0], b[1] - a[1], b[2] - a[2]) for a, b in zip(rows, rows[1:])]


def summarize(steps: Sequence[tuple[float, float, float]], jump: float) -> dict:
    """The Pearson correlation of the two changes over ``steps`` and the mean change of completion
    (points) at the steps where the seen surface grew by ``jump`` points or more and elsewhere (with
    the lowest at jumps and the population std elsewhere); ValueError for fewer than two steps."""
    if len(steps) < 2:
        raise ValueError("fewer than two steps between evaluations: nothing to compare")
    dv, dc = [s[1] for s in steps], [s[2] for s in steps]
    try:
        corr = correlation(dv, dc)
    except StatisticsError:  # one of the two never changes
        corr = math.nan
    at = [c for v, c in zip(dv, dc) if v >= jump]
    rest = [c for v, c in zip(dv, dc) if v < jump]
    return {"steps": len(steps), "correlation": corr, "jump_points": jump,
            "at_jumps": {"n": len(at), "mean": fmean(at) if at else math.nan, "min": min(at, default=math.nan)},
            "elsewhere": {"n": len(rest), "mean": fmean(rest) if rest else math.nan,
                          "std": pstdev(rest) if rest else math.nan}}


def analyse(archive: Path, jump: float, until: float = math.inf) -> dict:
    """:func:`summarize` over the steps of every run of ``archive`` (``runs/<point>/metrics.json``)
    up to ``until`` s, with ``runs`` (the number of runs read); a run that cannot be read is left
    out with a warning; :class:`InputError` when the archive holds no run or too few steps."""
    files = sorted((archive / "runs").glob("*/metrics.json"))
    if not files:
        raise InputError(f"{archive} holds no runs/<point>/metrics.json; expected an archived sweep folder, e.g. "
                         f"docs/results/paper/paper_fig7_authors_split.")
    steps = []
    for f in files:
        try:
            steps += run_steps(json.loads(f.read_text(encoding="utf-8")), until)
        except (OSError, ValueError) as exc:
            log.warning("surface_steps: %s left out: %s", f, exc)
    try:
        res = summarize(steps, jump)
    except ValueError as exc:
        raise InputError(f"{archive}: {exc}") from None
    return {"runs": len(files), **res}


def render(archive: Path, res: dict) -> str:
    """:func:`analyse`'s result in three lines of words (points; correlation without unit)."""
    a, e = res["at_jumps"], res["elsewhere"]
    return (f"{archive}: {res['runs']} runs, {res['steps']} steps between evaluations; correlation of the "
            f"seen surface's change with the team completion's change {res['correlation']:+.2f}\n"
            f"steps where the seen surface grew >= {res['jump_points']:g} points: {a['n']}, completion change "
            f"{a['mean']:+.2f} points on average (lowest {a['min']:+.2f})\n"
            f"the other steps: {e['n']}, completion change {e['mean']:+.2f} +- {e['std']:.2f} points\n")
