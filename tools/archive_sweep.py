"""Keep a sweep's results in the repository, without its meshes, so that the work goes on from
them on a fresh machine (docs/RESULTS.md, "The paper's horizon").

    python tools/archive_sweep.py runs/sweeps/paper_table1 docs/results/paper/paper_table1

copies, for every finished point, its ``status.json``, ``metrics.json`` (the final metrics, the
timeline at every evaluation, the consensus probes) and ``scenario.yaml`` into
``DEST/runs/<point>/``, and the sweep's report (``summary.md``, ``summary.csv``, ``runs.csv``,
``runs_timeline.csv``, ``time_to_consensus.*``, ``report.html``, ``plots/*.png``) into ``DEST``. To resume on a
fresh machine, copy ``DEST/runs`` back into the sweep folder: ``ramensim sweep`` counts a point
whose status.json and metrics.json are there (same resolved scenario) as done and runs the rest.
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sweep", type=Path, help="the sweep folder (--out of 'ramensim sweep')")
    ap.add_argument("dest", type=Path, help="where to keep its results (e.g. docs/results/paper/NAME)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    n = archive(args.sweep, args.dest)
    log.info("archived %d finished point(s) of %s into %s", n, args.sweep, args.dest)
    return 0


if __name__ == "__main__":
    sys.exit(main())
