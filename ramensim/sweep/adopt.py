"""Counting finished runs of one sweep as points of another when both ran the same scenario, so
that a CPU-hour is not spent twice (docs/RESULTS.md, "The paper's horizon": the cause sweep
`cause/ramen_link_600.yaml` ran RAMEN on the 1-Tbit/s link on four trials, which are
`paper/dsgt_async.yaml`'s RAMEN points with clocks in step; ``ramensim archive --adopt``).

A point's fingerprint hashes the scenario dict as its sweep file writes it, so two files that
reach the same scenario by different keys (one sets ``agents.compute.jitter: 0.0``, the other
leaves the default 0.0) give different fingerprints. :func:`match` compares what the runs really
ran: a source run's ``scenario.yaml`` and each planned point's scenario, both validated into the
full scenario with every default filled in. A source run that equals exactly one point is copied
into ``SWEEP_FOLDER/runs/<point>/`` by :func:`adopt`, with its status.json rewritten to that point
(name, axes, settings, fingerprint) and an ``adopted_from`` entry naming the source folder and its
original fingerprint; ``ramensim sweep`` then counts the point as done and ``ramensim archive``
keeps it like any other. A point that already has a result is left alone; :func:`adopt_all` writes
nothing when one source equals no point or is unfinished.
"""
from __future__ import annotations

import logging
import shutil
from pathlib import Path
from typing import Any

from ramensim.core.errors import InputError
from ramensim.sweep import store

log = logging.getLogger(__name__)


def resolved(data: Any, source: str) -> dict[str, Any]:
    """The full scenario (every default filled in) of a scenario dict, as JSON-able data."""
    from ramensim import config

    return config.validate(data, source).model_dump(mode="json")


def match(source: Path, points: list[Any]) -> Any:
    """The one planned point of ``points`` whose resolved scenario equals the finished run
    ``source``'s; :class:`InputError` for an unfinished source or one that equals no point or several."""
    from ramensim import config

    if not store.is_complete(source):
        raise InputError(f"{source}: no finished result (status.json with status ok or diverged and a "
                         f"readable metrics.json); expected a finished run folder of a sweep.")
    if not (source / "scenario.yaml").is_file():
        raise InputError(f"{source}: scenario.yaml is missing; expected the scenario the run wrote beside "
                         f"its metrics.json.")
    try:
        ran = resolved(config.load_scenario_dict(source / "scenario.yaml"), str(source / "scenario.yaml"))
    except InputError as exc:
        raise InputError(f"{source}: its scenario.yaml does not validate: {exc}") from None
    same = [p for p in points if resolved(p.data, p.name) == ran]
    if len(same) != 1:
        what = "no point" if not same else f"{len(same)} points ({', '.join(p.name for p in same)})"
        raise InputError(f"{source}: its scenario equals {what} of the plan; expected exactly one.")
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


def adopt_all(sources: list[Path], plan_file: Path, into: Path) -> tuple[int, int]:
    """Adopt each finished run of ``sources`` as its point of the sweep file ``plan_file`` into the
    sweep folder ``into``; returns (runs adopted, sources). Every source is matched before anything
    is written: :class:`InputError` (nothing written) for a plan that cannot be read, a source that
    equals no point, and two sources that are the same point."""
    from ramensim.sweep.spec import plan_sweep

    plan = plan_sweep(plan_file)
    pairs = [(s, match(s, plan.points)) for s in sources]
    names = [p.name for _, p in pairs]
    if len(set(names)) != len(names):
        raise InputError(f"two sources are the same point of {plan_file} ({sorted(names)}); expected one each.")
    runs_dir = into / store.RUNS
    runs_dir.mkdir(parents=True, exist_ok=True)
    n = sum(adopt(s, p, plan.fixed, runs_dir) for s, p in pairs)
    log.info("adopted %d of %d run(s) into %s", n, len(pairs), runs_dir)
    return n, len(pairs)
