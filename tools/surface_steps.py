"""Why a completion curve dips: the evaluated surface grows in steps.

With ``evaluation.cull: frustum_occlusion`` the ground truth a map is scored against at time t is
the surface some robot's camera has seen by t (docs/ALGORITHM.md, "Culling"), so the surface
grows in jumps when a robot enters a new room; its fresh part is not learnt yet, and the team's
completion ratio (%) falls until training catches up. This reads every finished run of an
archived sweep (``runs/*/metrics.json``, its ``timeline``) and compares, between consecutive
evaluations, the change of the team's completion (mean over robots, points) with the change of
the team coverage (``team_coverage_pct``: the seen part of the house, points): the Pearson
correlation over all steps, and the mean change of completion at the steps where the seen
surface grew by at least ``--jump`` points against the other steps.

    python tools/surface_steps.py docs/results/paper/paper_fig7_authors_split [--jump 5] [--until 600]
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections import defaultdict
from pathlib import Path
from statistics import StatisticsError, correlation, fmean, pstdev
from typing import Sequence

log = logging.getLogger("surface_steps")


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
    """The correlation of the two changes and the mean completion change at jumps and elsewhere."""
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


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("archive", type=Path, help="an archived sweep folder (holding runs/<point>/metrics.json)")
    ap.add_argument("--jump", type=float, default=5.0, help="a step of the seen surface, points (default 5)")
    ap.add_argument("--until", type=float, default=math.inf, help="only evaluations up to this time, s")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    files = sorted((args.archive / "runs").glob("*/metrics.json"))
    if not files:
        log.error("surface_steps: %s holds no runs/<point>/metrics.json; expected an archived sweep folder, e.g. "
                  "docs/results/paper/paper_fig7_authors_split.", args.archive)
        return 2
    steps = []
    for f in files:
        try:
            steps += run_steps(json.loads(f.read_text(encoding="utf-8")), args.until)
        except (OSError, ValueError) as exc:
            log.warning("surface_steps: %s left out: %s", f, exc)
    try:
        res = summarize(steps, args.jump)
    except ValueError as exc:
        log.error("surface_steps: %s: %s", args.archive, exc)
        return 2
    a, e = res["at_jumps"], res["elsewhere"]
    print(f"{args.archive}: {len(files)} runs, {res['steps']} steps between evaluations; correlation of the "
          f"seen surface's change with the team completion's change {res['correlation']:+.2f}\n"
          f"steps where the seen surface grew >= {args.jump:g} points: {a['n']}, completion change "
          f"{a['mean']:+.2f} points on average (lowest {a['min']:+.2f})\n"
          f"the other steps: {e['n']}, completion change {e['mean']:+.2f} +- {e['std']:.2f} points")
    return 0


if __name__ == "__main__":
    sys.exit(main())
