"""Keeping a sweep's results in the repository, without its meshes, so that the work goes on from
them on a fresh machine (docs/RESULTS.md, "The paper's horizon"), and putting them back
(``ramensim archive``).

:func:`archive` copies, for every finished point, its ``status.json``, ``metrics.json`` (the final
metrics, the timeline at every evaluation, the consensus probes) and ``scenario.yaml`` into
``DEST/runs/<point>/``, and the sweep's report (``summary.md``, ``summary.csv``, ``runs.csv``,
``runs_timeline.csv``, ``time_to_consensus.*``, ``report.html``, ``plots/*.png``) into ``DEST``.
:func:`report_is_current` tells whether ``DEST``'s ``runs.csv`` names exactly the finished runs
``DEST`` holds; it does not when the sweep ran with ``--no-report`` or when the sweep folder held
only part of the archive's runs (a batch, a second run seed on a fresh folder), and
:func:`redraw_report` then redraws the report from ``DEST`` itself (``ramensim archive`` does both).
:func:`keep_plan` keeps the whole protocol's plan as the archive's ``sweep.json`` when the protocol
runs in batches (subset files with the same name, base, settings and axis order, each rewriting
the folder's plan), so that the archive's report counts every run of the whole protocol, done and
missing. :func:`restore` is the inverse: the archived runs go back into the sweep folders, where
``ramensim sweep`` counts a point whose status.json and metrics.json are there (same resolved
scenario) as done and runs the rest.
"""
from __future__ import annotations

import csv
import json
import logging
import os
import shutil
import tempfile
from pathlib import Path

from ramensim.core.errors import InputError
from ramensim.sweep import store

log = logging.getLogger(__name__)

POINT_FILES = (store.STATUS, store.METRICS, "scenario.yaml")
"""What a finished point keeps in its archive."""
REPORT_FILES = ("summary.md", "summary.csv", "runs.csv", "runs_timeline.csv", "time_to_consensus.csv",
                "time_to_consensus.md", store.PLAN, "report.html", "report.json")
"""The sweep's report files an archive keeps (and ``plots/*.png``)."""


def archive(sweep: Path, dest: Path) -> int:
    """Copy the finished points and the report of the sweep folder ``sweep`` into ``dest``; returns
    the number of points copied; :class:`InputError` when ``sweep`` has no ``runs/`` folder."""
    runs = sweep / store.RUNS
    if not runs.is_dir():
        raise InputError(f"{sweep} has no runs/ folder; expected the --out folder of 'ramensim sweep'.")
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
    """Write the sweep file ``plan_file``'s plan as ``dest``'s sweep.json after checking that every
    archived point is one of its points with the same fingerprint; returns its number of points;
    :class:`InputError` (nothing written) for a point that is not the plan's."""
    from ramensim.sweep.spec import plan_sweep

    plan = plan_sweep(plan_file)
    prints = {p.name: p.fingerprint for p in plan.points}
    runs = dest / store.RUNS
    for point in sorted(p for p in runs.iterdir() if p.is_dir()) if runs.is_dir() else []:
        if point.name not in prints:
            raise InputError(f"{point} is not a point of {plan_file}; expected the batches to use its axes.")
        if not store.is_complete(point, prints[point.name]):
            raise InputError(f"{point} holds no result of the scenario {plan_file} plans for it "
                             f"(another fingerprint, or no complete result).")
    store.atomic_write_json(dest / store.PLAN, plan.to_json())
    return len(plan.points)


def report_is_current(dest: Path) -> bool:
    """True when ``dest/runs.csv`` lists exactly the finished runs in ``dest/runs/`` (by name);
    False when either is missing or they differ."""
    table = dest / "runs.csv"
    runs = dest / store.RUNS
    if not table.is_file() or not runs.is_dir():
        return False
    with table.open(encoding="utf-8", newline="") as f:
        listed = {row.get("name") for row in csv.DictReader(f)}
    done = {p.name for p in runs.iterdir() if p.is_dir() and store.is_complete(p)}
    return listed == done


def redraw_report(dest: Path) -> None:
    """Redraw ``dest``'s report from the runs it holds (:func:`ramensim.sweep.report.make_report`)
    with the options it was last drawn with (its ``report.json``: metrics, formats, html mode,
    style, width and the reference sweeps, relative to the folder; a reference no longer there is
    left out with a warning). A report drawn before report.json existed keeps the figure formats
    and report.html mode it has (default: PNG and SVG, figures embedded) and has no references."""
    from ramensim.sweep.report import REPORT_OPTIONS, make_report

    opts = store.read_json(dest / REPORT_OPTIONS) if (dest / REPORT_OPTIONS).is_file() else None
    if isinstance(opts, dict):
        refs = []
        for r in opts.get("references") or []:
            path = dest / r
            if path.is_dir():
                refs.append(path)
            else:
                log.warning("%s: its report was drawn with the reference sweep %s, which is not there "
                            "(%s); redrawn without it", dest, r, path)
        make_report(dest, metrics=opts.get("metrics"), formats=opts.get("formats") or ("png", "svg"),
                    digits=int(opts.get("digits", 2)), references=refs, html=opts.get("html") or "embedded",
                    style=opts.get("style") or "default", width=opts.get("width") or "column")
        return
    formats = sorted({f.suffix[1:] for f in (dest / "plots").glob("*.*")} & {"png", "svg", "pdf"}) \
        if (dest / "plots").is_dir() else []
    page = dest / "report.html"
    linked = page.is_file() and "data:image/png;base64," not in page.read_text(encoding="utf-8", errors="replace")
    make_report(dest, formats=formats or ("png", "svg"), html="linked" if linked else "embedded")


def restore(archives: Path, sweeps: Path) -> dict[str, int]:
    """Copy the archived runs missing from the sweep folders; returns the runs restored per sweep name.

    For every archive ``archives/<group>/<archive>/`` with a ``sweep.json`` (its plan names the
    sweep, e.g. ``paper_fig5``), each finished run in its ``runs/`` that ``sweeps/<name>/runs/``
    does not hold yet is copied there (status.json, metrics.json, scenario.yaml). A run already in
    the sweep folder is never touched, so this is safe to repeat and to run from two queues at once:
    each copy is made under a temporary name and renamed into place. :class:`InputError` for a
    ``sweep.json`` without a name."""
    done: dict[str, int] = {}
    for plan_file in sorted(archives.glob(f"*/*/{store.PLAN}")):
        folder = plan_file.parent
        try:
            name = json.loads(plan_file.read_text(encoding="utf-8"))["name"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{plan_file}: not a sweep plan with a 'name' ({exc}); expected the sweep.json "
                             f"that 'ramensim archive' keeps.") from None
        runs = folder / store.RUNS
        if not runs.is_dir():
            continue
        target = sweeps / str(name) / store.RUNS
        n = 0
        for point in sorted(p for p in runs.iterdir() if p.is_dir() and store.is_complete(p)):
            if (target / point.name).exists():
                continue
            target.mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=f".restore-{point.name}-", dir=target))
            for f in point.iterdir():
                if f.is_file():
                    shutil.copy2(f, tmp / f.name)
            try:
                os.rename(tmp, target / point.name)  # atomic; fails if another queue put it there first
                n += 1
            except OSError:
                shutil.rmtree(tmp, ignore_errors=True)
        if n:
            done[str(name)] = n
    return done
