"""Run a sweep: every point without a complete result, on a local process pool or on Ray,
with a progress bar, crash-safe and resumable (layout and atomic writes in :mod:`.store`).

Re-running the same sweep into the same folder runs only the points that have no complete
result (status ok/diverged with metrics) for the same resolved scenario; failed points are
run again unless ``retry_failed=False``. Two sweeps of one plan started on one folder share its
points: each point is run by the one that claims it first (:class:`ramensim.sweep.store.PointClaim`).
"""
from __future__ import annotations

import logging
import multiprocessing as mp
import os
import time
from collections import deque
from contextlib import contextmanager
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from functools import partial
from typing import Any, Callable, Iterator, Literal

from ramensim.core.errors import InputError
from ramensim.sweep import store
from ramensim.sweep.spec import SweepPlan
from ramensim.sweep.worker import (PointResult, PointTask, RunFn, ValidateFn, execute_point,
                                   init_pool_worker, record_failure)

log = logging.getLogger(__name__)

MAX_WORKER_DEATHS = 2
"""A point whose worker process dies this many times (OOM, killed) is recorded as failed."""

PLAN_LOCK_WAIT_S = 30.0
"""How long a sweep waits for another one to finish planning in the same folder (s)."""


@dataclass
class SweepOutcome:
    """Counts of one sweep invocation."""

    out_dir: Path
    total: int
    """Points in the plan."""
    skipped: int = 0
    """Points that already had a complete result (when the sweep planned, or one that reached the
    folder while it ran)."""
    ok: list[str] = field(default_factory=list)
    diverged: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    """Point name -> one-line error."""
    interrupted: list[str] = field(default_factory=list)
    """Points that were running when the sweep was stopped (SIGTERM, Ctrl-C): recorded as
    'interrupted', run again on resume."""
    elsewhere: list[str] = field(default_factory=list)
    """Points left to another sweep of the same plan in the same folder, which was running
    them when this one came to them."""


class SweepInterrupted(KeyboardInterrupt):
    """The sweep was stopped (SIGTERM, Ctrl-C) after its running points were ended and
    recorded; ``outcome`` holds what finished before."""

    def __init__(self, outcome: SweepOutcome) -> None:
        super().__init__(f"sweep interrupted: {len(outcome.interrupted)} running point(s) stopped")
        self.outcome = outcome


def default_workers() -> int:
    """min(2, CPU count) local worker processes."""
    return max(1, min(2, os.cpu_count() or 1))


def pending_points(plan: SweepPlan, out_dir: Path, retry_failed: bool = True) -> tuple[list[str], int]:
    """Names of the points to run (in plan order) and how many already have a result."""
    runs = Path(out_dir) / store.RUNS
    todo, done = [], 0
    for p in plan.points:
        folder = runs / p.name
        if store.is_complete(folder, p.fingerprint):
            done += 1
            continue
        status = store.read_status(folder)
        if status and status.get("status") in store.COMPLETE:
            log.info("point %s: stored result is for another scenario (base or 'set' changed); running it again",
                     p.name)
        elif status and status.get("status") == "failed" and not retry_failed:
            done += 1
            continue
        todo.append(p.name)
    return todo, done


class _Bar:
    """Rich progress bar: done / running / failed."""

    def __init__(self, total: int, done: int, enabled: bool, title: str) -> None:
        self._progress = None
        if not enabled:
            return
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn,
                                   TimeElapsedColumn, TimeRemainingColumn)

        self._progress = Progress(
            SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("running {task.fields[running]}  failed {task.fields[failed]}"),
            TimeElapsedColumn(), TimeRemainingColumn(), transient=False)
        self._task = self._progress.add_task(title, total=total, completed=done, running=0, failed=0)
        self._progress.start()

    def update(self, done: int, running: int, failed: int) -> None:
        if self._progress is not None:
            self._progress.update(self._task, completed=done, running=running, failed=failed)

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()


def run_sweep(plan: SweepPlan, out_dir: str | Path, *, workers: int | None = None,
              executor: Literal["local", "ray"] = "local", address: str | None = None,
              run_fn: RunFn | None = None, validate_fn: ValidateFn | None = None,
              threads: int | None = None, retry_failed: bool = True, progress: bool = True,
              storage: str | Path | None = None, only: set[str] | None = None,
              device: str | None = None) -> SweepOutcome:
    """Run every point of ``plan`` that lacks a complete result into ``out_dir/runs/NAME``.

    ``run_fn(scenario, out_dir) -> metrics`` defaults to :func:`ramensim.lifecycle.run_scenario` and
    ``validate_fn`` to :func:`ramensim.config.validate`; injected ones must be importable
    module-level functions (they are pickled by reference into worker processes).
    ``threads`` per run defaults to CPU count // workers. A failed run is recorded and the
    sweep goes on; a second sweep in the same folder at the same time is refused.
    Local workers are *spawned*: a script that calls this must guard its top level with
    ``if __name__ == "__main__":`` (the ``ramensim`` command does).

    On Ray each point runs in a temp folder of the node it lands on and its finished folder
    comes back to ``out_dir`` through Ray, or, with ``storage`` (a folder mounted at the same
    path on every node and on this machine), through that folder (:mod:`.transfer`).

    ``only`` (point names, :func:`ramensim.sweep.spec.select_points`): run just those of the
    pending points; the others stay pending, and ``sweep.json`` keeps the whole plan.

    ``device`` (``cpu``, ``cuda``, ``auto``): the torch device of every run's maps instead of the
    scenario's ``map.device``; like ``threads`` it says where the runs compute, not what they
    are, so the points and their fingerprints stay the plan's and a run made on a GPU completes
    the same point as one made on the CPU (they differ by float rounding,
    docs/MAP_PERFORMANCE.md, "On a GPU"). Each run's ``scenario.yaml`` and ``metrics.json``
    (``build.device``) record the device it ran on.
    """
    out = Path(out_dir)
    if workers is not None and workers < 1:
        raise InputError(f"--workers {workers}: expected a positive number of worker processes.")
    if executor not in ("local", "ray"):
        raise InputError(f"--executor {executor!r}: expected 'local' or 'ray'.")
    storage_dir = _storage_dir(storage, executor)
    out.mkdir(parents=True, exist_ok=True)
    runs = out / store.RUNS
    runs.mkdir(exist_ok=True)
    presence = store.SweepPresence(out)
    try:
        todo, outcome = _plan_folder(plan, out, presence, retry_failed, only)
        if not todo:
            return outcome
        by_name = {p.name: p for p in plan.points}
        tasks = [PointTask(name=n, axes=by_name[n].axes, data=by_name[n].data,
                           fingerprint=by_name[n].fingerprint, source=str(plan.base), runs_dir=str(runs),
                           run_fn=run_fn, validate_fn=validate_fn, fixed=plan.fixed, device=device)
                 for n in todo]
        bar = _Bar(len(plan.points), outcome.skipped, progress, f"sweep {plan.name}")
        claims = _Claims(runs)
        try:
            if executor == "local":
                _run_local(tasks, outcome, bar, _workers_that_fit(tasks, workers or default_workers(),
                                                                  validate_fn), threads, claims)
            else:
                _run_ray(tasks, outcome, bar, workers, threads, address, storage_dir, claims)
        except KeyboardInterrupt:
            log.warning("sweep %s interrupted: %d ok, %d diverged, %d failed, %d stopped while running "
                        "(recorded as interrupted; run the sweep again to finish them)", plan.name,
                        len(outcome.ok), len(outcome.diverged), len(outcome.failed), len(outcome.interrupted))
            raise SweepInterrupted(outcome) from None
        finally:
            claims.release_all()  # after the stopped points were recorded
            bar.close()
        if outcome.elsewhere:
            log.info("sweep %s: %d point(s) left to the other sweep running in %s: %s", plan.name,
                     len(outcome.elsewhere), out, ", ".join(outcome.elsewhere))
        # debug: the caller reports the outcome (the CLI prints this line with the folder)
        log.debug("sweep %s: %d ok, %d diverged, %d failed, %d already done", plan.name, len(outcome.ok),
                 len(outcome.diverged), len(outcome.failed), outcome.skipped)
        return outcome
    finally:
        presence.release()


def _plan_folder(plan: SweepPlan, out: Path, presence: store.SweepPresence, retry_failed: bool,
                 only: set[str] | None) -> tuple[list[str], SweepOutcome]:
    """Under the folder lock: join the sweep of the same plan running in ``out`` (refuse one
    of another plan), mark this sweep present, clean up what no sweep claims, write
    ``sweep.json`` and list the points to run (those of ``only``, when given)."""
    runs = out / store.RUNS
    with _plan_lock(out):
        planned = plan.to_json()
        if presence.others():
            if not store.same_plan(store.read_json(out / store.PLAN), planned):
                running = store.claimed_points(runs)
                doing = (f"it runs {running[0]}" + (f" and {len(running) - 1} more" if len(running) > 1 else "")
                         if running else "it is starting")
                raise InputError(f"{out}: another sweep with a different plan is running in this output folder "
                                 f"({doing}); wait for it to finish or pass another --out.")
            log.info("sweep %s: joining the sweep of the same plan running in %s", plan.name, out)
        presence.hold()
        store.clean_leftovers(runs)
        store.atomic_write_json(out / store.PLAN, planned)
        todo, done = pending_points(plan, out, retry_failed)
    outcome = SweepOutcome(out_dir=out, total=len(plan.points), skipped=done)
    if only is not None:
        left = len(todo)
        todo = [n for n in todo if n in only]
        log.info("sweep %s: --only selects %d of the %d points without a result; %d stay for a later run",
                 plan.name, len(todo), left, left - len(todo))
    elif done:
        log.info("sweep %s: %d of %d points already have a result; running the other %d",
                 plan.name, done, len(plan.points), len(todo))
    return todo, outcome


@contextmanager
def _plan_lock(out: Path, wait_s: float | None = None) -> Iterator[None]:
    """Hold the sweep folder's lock while planning: waits up to ``wait_s`` (default
    :data:`PLAN_LOCK_WAIT_S`) while another sweep plans there, then refuses (InputError:
    another sweep is running in this output folder)."""
    deadline = time.monotonic() + (PLAN_LOCK_WAIT_S if wait_s is None else wait_s)
    lock = store.SweepLock(out)
    while True:
        try:
            lock.__enter__()
            break
        except InputError:
            if time.monotonic() >= deadline:
                raise
            time.sleep(0.2)
    try:
        yield
    finally:
        lock.__exit__(None, None, None)


class _Claims:
    """The points this sweep has claimed (:class:`ramensim.sweep.store.PointClaim`), by name."""

    def __init__(self, runs_dir: Path) -> None:
        self.runs_dir = Path(runs_dir)
        self.held: dict[str, store.PointClaim] = {}

    def take(self, name: str) -> bool:
        """Claim a point; False when another sweep in the folder is running it."""
        claim = store.PointClaim(self.runs_dir, name)
        if not claim.try_acquire():
            return False
        self.held[name] = claim
        return True

    def release(self, name: str) -> None:
        claim = self.held.pop(name, None)
        if claim is not None:
            claim.release()

    def release_all(self) -> None:
        for name in list(self.held):
            self.release(name)


def _workers_that_fit(tasks: list[PointTask], workers: int, validate_fn: ValidateFn | None) -> int:
    """The local worker count lowered to what the machine's memory holds (``ramensim.memory``);
    InputError naming a point too large to run at all. Points whose estimate cannot be made
    (an injected scenario type in tests) are left out of the check."""
    from ramensim import config
    from ramensim.memory import scenario_estimate, sweep_workers_that_fit

    if validate_fn is not None:
        return workers
    estimates = {}
    for t in tasks:
        try:
            estimates[t.name] = scenario_estimate(config.validate(t.data, t.source))
        except (InputError, ValueError, KeyError, AttributeError):
            continue
    return sweep_workers_that_fit(estimates, workers)


def _storage_dir(storage: str | Path | None, executor: str) -> Path | None:
    """The storage folder as an absolute path (the same on every node), or None."""
    if storage is None:
        return None
    if executor != "ray":
        raise InputError(f"--storage {storage}: only used with --executor ray (local runs write into the "
                         f"sweep folder directly).")
    text = str(storage)
    if "://" in text:
        raise InputError(f"--storage {text}: expected a folder path mounted at the same place on every Ray node "
                         f"(e.g. an NFS mount); URLs such as s3:// are not supported.")
    return Path(text).expanduser().resolve()


def _account(outcome: SweepOutcome, result: PointResult) -> None:
    if result.status == "ok":
        outcome.ok.append(result.name)
    elif result.status == "diverged":
        outcome.diverged.append(result.name)
    else:
        outcome.failed[result.name] = result.error or "failed"


def _finished(outcome: SweepOutcome) -> int:
    return (outcome.skipped + len(outcome.ok) + len(outcome.diverged) + len(outcome.failed)
            + len(outcome.interrupted))


def _drain(queue: deque[PointTask], workers: int, submit: Callable[[PointTask], Future], outcome: SweepOutcome,
           bar: _Bar, failure_prefix: str,
           receive: Callable[[PointTask, Any], PointResult] | None = None,
           inflight: dict[Future, PointTask] | None = None, claims: _Claims | None = None) -> list[PointTask]:
    """Keep ``workers`` points in flight through ``submit`` (a process pool or Ray, both as
    ``concurrent.futures`` futures) until ``queue`` is empty, accounting each result. A point
    whose future raises is published as failed. ``receive(task, value)`` turns a future's
    value into the point's result once its files are in the sweep folder (Ray: unpack the
    shipped folder); a point whose files do not arrive is published as failed. Returns the
    in-flight points lost when a local pool breaks (a worker process died); the caller decides
    whether to run them again. ``inflight`` (the caller's, when given) holds the points running
    at any moment, so the caller can stop and record them when the sweep is interrupted.
    ``claims`` (the caller's, when given): each point is claimed before it starts and given up
    once its result is accounted; a point another sweep has claimed is left to it
    (``outcome.elsewhere``). The claims of points still in flight when this returns or raises
    are the caller's to give up."""
    inflight = {} if inflight is None else inflight

    def settle(result: PointResult) -> None:  # the point's result is in its folder: account it, give it up
        _account(outcome, result)
        if claims is not None:
            claims.release(result.name)
    while queue or inflight:
        while queue and len(inflight) < workers:
            task = queue.popleft()
            if claims is not None and not claims.take(task.name):
                log.info("point %s: another sweep in this folder is running it; leaving it to that sweep", task.name)
                outcome.elsewhere.append(task.name)
                continue
            if store.is_complete(Path(task.runs_dir) / task.name, task.fingerprint):
                # finished elsewhere since the sweep planned (another sweep in this folder, or a
                # run made on a GPU machine and copied in)
                log.info("point %s: a result for it reached the sweep folder while this sweep ran; "
                         "not running it again", task.name)
                outcome.skipped += 1
                if claims is not None:
                    claims.release(task.name)
                continue
            inflight[submit(task)] = task
        bar.update(_finished(outcome), len(inflight), len(outcome.failed))
        finished, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
        for fut in finished:
            task = inflight.pop(fut)
            try:
                value = fut.result()
            except BrokenProcessPool:
                return [task, *inflight.values()]
            except Exception as exc:  # noqa: BLE001 - worker crash, lost node, disk full while publishing
                msg = " ".join(str(exc).split())[:500]
                settle(record_failure(task, f"{failure_prefix}{type(exc).__name__}: {msg}"))
                continue
            if receive is None:
                settle(value)
                continue
            try:
                result = receive(task, value)
            except Exception as exc:  # noqa: BLE001 - files lost on the way: the point has no result
                msg = " ".join(str(exc).split())[:500]
                log.warning("sweep point %s: its files did not reach the sweep folder: %s", task.name, msg)
                result = record_failure(task, f"the run ended on its node but its files did not reach the sweep "
                                              f"folder: {type(exc).__name__}: {msg}")
            settle(result)
        bar.update(_finished(outcome), len(inflight), len(outcome.failed))
    return []


def _run_local(tasks: list[PointTask], outcome: SweepOutcome, bar: _Bar, workers: int,
               threads: int | None, claims: _Claims | None = None) -> None:
    workers = min(workers, len(tasks))
    threads = threads or max(1, (os.cpu_count() or 1) // workers)
    log.info("running %d point(s) on %d worker process(es) x %d thread(s) each (%d CPUs; docs/BENCHMARKS.md: "
             "two single-threaded runs at once finish 1.3x as many runs per hour as one run on two threads)",
             len(tasks), workers, threads, os.cpu_count() or 1)
    for t in tasks:
        t.threads = threads
    ctx = mp.get_context("spawn")
    queue = deque(tasks)
    deaths: dict[str, int] = {}
    while queue:
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=init_pool_worker,
                                   initargs=(threads, os.getpid(), workers))
        lost: list[PointTask] = []
        inflight: dict[Future, PointTask] = {}
        stopped = False
        try:
            lost = _drain(queue, workers, partial(pool.submit, execute_point), outcome, bar, "", inflight=inflight,
                          claims=claims)
        except KeyboardInterrupt:
            stopped = True
            _kill_pool_workers(pool)
            _record_stopped(inflight, outcome)
            raise
        finally:
            pool.shutdown(wait=not (lost or stopped), cancel_futures=True)
        # A worker died (killed, out of memory): every in-flight point of that pool is lost.
        for task in lost:
            deaths[task.name] = deaths.get(task.name, 0) + 1
            if deaths[task.name] >= MAX_WORKER_DEATHS:
                _account(outcome, record_failure(
                    task, f"the worker process running this point died {deaths[task.name]} times "
                          f"(killed or out of memory)"))
            if claims is not None:
                claims.release(task.name)  # run again below (claimed anew) or recorded as failed
            if deaths[task.name] < MAX_WORKER_DEATHS:
                log.warning("a worker process died while running %s; running it again", task.name)
                queue.appendleft(task)
        bar.update(_finished(outcome), 0, len(outcome.failed))


def _kill_pool_workers(pool: ProcessPoolExecutor, timeout_s: float = 5.0) -> None:
    """End a local pool's worker processes at once (SIGKILL). A run stopped by a signal would
    still spend its final evaluation (tens of seconds at the paper's horizon) on a result that
    is not kept: a resumed sweep runs an interrupted point again from the start."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for proc in procs:
        if proc.is_alive():
            proc.kill()
    for proc in procs:
        proc.join(timeout_s)


def _record_stopped(inflight: dict[Future, PointTask], outcome: SweepOutcome) -> None:
    """Account the points that were running when the sweep stopped: one that finished in the
    meantime with its result, every other one as *interrupted* (status.json written by this
    process; ``pending_points`` runs it again)."""
    for fut, task in inflight.items():
        if fut.done() and not fut.cancelled() and fut.exception() is None:
            result = fut.result()
            if isinstance(result, PointResult):
                _account(outcome, result)
                continue
        if store.is_complete(Path(task.runs_dir) / task.name, task.fingerprint):
            outcome.ok.append(task.name)
            continue
        record_failure(task, "the sweep was stopped (SIGTERM or Ctrl-C) while this point ran; "
                             "running the sweep again runs it from the start", status="interrupted")
        outcome.interrupted.append(task.name)


def _run_ray(tasks: list[PointTask], outcome: SweepOutcome, bar: _Bar, workers: int | None,
             threads: int | None, address: str | None, storage: Path | None = None,
             claims: _Claims | None = None) -> None:
    """Run the points as Ray tasks. Each task runs its point in a temp folder of its own node
    and sends the finished folder back (:func:`ramensim.sweep.worker.execute_point_shipped`);
    the driver puts it into ``runs/NAME`` (:func:`ramensim.sweep.transfer.receive`) before
    the point counts as done, so the sweep folder is complete whatever the nodes' working
    directories or file systems."""
    try:
        import ray
    except ImportError:
        raise InputError("--executor ray: the 'ray' package is not installed; install the optional extra "
                         "with: pip install 'ramensim[ray]' (or use --executor local).") from None
    from ramensim.sweep.transfer import receive
    from ramensim.sweep.worker import execute_point_shipped

    started_here = False
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address:
            kwargs["address"] = address
        elif workers:
            kwargs["num_cpus"] = workers * (threads or 1)
        try:
            ray.init(**kwargs)
        except ConnectionError as exc:
            raise InputError(f"--address {address}: could not connect to a Ray cluster there "
                             f"({' '.join(str(exc).split())[:300]}).") from None
        started_here = True
    refs: dict[Future, Any] = {}

    def submit(task: PointTask) -> Future:
        ref = remote.remote(task, str(storage) if storage is not None else None)
        fut = ref.future()
        refs[fut] = ref
        return fut

    def arrived(task: PointTask, shipment: Any) -> PointResult:
        receive(shipment, Path(task.runs_dir), task.name)
        log.info("sweep point %s: %s on %s, %d files in the sweep folder", task.name, shipment.result.status,
                 shipment.host, len(shipment.manifest))
        return shipment.result

    try:
        cpus = int(ray.cluster_resources().get("CPU", 1))
        threads = threads or 1
        workers = workers or max(1, cpus // threads)
        for t in tasks:
            t.threads = threads
        # the driver's OpenMP wait policy (the CLI and API set PASSIVE unless the user chose one)
        # travels to the workers, which Ray starts with their own environment
        omp = {k: os.environ[k] for k in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT") if k in os.environ}
        remote = ray.remote(num_cpus=threads, max_retries=0,
                            **({"runtime_env": {"env_vars": omp}} if omp else {}))(execute_point_shipped)
        inflight: dict[Future, PointTask] = {}
        try:
            _drain(deque(tasks), workers, submit, outcome, bar, "ray task failed: ", receive=arrived,
                   inflight=inflight, claims=claims)
        except BaseException as exc:
            for fut, ref in refs.items():  # Ctrl-C / SIGTERM: stop the points still running on the cluster
                if not fut.done():
                    ray.cancel(ref, force=True)
            if isinstance(exc, KeyboardInterrupt):
                _record_stopped({f: t for f, t in inflight.items() if not f.done()}, outcome)
            raise
    finally:
        if started_here:
            ray.shutdown()
