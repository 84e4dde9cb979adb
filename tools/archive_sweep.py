"""Keep a sweep's results in the repository, without its meshes, so that the work goes on from
them on a fresh machine (docs/RESULTS.md, "The paper's horizon").

    python tools/archive_sweep.py runs/sweeps/paper_table1 docs/results/paper/paper_table1

copies, for every finished point, its ``status.json``, ``metrics.json`` (the final metrics, the
timeline at every evaluation, the consensus probes) and ``scenario.yaml`` into
``DEST/runs/<point>/``, and the sweep's report (``summary.md``, ``summary.csv``, ``runs.csv``,
``runs_timeline.csv``, ``time_to_consensus.*``, ``report.html``, ``plots/*.png``) into ``DEST``. To resume on a
fresh machine, ``tools/restore_archives.py`` copies ``DEST/runs`` back into the sweep folder:
``ramensim sweep`` counts a point whose status.json and metrics.json are there (same resolved
scenario) as done and runs the rest.

    python tools/archive_sweep.py runs/sweeps/paper_table1 docs/results/paper/paper_table1 \
        --plan scenarios/sweeps/paper/table1.yaml

``--plan FILE`` keeps FILE's plan as the archive's ``sweep.json`` instead of the sweep folder's:
when the protocol runs in batches (subset files with the same name, base, settings and axis
order, each rewriting the folder's plan), the report of the archive then counts every run of
the whole protocol, done and missing. Each archived point must be a point of FILE with the same
resolved scenario (fingerprint), else nothing is written.
"""
from __future__ import annotations

import argparse
import logging
import shutil
import sys
from pathlib import Path

from ramensim.sweep import store

log = logging.getLogger("archive_sweep")

POINT_FILES = (store.STATUS, store.METRICS, "scenario.yaml")
REPORT_FILES = ("summary.md", "summary.csv", "runs.csv", "runs_timeline.csv", "time_to_consensus.csv",
                "time_to_consensus.md", store.PLAN, "report.html")


def archive(sweep: Path, dest: Path) -> int:
    """Copy the finished points and the report of ``sweep`` into ``dest``; returns the points copied."""
    runs = sweep / store.RUNS
    if not runs.is_dir():
        raise SystemExit(f"error: {sweep} has no runs/ folder; expected the --out folder of 'ramensim sweep'.")
    n = 0
    for point in sorted(p for p in runs.iterdir() if p.is_dir() and not p.name.startswith(".")):
        if not store.is_complete(point):
            continue
        out = dest / store.RUNS / point.name
        out.mkdir(parents=True, exist_ok=True)
        for name in POINT_FILES:
            if (point / name).is_file():
                shutil.copy2(point / name, out / name)
        n += 1
    for name in REPORT_FILES:
        if (sweep / name).is_file():
            shutil.copy2(sweep / name, dest / name)
    plots = sweep / "plots"
    if plots.is_dir():
        (dest / "plots").mkdir(parents=True, exist_ok=True)
        for png in plots.glob("*.png"):
            shutil.copy2(png, dest / "plots" / png.name)
    return n


def keep_plan(plan_file: Path, dest: Path) -> int:
    """Write ``plan_file``'s plan as ``dest``'s sweep.json after checking that every archived
    point is one of its points with the same fingerprint; returns its number of points."""
    from ramensim.sweep.spec import plan_sweep

    plan = plan_sweep(plan_file)
    prints = {p.name: p.fingerprint for p in plan.points}
    runs = dest / store.RUNS
    for point in sorted(p for p in runs.iterdir() if p.is_dir()) if runs.is_dir() else []:
        if point.name not in prints:
            raise SystemExit(f"error: {point} is not a point of {plan_file}; expected the batches to use its axes.")
        if not store.is_complete(point, prints[point.name]):
            raise SystemExit(f"error: {point} holds no result of the scenario {plan_file} plans for it "
                             f"(another fingerprint, or no complete result).")
    store.atomic_write_json(dest / store.PLAN, plan.to_json())
    return len(plan.points)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sweep", type=Path, help="the sweep folder (--out of 'ramensim sweep')")
    ap.add_argument("dest", type=Path, help="where to keep its results (e.g. docs/results/paper/NAME)")
    ap.add_argument("--plan", type=Path, help="the whole protocol's sweep file, kept as the archive's plan")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    n = archive(args.sweep, args.dest)
    log.info("archived %d finished point(s) of %s into %s", n, args.sweep, args.dest)
    if args.plan is not None:
        log.info("kept the plan of %s (%d points) as %s", args.plan, keep_plan(args.plan, args.dest),
                 args.dest / store.PLAN)
    return 0


if __name__ == "__main__":
    sys.exit(main())
