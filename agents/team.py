"""The team engine: every robot's mapping round computed off the event loop, several at once.

A round's inputs are fixed when it starts (docs/DESIGN.md, "The team engine"): the copies the
stale policy selects then, the robot's degree then, its map and method state then, and the frames
it held then (frames that arrive while the round is in flight are held back by
:class:`ramensim.agents.step.ConsensusStep` and applied when the round's result is collected).
Its result is first needed when the round ends on the robot's compute clock (start + cost, s),
and the cost of a ``model`` clock is known at the start from the method's planned gradient
evaluations. So a round can be handed to a worker at its start and collected at its end: the
event loop goes on meanwhile (other robots start their rounds, the channel carries messages,
cameras render), and the rounds of all robots whose compute clocks overlap run at the same time,
one per worker thread (torch and the C kernels release the GIL). The result equals computing
the round inline at its start: the same numbers, only computed on another thread, later in
wall time. Observers that read the maps (evaluation, consensus probes, snapshots) call
:meth:`TeamEngine.drain` first, so they see every round started before them, as inline.

With ``workers <= 1`` a submitted round is computed at once, on the caller's thread (the
inline order of every earlier version).
"""
from __future__ import annotations

import logging
import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable, Generic, TypeVar

import torch

from ramensim.agents.map.threads import set_lockstep_gate, set_thread_cap

log = logging.getLogger(__name__)

T = TypeVar("T")

WORKERS_ENV = "RAMENSIM_TEAM_WORKERS"
"""Environment variable that sets the engine's worker threads (an integer >= 1; 1 = inline)."""


BATCH_ENV = "RAMENSIM_TEAM_BATCH"
"""Environment variable for lockstep batches of the team's gradients: ``1`` (on; the maps must
be on the torch path: ``map.native: false``, or a GPU), unset or ``0`` (off). Off by default:
on the CPU's torch path a batch measured 0.90-0.93x the maps' separate steps at the default map
size and 1.55x slower at 128 rays for 24 robots (docs/BENCHMARKS.md, "The team"); on a GPU, the
form it is built for, it has not been measured yet."""


def team_batching(n_maps: int, device: torch.device | str = "cpu") -> bool:
    """Whether the team's gradients go in lockstep batches (``$RAMENSIM_TEAM_BATCH``)."""
    raw = os.environ.get(BATCH_ENV, "").strip()
    if raw not in ("", "0", "1"):
        raise ValueError(f"environment variable {BATCH_ENV}={raw!r}: expected 1 (lockstep batches of the "
                         f"team's gradients; maps on the torch path) or 0 (none, the default).")
    return raw == "1"


def team_workers(n_maps: int, device: torch.device | str = "cpu") -> int:
    """Worker threads for a team of ``n_maps`` maps: ``$RAMENSIM_TEAM_WORKERS`` when set, else
    torch's intra-op thread count (what this process was given: a sweep worker started with
    ``--threads 1`` computes inline), never more than the maps; 1 on a GPU (its kernels are
    asynchronous already) or for a single map."""
    raw = os.environ.get(WORKERS_ENV, "").strip()
    if raw:
        try:
            wanted = int(raw)
        except ValueError:
            raise ValueError(f"environment variable {WORKERS_ENV}={raw!r}: expected an integer >= 1 "
                             f"(worker threads of the team engine).") from None
        if wanted < 1:
            raise ValueError(f"environment variable {WORKERS_ENV}={raw!r}: expected an integer >= 1 "
                             f"(worker threads of the team engine).")
    else:
        if torch.device(device).type != "cpu":
            return 1
        wanted = torch.get_num_threads()
    return max(1, min(wanted, n_maps))


class Ticket(Generic[T]):
    """A submitted round: its result (or the exception it raised) once computed."""

    __slots__ = ("_future", "_outcome", "_error", "_done", "_engine")

    def __init__(self, future: Future | None = None, engine: "TeamEngine | None" = None) -> None:
        self._future = future
        self._engine = engine  # lockstep mode: computed with the engine's pending rounds when needed
        self._outcome: T | None = None
        self._error: BaseException | None = None
        self._done = future is None and engine is None

    def _settle(self) -> None:
        if not self._done and self._engine is not None:
            self._engine._run_lockstep()
        if not self._done:
            assert self._future is not None
            try:
                self._outcome = self._future.result()
            except BaseException as exc:  # noqa: BLE001 - re-raised to the round's owner
                self._error = exc
            self._done = True
            self._future = None

    def result(self) -> T:
        """The round's result; waits for it; re-raises the exception the round raised."""
        self._settle()
        if self._error is not None:
            raise self._error
        return self._outcome  # type: ignore[return-value]


def _single_thread_worker() -> None:
    """Worker initialiser: every map stage (torch's intra-op pool and the C kernels) on one
    thread here, so that ``workers`` rounds at once use ``workers`` cores, not ``workers``
    squared. The stages' results do not depend on their thread count (docs/DESIGN.md)."""
    set_thread_cap(1)


class LockstepGate:
    """Joins the gradient evaluations of a batch of rounds that run at once, one thread each:
    when every round still running waits in ``loss_and_grad``, their maps' gradients are
    computed together by ``batch`` (:func:`ramensim.agents.map.team_batch.team_loss_and_grad`),
    in the rounds' submission order whatever the threads' timing, so the batches, and so the
    numbers, are the same on every run."""

    def __init__(self, rounds: int, batch: Callable[[list], list]) -> None:
        self._cv = threading.Condition()
        self._running = rounds
        self._batch = batch
        self._waiting: list[list] = []
        self._order: dict[int, int] = {}
        self.batches = 0
        """Batched gradient steps computed."""
        self.largest = 0
        """The most maps in one batched step."""

    def enter(self, index: int) -> None:
        """The calling thread runs the round submitted ``index``-th."""
        self._order[threading.get_ident()] = index

    def loss_and_grad(self, learner):
        """A round's ``learner.loss_and_grad()``: waits for the team's batched step."""
        slot = [self._order[threading.get_ident()], learner, None, None]
        with self._cv:
            self._waiting.append(slot)
            self._fire_if_all_wait()
            while slot[2] is None and slot[3] is None:
                self._cv.wait()
        if slot[3] is not None:
            raise slot[3]
        return slot[2]

    def leave(self) -> None:
        """The calling thread's round has ended (or failed)."""
        with self._cv:
            self._running -= 1
            self._fire_if_all_wait()

    def _fire_if_all_wait(self) -> None:
        if not self._waiting or len(self._waiting) < self._running:
            return
        batch = sorted(self._waiting, key=lambda s: s[0])
        self._waiting = []
        try:
            results = self._batch([s[1] for s in batch])
            for s, r in zip(batch, results):
                s[2] = r
        except BaseException as exc:  # noqa: BLE001 - every round of the batch sees it
            for s in batch:
                s[3] = exc
        self.batches += 1
        self.largest = max(self.largest, len(batch))
        self._cv.notify_all()


class TeamEngine:
    """Computes submitted rounds on ``workers`` threads (see the module's docstring).

    ``submit(job)`` hands over a callable whose inputs are already fixed; ``Ticket.result()``
    waits for it; ``drain()`` waits for every round in flight (before anything reads a map).

    With ``batch`` (lockstep mode, the maps' torch path: a GPU, or ``map.native: false``) a
    submitted round waits until its result or a drain is needed; then every pending round runs
    at once, one thread each, and each of their optimiser steps' gradients is one batched
    computation of all of them (:class:`LockstepGate`). Which rounds are pending at a given
    simulated time is fixed by the event loop, so the batches are the same on every run."""

    def __init__(self, workers: int = 1, batch: Callable[[list], list] | None = None) -> None:
        self.workers = max(1, int(workers))
        self.batch = batch
        self._pending: list[tuple[Ticket, Callable[[], object]]] = []
        self.batches = 0
        """Lockstep mode: batched gradient steps computed so far."""
        self.largest_batch = 0
        """Lockstep mode: the most maps in one batched step."""
        self._pool: ThreadPoolExecutor | None = None
        if self.workers > 1 and batch is None:
            self._pool = ThreadPoolExecutor(self.workers, thread_name_prefix="ramensim-round",
                                            initializer=_single_thread_worker)
        self._in_flight: list[Ticket] = []
        self._lock = threading.Lock()
        self.submitted = 0
        """Rounds submitted so far."""
        self.max_in_flight = 0
        """The most rounds in flight at once (how much the team overlapped)."""

    @property
    def concurrent(self) -> bool:
        """True when rounds leave the event loop's thread (worker threads, or lockstep batches)."""
        return self._pool is not None or self.batch is not None

    def submit(self, job: Callable[[], T]) -> Ticket[T]:
        """Start computing ``job`` (on a worker, or now with one worker; in lockstep mode it
        waits for the batch that first needs a pending result)."""
        self.submitted += 1
        if self.batch is not None:
            ticket: Ticket[T] = Ticket(engine=self)
            self._pending.append((ticket, job))
            self.max_in_flight = max(self.max_in_flight, len(self._pending))
            return ticket
        if self._pool is None:
            ticket: Ticket[T] = Ticket()
            try:
                ticket._outcome = job()
            except BaseException as exc:  # noqa: BLE001 - re-raised by result()
                ticket._error = exc
            return ticket
        ticket = Ticket(self._pool.submit(job))
        with self._lock:
            self._in_flight = [t for t in self._in_flight if not t._done]
            self._in_flight.append(ticket)
            self.max_in_flight = max(self.max_in_flight, len(self._in_flight))
        return ticket

    def map(self, fn: Callable[[object], T], items: list) -> list[T]:
        """``[fn(x) for x in items]`` on the workers when there are any (each capped at one
        thread), in order; for work that reads the maps, e.g. the meshes of an evaluation (call
        it after :meth:`drain`, never from a worker)."""
        if self._pool is None or len(items) < 2:
            return [fn(x) for x in items]
        return list(self._pool.map(fn, items))

    def _run_lockstep(self) -> None:
        """Run every pending round at once, one thread each, their gradients batched."""
        pending, self._pending = self._pending, []
        if not pending:
            return
        assert self.batch is not None
        gate = LockstepGate(len(pending), self.batch)

        def run(index: int, ticket: Ticket, job: Callable[[], object]) -> None:
            gate.enter(index)
            set_lockstep_gate(gate)
            try:
                ticket._outcome = job()
            except BaseException as exc:  # noqa: BLE001 - re-raised to the round's owner
                ticket._error = exc
            finally:
                set_lockstep_gate(None)
                gate.leave()

        threads = [threading.Thread(target=run, args=(i, t, job), name=f"ramensim-lockstep-{i}", daemon=True)
                   for i, (t, job) in enumerate(pending)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        for t, _ in pending:
            t._done = True
        self.batches += gate.batches
        self.largest_batch = max(self.largest_batch, gate.largest)

    def drain(self) -> None:
        """Wait until every submitted round is computed (their exceptions stay with their
        tickets, raised to their owners when they collect them)."""
        if self.batch is not None:
            self._run_lockstep()
            return
        with self._lock:
            pending, self._in_flight = self._in_flight, []
        for t in pending:
            t._settle()

    def close(self) -> None:
        """Finish the rounds in flight and stop the workers."""
        self.drain()
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
