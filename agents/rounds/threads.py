"""Threads mode: each round computed on one of ``workers`` threads from its start, while the event
loop goes on; collected when the robot's compute clock reaches the round's end.

torch and the C kernels release the GIL, so the rounds of the robots whose clocks overlap run at
the same time. Each worker caps every map stage at one thread (``agents/map/threads.py``), so
``workers`` rounds at once use ``workers`` cores, not ``workers`` squared; the stages' results do
not depend on their thread count (docs/DESIGN.md, "The team engine").
"""
from __future__ import annotations

import logging
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable, Sequence, TypeVar

from ramensim.agents.map.threads import set_thread_cap

from .engine import Engine, Ticket

T = TypeVar("T")

log = logging.getLogger(__name__)


def _single_thread_worker() -> None:
    """Worker initialiser: every map stage (torch's intra-op pool and the C kernels) on one
    thread here."""
    set_thread_cap(1)


def _wait_for(future: Future) -> Callable[[Ticket], None]:
    def wait(ticket: Ticket) -> None:
        try:
            ticket.fulfil(future.result())
        except BaseException as exc:  # noqa: BLE001 - re-raised to the round's owner
            ticket.fail(exc)
    return wait


class ThreadEngine(Engine):
    """Rounds on a pool of ``workers`` threads (``workers >= 2``), started at submission."""

    mode = "threads"

    def __init__(self, workers: int = 2) -> None:
        super().__init__(workers)
        self._pool: ThreadPoolExecutor | None = ThreadPoolExecutor(
            self.workers, thread_name_prefix="ramensim-round", initializer=_single_thread_worker)
        self._in_flight: list[Ticket] = []
        self._lock = threading.Lock()

    @classmethod
    def create(cls, workers: int, maps: Sequence[Any] = ()) -> "ThreadEngine":
        log.info("team engine: %d robots' rounds on %d worker threads", len(maps), workers)
        return cls(workers)

    @staticmethod
    def pool_threads(workers: int) -> int:
        return workers

    @staticmethod
    def rounds_at_once(workers: int, n_maps: int) -> int:
        return workers

    @property
    def concurrent(self) -> bool:
        return self._pool is not None

    @property
    def parallel_map(self) -> bool:
        return self._pool is not None

    def submit(self, job: Callable[[], T]) -> Ticket[T]:
        self.submitted += 1
        if self._pool is None:  # closed: what is still submitted is computed here
            return Ticket.computed(job)
        ticket: Ticket[T] = Ticket(_wait_for(self._pool.submit(job)))
        with self._lock:
            self._in_flight = [t for t in self._in_flight if not t.done]
            self._in_flight.append(ticket)
            self.max_in_flight = max(self.max_in_flight, len(self._in_flight))
        return ticket

    def map(self, fn: Callable[[Any], T], items: list) -> list[T]:
        if self._pool is None or len(items) < 2:
            return [fn(x) for x in items]
        return list(self._pool.map(fn, items))

    def drain(self) -> None:
        with self._lock:
            pending, self._in_flight = self._in_flight, []
        for t in pending:
            t.settle()

    def close(self) -> None:
        self.drain()
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
