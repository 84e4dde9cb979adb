"""Count finished runs of one sweep as points of another when both ran the same scenario, so
that a CPU-hour is not spent twice (docs/RESULTS.md, "The paper's horizon": the cause sweep
`cause/ramen_link_600.yaml` ran RAMEN on the 1-Tbit/s link on four trials, which are
`paper/dsgt_async.yaml`'s RAMEN points with clocks in step).

    python tools/adopt_runs.py SOURCE_RUN [SOURCE_RUN ...] --plan SWEEP_FILE --into SWEEP_FOLDER

A point's fingerprint hashes the scenario dict as its sweep file writes it, so two files that
reach the same scenario by different keys (one sets ``agents.compute.jitter: 0.0``, the other
leaves the default 0.0) give different fingerprints. This compares what the runs really ran:
each SOURCE_RUN's ``scenario.yaml`` and each planned point's scenario, both validated into the
full scenario with every default filled in. A source run that equals exactly one point is
copied into ``SWEEP_FOLDER/runs/<point>/`` with its status.json rewritten to that point (name,
axes, settings, fingerprint) and an ``adopted_from`` entry naming the source folder and its
original fingerprint; ``ramensim sweep`` then counts the point as done and
``tools/archive_sweep.py`` keeps it like any other. A point that already has a result is left
alone; a source that equals no point, or an unfinished source, is an error (exit 2) and nothing
of that source is written.
"""
from __future__ import annotations

import argparse
import logging
import shutil
import sys
from pathlib import Path
from typing import Any

from ramensim.core.errors import InputError
from ramensim.sweep import store

log = logging.getLogger("adopt_runs")


class InputProblem(Exception):
    """A source run or plan that cannot be adopted (one paragraph, exit 2)."""


def resolved(data: Any, source: str) -> dict[str, Any]:
    """The full scenario (every default filled in) of a scenario dict, as JSON-able data."""
    from ramensim import config

    return config.validate(data, source).model_dump(mode="json")


def match(source: Path, points: list[Any]) -> Any:
    """The one planned point whose resolved scenario equals the finished run ``source``'s."""
    from ramensim import config

    if not store.is_complete(source):
        raise InputProblem(f"{source}: no finished result (status.json with status ok or diverged and a "
                           f"readable metrics.json); expected a finished run folder of a sweep.")
    if not (source / "scenario.yaml").is_file():
        raise InputProblem(f"{source}: scenario.yaml is missing; expected the scenario the run wrote beside "
                           f"its metrics.json.")
    try:
        ran = resolved(config.load_scenario_dict(source / "scenario.yaml"), str(source / "scenario.yaml"))
    except InputError as exc:
        raise InputProblem(f"{source}: its scenario.yaml does not validate: {exc}") from None
    same = [p for p in points if resolved(p.data, p.name) == ran]
    if len(same) != 1:
        what = "no point" if not same else f"{len(same)} points ({', '.join(p.name for p in same)})"
        raise InputProblem(f"{source}: its scenario equals {what} of the plan; expected exactly one.")
    return same[0]


def adopt(source: Path, point: Any, fixed: dict[str, Any], runs_dir: Path) -> bool:
    """Copy ``source`` into ``runs_dir/<point>`` with its status rewritten to ``point`` (and the
    plan's fixed settings ``fixed``); False (nothing written) when the point already holds a
    result."""
    dest = runs_dir / point.name
    if store.is_complete(dest, point.fingerprint):
        log.info("%s: already done, left alone", dest)
        return False
    status = store.read_status(source) or {}
    partial = store.new_partial_dir(runs_dir, point.name)
    for f in source.iterdir():
        if f.is_file() and f.name != store.STATUS:
            shutil.copy2(f, partial / f.name)
    status.update(name=point.name, axes=point.axes, set=fixed, fingerprint=point.fingerprint,
                  adopted_from={"folder": str(source), "name": status.get("name"), "axes": status.get("axes"),
                                "set": status.get("set"), "fingerprint": status.get("fingerprint")})
    store.atomic_write_json(partial / store.STATUS, status)
    store.commit_dir(partial, dest)
    log.info("%s -> %s", source, dest)
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sources", type=Path, nargs="+", help="finished run folders of another sweep")
    ap.add_argument("--plan", type=Path, required=True, help="the sweep file whose points they may be")
    ap.add_argument("--into", type=Path, required=True, help="that sweep's folder (its --out)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    from ramensim.sweep.spec import plan_sweep

    try:
        try:
            plan = plan_sweep(args.plan)
        except InputError as exc:
            raise InputProblem(str(exc)) from None
        pairs = [(s, match(s, plan.points)) for s in args.sources]
        names = [p.name for _, p in pairs]
        if len(set(names)) != len(names):
            raise InputProblem(f"two sources are the same point of {args.plan} ({sorted(names)}); expected one each.")
    except InputProblem as exc:
        log.error("adopt_runs: %s", exc)
        return 2
    runs_dir = args.into / store.RUNS
    runs_dir.mkdir(parents=True, exist_ok=True)
    n = sum(adopt(s, p, plan.fixed, runs_dir) for s, p in pairs)
    log.info("adopted %d of %d run(s) into %s", n, len(pairs), runs_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
