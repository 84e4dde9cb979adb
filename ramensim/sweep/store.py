"""The on-disk layout of a sweep folder and crash-safe writes.

::

    OUT/sweep.json               the plan (axes, points, fingerprints), rewritten atomically per sweep
    OUT/.lock                    flock held while a sweep runs (released by the kernel on kill -9)
    OUT/runs/NAME/               a finished point: status.json (+ metrics.json, scenario.yaml, logs...)
    OUT/runs/.partial-NAME-XXXX/ a point being run; renamed to runs/NAME as the very last step
    OUT/summary.csv, summary.md, plots/   written by aggregation / ``ramensim report``

A point folder appears under its name only by an atomic ``rename`` of a finished temp folder,
and every JSON file is written to a temp file and ``os.replace``-d, so a reader never sees a
half-written result whatever moment the sweep is killed.
"""
from __future__ import annotations

import logging
import os
import shutil
import uuid
from pathlib import Path
from typing import Any

from ramensim.core.files import atomic_write_json, atomic_write_text, fsync_dir, read_json
from ramensim.runfolder import FolderLock

log = logging.getLogger(__name__)

__all__ = ["atomic_write_json", "atomic_write_text", "read_json"]  # re-exported for the sweep modules

RUNS = "runs"
PLAN = "sweep.json"
STATUS = "status.json"
METRICS = "metrics.json"
ERROR = "error.txt"
LOCK = ".lock"
PARTIAL_PREFIX = ".partial-"
TRASH_PREFIX = ".trash-"

COMPLETE = ("ok", "diverged")


def default_out(name: str) -> Path:
    """A sweep's folder when none is given: ``runs/sweeps/NAME`` relative to the working
    directory (beside single runs)."""
    return Path("runs") / "sweeps" / name
"""Statuses that are a result: resuming does not run these points again."""


def read_status(point_dir: Path) -> dict[str, Any] | None:
    """A committed point's status dict, or None when it has no readable one."""
    data = read_json(Path(point_dir) / STATUS)
    return data if isinstance(data, dict) else None


def is_complete(point_dir: Path, fingerprint: str | None = None) -> bool:
    """True when the folder holds a result (status ok/diverged and a metrics.json that parses as
    a JSON object) for the same resolved scenario (same fingerprint, when one is given)."""
    status = read_status(point_dir)
    if not status or status.get("status") not in COMPLETE:
        return False
    if fingerprint is not None and status.get("fingerprint") not in (None, fingerprint):
        return False
    # a result whose metrics.json does not parse (a torn copy, a full disk) is no result: the
    # report counts it failed, so a resume runs it again
    return isinstance(read_json(Path(point_dir) / METRICS), dict)


def new_partial_dir(runs_dir: Path, name: str) -> Path:
    """Create a fresh temp folder for a point that is about to run."""
    path = Path(runs_dir) / f"{PARTIAL_PREFIX}{name}-{uuid.uuid4().hex[:8]}"
    path.mkdir(parents=True)
    return path


def commit_dir(partial: Path, final: Path) -> None:
    """Atomically publish a finished point folder under its final name, replacing an older
    attempt (moved aside first, then deleted)."""
    final = Path(final)
    if final.exists():
        trash = final.with_name(f"{TRASH_PREFIX}{final.name}-{uuid.uuid4().hex[:8]}")
        os.rename(final, trash)
        os.rename(partial, final)
        shutil.rmtree(trash, ignore_errors=True)
    else:
        os.rename(partial, final)
    fsync_dir(final.parent)


def clean_leftovers(runs_dir: Path) -> int:
    """Delete temp and trash folders left by a killed sweep; returns how many were removed.
    Call only while holding the sweep lock."""
    runs_dir = Path(runs_dir)
    if not runs_dir.is_dir():
        return 0
    removed = 0
    for child in runs_dir.iterdir():
        if child.name.startswith((PARTIAL_PREFIX, TRASH_PREFIX)) and child.is_dir():
            shutil.rmtree(child, ignore_errors=True)
            removed += 1
    if removed:
        log.info("removed %d unfinished run folder(s) left by an interrupted sweep in %s", removed, runs_dir)
    return removed


class SweepLock(FolderLock):
    """Exclusive ``flock`` on ``OUT/.lock`` so two sweeps never write one folder at once."""

    lock_name = LOCK
    busy = "another sweep is running in this output folder"
    advice = "wait for it to finish or pass another --out"

