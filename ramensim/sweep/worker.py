"""Run one sweep point inside a worker process (local pool or Ray) and publish its folder.

The point runs in ``runs/.partial-NAME-XXXX``; its ``status.json`` (and ``metrics.json`` if the
run function did not write one) are written atomically, and the folder is renamed to
``runs/NAME`` as the last step. An exception inside the run is a *failed* point (message in
``status.json``, traceback in ``error.txt``), never a crashed sweep.
"""
from __future__ import annotations

import logging
import os
import shutil
import socket
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping

from ramensim.core.results import RunResult
from ramensim.costs import PARALLEL_ENV
from ramensim.sweep import store

if TYPE_CHECKING:
    from ramensim.sweep.transfer import Shipment

log = logging.getLogger(__name__)

RunFn = Callable[..., "RunResult | Mapping[str, Any]"]
"""``run_fn(scenario, out_dir[, base_dir=...]) -> metrics`` (default :func:`ramensim.lifecycle.run_scenario`);
``base_dir`` (the base scenario's folder) is passed when the function accepts it."""
ValidateFn = Callable[[dict[str, Any], str], Any]
"""``validate_fn(data, source) -> scenario`` (the default is :func:`ramensim.config.validate`)."""

_THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


@dataclass
class PointTask:
    """Everything a worker needs to run one point (picklable: functions must be importable)."""

    name: str
    axes: dict[str, Any]
    data: dict[str, Any]
    fingerprint: str
    source: str
    """Path of the base scenario (used by validation for messages and relative paths)."""
    runs_dir: str
    run_fn: RunFn | None = None
    validate_fn: ValidateFn | None = None
    threads: int | None = None
    """Torch/BLAS threads for this run (None: leave as is)."""
    fixed: dict[str, Any] = field(default_factory=dict)
    device: str | None = None
    """Torch device of the run's maps (``map.device``), an execution setting like ``threads``:
    the point and its fingerprint stay the plan's (None: the scenario's own ``map.device``)."""


@dataclass
class PointResult:
    """What a worker reports back about one point."""

    name: str
    status: str
    """'ok', 'diverged' or 'failed'."""
    error: str | None = None
    elapsed_s: float = 0.0


def init_worker(threads: int | None) -> None:
    """Process-pool initializer: cap BLAS/OpenMP threads before torch is imported (cores // workers)."""
    if threads:
        for var in _THREAD_VARS:
            os.environ[var] = str(threads)


def _set_threads(threads: int | None) -> None:
    if not threads:
        return
    init_worker(threads)
    torch = sys.modules.get("torch")
    if torch is not None and torch.get_num_threads() != threads:
        torch.set_num_threads(threads)


def diverged_agents(metrics: Mapping[str, Any]) -> list[Any]:
    """The agents a run reports as diverged (``diverged``/``diverged_agents``: list, or a count)."""
    for key in ("diverged_agents", "diverged"):
        value = metrics.get(key)
        if isinstance(value, (list, tuple)):
            return list(value)
        if isinstance(value, bool):
            return ["?"] if value else []
        if isinstance(value, int) and value > 0:
            return list(range(value))
    return []


def _accepts(fn: Callable[..., Any], name: str) -> bool:
    import inspect

    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False
    return name in params or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "(no message)"
    return f"{type(exc).__name__}: {text}"


def execute_point(task: PointTask) -> PointResult:
    """Validate and run one point in a temp folder, then publish it as ``runs/NAME``."""
    _set_threads(task.threads)
    runs_dir = Path(task.runs_dir)
    partial = store.new_partial_dir(runs_dir, task.name)
    started = time.time()
    status: dict[str, Any] = {
        "name": task.name, "status": "running", "axes": task.axes, "set": task.fixed,
        "fingerprint": task.fingerprint, "host": socket.gethostname(), "pid": os.getpid(),
        "started": started,
    }
    if task.device is not None:
        status["device"] = task.device
    store.atomic_write_json(partial / store.STATUS, status)
    error: str | None = None
    try:
        if task.validate_fn is None:
            from ramensim.config import validate as validate_fn
        else:
            validate_fn = task.validate_fn
        if task.run_fn is None:
            from ramensim.lifecycle import run_scenario as run_fn
        else:
            run_fn = task.run_fn
        data = task.data
        if task.device is not None:  # where the maps compute: not part of the point (its fingerprint)
            from ramensim.config import apply_overrides
            data = apply_overrides(data, {"map.device": task.device})
        scenario = validate_fn(data, task.source)
        if _accepts(run_fn, "base_dir"):  # relative paths resolve against the base scenario's folder
            metrics = run_fn(scenario, partial, base_dir=Path(task.source).parent)
        else:
            metrics = run_fn(scenario, partial)
        if isinstance(metrics, RunResult):
            if not (partial / store.METRICS).is_file():
                metrics.write(partial / store.METRICS)
            metrics = metrics.to_dict()
        metrics = dict(metrics or {})
        if not (partial / store.METRICS).is_file():
            store.atomic_write_json(partial / store.METRICS, metrics)
        run_status = metrics.get("status")
        if run_status == "interrupted":
            # the run stopped early (SIGINT/SIGTERM): not a result, so a resumed sweep runs it again
            state = "interrupted"
            error = f"the run ended with status 'interrupted': {metrics.get('error') or 'no detail'}"
        elif isinstance(run_status, str) and run_status not in ("ok", "diverged"):
            raise RuntimeError(f"the run ended with status {run_status!r}: {metrics.get('error') or 'no detail'}")
        else:
            bad = diverged_agents(metrics)
            state = "diverged" if bad else "ok"
            if bad:
                status["diverged_agents"] = bad
    except Exception as exc:  # noqa: BLE001 - any failure of a run is recorded, the sweep goes on
        state = "failed"
        error = _one_line(exc)
        try:
            store.atomic_write_text(partial / store.ERROR, traceback.format_exc())
        except OSError:
            pass  # a full disk: the error still travels in the point's result
        log.warning("sweep point %s failed: %s", task.name, error)
    elapsed = time.time() - started
    status.update(status=state, error=error, finished=time.time(), elapsed_s=elapsed)
    try:
        store.atomic_write_json(partial / store.STATUS, status)
        store.commit_dir(partial, runs_dir / task.name)
    except OSError as exc:  # a full disk: the point has no folder, so a resume runs it again
        state, error = "failed", f"{error + '; ' if error else ''}its folder could not be written: {exc.strerror or exc}"
        log.warning("sweep point %s: %s", task.name, error)
    return PointResult(task.name, state, error, elapsed)


def execute_point_shipped(task: PointTask, storage: str | None = None) -> "Shipment":
    """Ray task: run one point in a temp folder of the node it landed on (under ``storage``
    when given, else the node's temp dir) and hand the finished folder back to the driver, as
    a tar archive through Ray or as its path under ``storage`` (:mod:`.transfer`). Nothing is
    written to the node's working directory or to the driver's paths as seen from the node."""
    import tempfile
    from dataclasses import replace

    from ramensim.sweep.transfer import Shipment, manifest, pack

    if storage is not None:
        Path(storage).mkdir(parents=True, exist_ok=True)
    parent = Path(storage) if storage is not None else Path(tempfile.gettempdir())
    remove_dead_point_dirs(parent)
    tmp = Path(tempfile.mkdtemp(prefix=f"{POINT_DIR_PREFIX}{task.name[:60]}-", dir=storage))
    store.atomic_write_json(tmp / OWNER, {"pid": os.getpid(), "host": socket.gethostname()})
    keep = False
    try:
        result = execute_point(replace(task, runs_dir=str(tmp)))
        folder = tmp / task.name
        files = manifest(folder)
        if storage is not None:
            keep = True
            return Shipment(result, files, socket.gethostname(), location=str(folder))
        return Shipment(result, files, socket.gethostname(), archive=pack(folder))
    finally:
        if not keep:
            shutil.rmtree(tmp, ignore_errors=True)


POINT_DIR_PREFIX = "ramensim-point-"
"""Temp folders of Ray tasks: ``<tmp or storage>/ramensim-point-<name>-XXXX``."""
OWNER = ".owner.json"
"""In a Ray task's temp folder: the pid and host of the task that made it."""
STALE_S = 24 * 3600.0
"""A task temp folder without a readable owner is removed after this long (s)."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: someone else's live process
        return True
    return True


def remove_dead_point_dirs(parent: Path) -> int:
    """Remove the temp folders under ``parent`` left by Ray tasks that died (killed, lost node
    restarted): those whose owner process on this host is gone, or, without a readable owner,
    older than :data:`STALE_S`. A task calls it before making its own, so a killed task's
    folder (which grows with how far its run got) does not stay for ever. Returns how many."""
    host, removed = socket.gethostname(), 0
    try:
        candidates = [d for d in Path(parent).glob(f"{POINT_DIR_PREFIX}*") if d.is_dir()]
    except OSError:
        return 0
    for d in candidates:
        owner = store.read_json(d / OWNER)
        try:
            if isinstance(owner, dict):
                if owner.get("host") != host or _alive(int(owner["pid"])):
                    continue
            elif time.time() - d.stat().st_mtime < STALE_S:
                continue
        except (OSError, KeyError, TypeError, ValueError):
            continue
        shutil.rmtree(d, ignore_errors=True)
        removed += 1
    if removed:
        log.info("removed %d temp folder(s) of sweep tasks that died, under %s", removed, parent)
    return removed


def record_failure(task: PointTask, error: str, status: str = "failed") -> PointResult:
    """Publish a *failed* folder for a point whose worker died before it could (killed, out of
    memory, lost Ray node), or an *interrupted* one (``status``) for a point stopped with the
    sweep: written by the coordinating process."""
    runs_dir = Path(task.runs_dir)
    now = time.time()
    try:
        partial = store.new_partial_dir(runs_dir, task.name)
        store.atomic_write_json(partial / store.STATUS, {
            "name": task.name, "status": status, "axes": task.axes, "set": task.fixed,
            "fingerprint": task.fingerprint, "error": error, "finished": now, "elapsed_s": None,
        })
        store.atomic_write_text(partial / store.ERROR, error + "\n")
        store.commit_dir(partial, runs_dir / task.name)
    except OSError as exc:  # a full disk: recorded in memory only; a resume runs the point again
        log.warning("sweep point %s: %s (not recorded on disk: %s)", task.name, error, exc.strerror or exc)
    return PointResult(task.name, status, error, 0.0)


def _watch_parent(parent_pid: int, period_s: float = 0.5) -> None:
    while True:
        time.sleep(period_s)
        if os.getppid() != parent_pid:
            os._exit(1)


def init_pool_worker(threads: int | None, parent_pid: int, parallel: int = 1) -> None:
    """Initializer of local pool workers: cap threads, and die with the sweep process (Linux
    ``PR_SET_PDEATHSIG`` plus a parent-pid watchdog), so a ``kill -9`` of the sweep leaves no
    orphan still running (and later publishing) a point. ``parallel``: the runs going at once."""
    import threading

    init_worker(threads)
    os.environ[PARALLEL_ENV] = str(parallel)  # the run-cost ledger notes how many ran at once
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            import signal

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:  # parent already gone before prctl took effect
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True, name="parent-watch").start()
