"""The on-disk layout of a sweep folder and crash-safe writes.

::

    OUT/sweep.json               the plan (axes, points, fingerprints), rewritten atomically per sweep
    OUT/.lock                    flock held while a sweep plans (seconds; released by the kernel on kill -9)
    OUT/.sweeping                shared flock held by every sweep running in the folder
    OUT/runs/NAME/               a finished point: status.json (+ metrics.json, scenario.yaml, logs...)
    OUT/runs/.partial-NAME-XXXX/ a point being run; renamed to runs/NAME as the very last step
    OUT/runs/.claim-NAME         flock held by the sweep running point NAME, for as long as it runs it
    OUT/summary.csv, summary.md, plots/   written by aggregation / ``ramensim report``

A point folder appears under its name only by an atomic ``rename`` of a finished temp folder,
and every JSON file is written to a temp file and ``os.replace``-d, so a reader never sees a
half-written result whatever moment the sweep is killed.

Several sweeps of one plan may run in one folder at once (two processes on one machine, say):
each point is run by the sweep that claims it first (:class:`PointClaim`), the others pass over
it, and a sweep cleans up only the temp folders of points no sweep claims.
"""
from __future__ import annotations

import fcntl
import logging
import os
import shutil
import uuid
from pathlib import Path
from typing import Any

from ramensim.core.errors import InputError
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
CLAIM_PREFIX = ".claim-"
_SUFFIX = 9
"""Length of the ``-XXXXXXXX`` a temp or trash folder's name ends with (:func:`new_partial_dir`)."""

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
    """Delete the temp and trash folders of points that no sweep claims (left by a killed
    sweep), and the claim files such a sweep left; returns how many folders were removed. A
    folder of a point that another sweep sharing this folder is running is left alone. Call
    while holding the sweep lock."""
    runs_dir = Path(runs_dir)
    if not runs_dir.is_dir():
        return 0
    claimed_points(runs_dir)  # removes the free claim files on the way
    removed = 0
    for child in runs_dir.iterdir():
        if not (child.name.startswith((PARTIAL_PREFIX, TRASH_PREFIX)) and child.is_dir()):
            continue
        prefix = PARTIAL_PREFIX if child.name.startswith(PARTIAL_PREFIX) else TRASH_PREFIX
        claim = PointClaim(runs_dir, child.name[len(prefix):-_SUFFIX])
        if not claim.try_acquire():
            continue  # being run by another sweep in this folder
        try:
            shutil.rmtree(child, ignore_errors=True)
        finally:
            claim.release()
        removed += 1
    if removed:
        log.info("removed %d unfinished run folder(s) left by an interrupted sweep in %s", removed, runs_dir)
    return removed


def claimed_points(runs_dir: Path) -> list[str]:
    """The points that sweeps are running in this folder now (their claim is held), sorted.
    A claim file left by a killed sweep is free, and is removed on the way."""
    runs_dir = Path(runs_dir)
    if not runs_dir.is_dir():
        return []
    held = []
    for child in runs_dir.glob(f"{CLAIM_PREFIX}*"):
        name = child.name[len(CLAIM_PREFIX):]
        claim = PointClaim(runs_dir, name)
        if claim.try_acquire():
            claim.release()
        else:
            held.append(name)
    return sorted(held)


def same_plan(stored: Any, plan: dict[str, Any]) -> bool:
    """True when a folder's ``sweep.json`` (``stored``) plans the same points as ``plan``
    (names and fingerprints; where the file was read from may differ)."""
    if not isinstance(stored, dict) or stored.get("name") != plan.get("name"):
        return False

    def points(p: dict[str, Any]) -> list[tuple[Any, Any]]:
        return [(q.get("name"), q.get("fingerprint")) for q in p.get("points") or [] if isinstance(q, dict)]

    return points(stored) == points(plan)


class SweepLock(FolderLock):
    """Exclusive ``flock`` on ``OUT/.lock`` while a sweep plans (cleans up, writes
    ``sweep.json``, lists what is left to run): a few seconds, after which another sweep of
    the same plan may join (:class:`PointClaim`)."""

    lock_name = LOCK
    busy = "another sweep is running in this output folder"
    advice = "wait for it to finish or pass another --out"


class SweepPresence:
    """Shared ``flock`` on ``OUT/.sweeping``, held by every sweep running in the folder from
    the end of its planning to its end (the kernel releases it if the sweep is killed), so a
    sweep about to plan sees whether others run there. The empty file stays in the folder."""

    name = ".sweeping"

    def __init__(self, out_dir: Path) -> None:
        self.path = Path(out_dir) / self.name
        self._fd: int | None = None

    def others(self) -> bool:
        """True when another sweep holds the folder. Call under the :class:`SweepLock`, before
        :meth:`hold`."""
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        finally:
            os.close(fd)  # closing releases the probe's lock
        return False

    def hold(self) -> None:
        """Mark this sweep as running in the folder (under the :class:`SweepLock`)."""
        if self._fd is None:
            self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            fcntl.flock(self._fd, fcntl.LOCK_SH)

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


class PointClaim(FolderLock):
    """Exclusive ``flock`` on ``runs/.claim-NAME`` held by the sweep process that runs point NAME,
    from before its temp folder is made until its result (or failure) is in ``runs/NAME``, so
    that two sweeps sharing a folder never run one point at once. The kernel releases it if the
    sweep is killed."""

    busy = "another sweep is running this point"
    advice = "it is left to that sweep"

    def __init__(self, runs_dir: Path, name: str) -> None:
        super().__init__(Path(runs_dir))
        self.path = Path(runs_dir) / f"{CLAIM_PREFIX}{name}"

    def try_acquire(self) -> bool:
        """Take the claim if no one holds it; False (nothing taken) when another sweep does."""
        try:
            self.__enter__()
        except InputError:
            return False
        return True

    def release(self) -> None:
        """Give the claim up (its file is removed); nothing when not held."""
        self.__exit__(None, None, None)
