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

from ramensim.agents.map.threads import set_thread_cap

log = logging.getLogger(__name__)

T = TypeVar("T")

WORKERS_ENV = "RAMENSIM_TEAM_WORKERS"
"""Environment variable that sets the engine's worker threads (an integer >= 1; 1 = inline)."""


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

    __slots__ = ("_future", "_value", "_error", "_done")

    def __init__(self, future: Future | None = None) -> None:
        self._future = future
        self._value: T | None = None
        self._error: BaseException | None = None
        self._done = future is None

    def _settle(self) -> None:
        if not self._done:
            assert self._future is not None
            try:
                self._value = self._future.result()
            except BaseException as exc:  # noqa: BLE001 - re-raised to the round's owner
                self._error = exc
            self._done = True
            self._future = None

    def result(self) -> T:
        """The round's result; waits for it; re-raises the exception the round raised."""
        self._settle()
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]


def _single_thread_worker() -> None:
    """Worker initialiser: every map stage (torch's intra-op pool and the C kernels) on one
    thread here, so that ``workers`` rounds at once use ``workers`` cores, not ``workers``
    squared. The stages' results do not depend on their thread count (docs/DESIGN.md)."""
    set_thread_cap(1)


class TeamEngine:
    """Computes submitted rounds on ``workers`` threads (see the module's docstring).

    ``submit(job)`` hands over a callable whose inputs are already fixed; ``Ticket.result()``
    waits for it; ``drain()`` waits for every round in flight (before anything reads a map)."""

    def __init__(self, workers: int = 1) -> None:
        self.workers = max(1, int(workers))
        self._pool: ThreadPoolExecutor | None = None
        if self.workers > 1:
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
        """True when rounds run on worker threads (``workers > 1``)."""
        return self._pool is not None

    def submit(self, job: Callable[[], T]) -> Ticket[T]:
        """Start computing ``job`` (on a worker, or now with one worker)."""
        self.submitted += 1
        if self._pool is None:
            ticket: Ticket[T] = Ticket()
            try:
                ticket._value = job()
            except BaseException as exc:  # noqa: BLE001 - re-raised by result()
                ticket._error = exc
            return ticket
        ticket = Ticket(self._pool.submit(job))
        with self._lock:
            self._in_flight = [t for t in self._in_flight if not t._done]
            self._in_flight.append(ticket)
            self.max_in_flight = max(self.max_in_flight, len(self._in_flight))
        return ticket

    def drain(self) -> None:
        """Wait until every submitted round is computed (their exceptions stay with their
        tickets, raised to their owners when they collect them)."""
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
