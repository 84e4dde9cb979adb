"""Inline mode: every round computed at once, at its start, on the event loop's thread (the order
of every version before the team engine; one core, a GPU, a sweep worker with one thread)."""
from __future__ import annotations

from typing import Callable, TypeVar

from .engine import Engine, Ticket

T = TypeVar("T")


class InlineEngine(Engine):
    """Computes a submitted round now, on the caller's thread; its ticket is settled at once."""

    mode = "inline"

    def __init__(self, workers: int = 1) -> None:
        super().__init__(1)

    def submit(self, job: Callable[[], T]) -> Ticket[T]:
        self.submitted += 1
        self.max_in_flight = max(self.max_in_flight, 1)
        return Ticket.computed(job)
