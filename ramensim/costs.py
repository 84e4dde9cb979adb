"""Measured run costs on this machine, for the time a sweep will take before it starts.

Every finished run appends one line to ``$RAMENSIM_CACHE_DIR/run_costs.jsonl`` (default
``~/.cache/ramensim``, beside the kernel cache): its scenario name, method, agents,
simulated and wall seconds (``RunResult.wall_time_s``), threads, and how many runs were going
at once (a sweep's workers set ``RAMENSIM_PARALLEL_RUNS``). ``ramensim sweep --dry-run``
estimates each point's wall time as its simulated duration times the median wall seconds per
simulated second of the runs measured here with the same scenario name, method and about
the same duration (else the same scenario and method, else the same scenario), preferring
those measured with as many runs at once as the sweep will use, and divides the sum by the workers (W runs at once, each at its measured pace). Points
with no measured run are counted and named instead of guessed.
"""
from __future__ import annotations

import json
import logging
import os
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

log = logging.getLogger(__name__)

LEDGER = "run_costs.jsonl"
READ_LINES = 5000
"""Newest ledger lines read for an estimate (older runs may predate speed-ups)."""
PARALLEL_ENV = "RAMENSIM_PARALLEL_RUNS"
"""Set by a sweep's local workers to the number of runs going at once."""


LEDGER_ENV = "RAMENSIM_RUN_COSTS"
"""A file to use as the ledger instead (the test suite points it at a temporary file, so its
tiny runs do not enter this machine's estimates)."""


def ledger_path() -> Path:
    """``$RAMENSIM_RUN_COSTS``, else ``$RAMENSIM_CACHE_DIR/run_costs.jsonl`` (default
    ``~/.cache/ramensim``)."""
    if os.environ.get(LEDGER_ENV):
        return Path(os.environ[LEDGER_ENV])
    root = os.environ.get("RAMENSIM_CACHE_DIR") or Path.home() / ".cache" / "ramensim"
    return Path(root) / LEDGER


def record(scenario: str, method: str, agents: int, sim_s: float, wall_s: float, status: str) -> None:
    """Append one finished run's cost to the ledger; a run never fails for it (a read-only or
    full disk leaves the ledger as it was, logged at debug level)."""
    if status not in ("ok", "diverged") or not (sim_s > 0 and wall_s > 0):
        return  # an interrupted or failed run's pace says nothing about a whole one
    torch = sys.modules.get("torch")  # a run has it loaded; never imported here
    line = {"scenario": scenario, "method": method, "agents": int(agents), "sim_s": round(float(sim_s), 3),
            "wall_s": round(float(wall_s), 3), "parallel": _parallel(),
            "threads": int(torch.get_num_threads()) if torch is not None else None,
            "time": time.strftime("%Y-%m-%dT%H:%M:%S")}
    path = ledger_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a", encoding="utf-8") as fh:  # one short line: appends do not interleave
            fh.write(json.dumps(line, sort_keys=True) + "\n")
    except OSError as exc:
        log.debug("run cost not recorded in %s: %s", path, exc)


def _parallel() -> int:
    try:
        return max(1, int(os.environ.get(PARALLEL_ENV, "1")))
    except ValueError:
        return 1


def load(path: Path | None = None) -> list[dict[str, Any]]:
    """The newest :data:`READ_LINES` ledger entries that parse (others are skipped)."""
    path = ledger_path() if path is None else path
    try:
        lines = path.read_text(encoding="utf-8").splitlines()[-READ_LINES:]
    except (OSError, UnicodeDecodeError):
        return []
    out = []
    for ln in lines:
        try:
            e = json.loads(ln)
            if isinstance(e, dict) and float(e["sim_s"]) > 0 and float(e["wall_s"]) > 0:
                out.append(e)
        except (ValueError, KeyError, TypeError):
            continue
    return out


@dataclass
class Estimate:
    """Estimated wall time of a sweep's points (s) and what it rests on."""

    wall_s: float = 0.0
    """Sum over the estimated points of their wall time, over the workers (s)."""
    measured: int = 0
    """Points with a measured pace."""
    unknown: list[str] = field(default_factory=list)
    """Points with no measured run of their scenario on this machine."""
    runs_used: int = 0
    """Ledger entries the estimate rests on."""


def pace(entries: Iterable[dict[str, Any]], scenario: str, method: str, parallel: int,
         duration: float | None = None) -> tuple[float, int] | None:
    """Median wall seconds per simulated second of the measured runs of ``scenario`` with
    ``method`` and about this simulated ``duration`` (within 25 %: a run's start-up and final
    evaluation weigh more in a short run), else of ``scenario`` with ``method``, else of
    ``scenario``; among them those measured with ``parallel`` runs at once if any. Returns the
    pace and how many runs it rests on; None when nothing matches."""
    entries = list(entries)

    def near(e: dict[str, Any]) -> bool:
        return duration is not None and abs(float(e["sim_s"]) - duration) <= 0.25 * duration

    for pick in (lambda e: e.get("scenario") == scenario and e.get("method") == method and near(e),
                 lambda e: e.get("scenario") == scenario and e.get("method") == method,
                 lambda e: e.get("scenario") == scenario):
        match = [e for e in entries if pick(e)]
        if match:
            same = [e for e in match if int(e.get("parallel") or 1) == parallel]
            use = same or match
            return statistics.median(float(e["wall_s"]) / float(e["sim_s"]) for e in use), len(use)
    return None


def estimate(points: Iterable[tuple[str, str, str, float]], workers: int,
             entries: list[dict[str, Any]] | None = None) -> Estimate:
    """:class:`Estimate` of ``points`` (name, scenario name, method, simulated duration s) run
    by ``workers`` at once, from the ledger (or ``entries``)."""
    entries = load() if entries is None else entries
    est = Estimate()
    used = 0
    total = 0.0
    for name, scenario, method, duration in points:
        p = pace(entries, scenario, method, workers, duration)
        if p is None:
            est.unknown.append(name)
            continue
        total += p[0] * duration
        used = max(used, p[1])
        est.measured += 1
    est.wall_s = total / max(1, workers)
    est.runs_used = used
    return est
