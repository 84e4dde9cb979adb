"""An event clock in integer nanoseconds for the shared medium, standalone or inside SimPy.

The medium decides collisions by comparing instants (two backoff counters that end in the same
slot collide; a signal that ends when another starts does not overlap it), so its clock is an
integer count of nanoseconds: equal instants are equal, and no sum of slots drifts. Events at
one instant run in order of their priority, then in the order they were scheduled.

``EventClock.run(until_ns)`` drives it alone (``ramensim medium saturation``); ``SimpyClock``
keeps one SimPy timeout at its earliest event, so inside a run the medium's events happen at
their simulated times among the agents' (``Channel`` calls ``sync`` before it enqueues).
"""
from __future__ import annotations

import heapq
import math
from typing import Any, Callable

import simpy
from simpy.events import Event, Timeout

NS = 1_000_000_000
"""Nanoseconds per second."""


def to_ns(t_s: float) -> int:
    """Seconds -> the nearest nanosecond (exact for the times a run reaches, < 1e6 s)."""
    return int(round(t_s * NS))


class EventClock:
    """A heap of ``(t_ns, priority, seq, fn, args)``; ``now_ns`` is the time of the event running."""

    def __init__(self) -> None:
        self._heap: list[tuple[int, int, int, Callable[..., None], tuple[Any, ...]]] = []
        self._seq = 0
        self.now_ns = 0
        self.events = 0
        """Events run so far (count)."""

    def at(self, t_ns: int, prio: int, fn: Callable[..., None], *args: Any) -> None:
        """Run ``fn(*args)`` at ``t_ns`` (never before now)."""
        self._seq += 1
        heapq.heappush(self._heap, (max(t_ns, self.now_ns), prio, self._seq, fn, args))

    def next_ns(self) -> int | None:
        """Time of the earliest pending event (ns), None when none is pending."""
        return self._heap[0][0] if self._heap else None

    def run(self, until_ns: int) -> None:
        """Run every event due at or before ``until_ns``; then now = until_ns."""
        heap = self._heap
        pop = heapq.heappop
        while heap and heap[0][0] <= until_ns:
            t, _, _, fn, args = pop(heap)
            self.now_ns = t
            self.events += 1
            fn(*args)
        self.now_ns = max(self.now_ns, until_ns)


class SimpyClock(EventClock):
    """An ``EventClock`` inside a ``simpy.Environment`` (seconds): one pending SimPy timeout at
    its earliest event wakes it, runs what is due and re-arms itself."""

    def __init__(self, env: simpy.Environment) -> None:
        super().__init__()
        self.env = env
        self._wake_ns = math.inf
        self._cb = self._woken
        self._running = False

    def sync(self) -> None:
        """Run what is due up to the SimPy time now (call before acting at ``env.now``)."""
        self._run_armed(to_ns(self.env.now))

    def at(self, t_ns: int, prio: int, fn: Callable[..., None], *args: Any) -> None:
        super().at(t_ns, prio, fn, *args)
        if not self._running and t_ns < self._wake_ns:
            self._arm()

    def _run_armed(self, until_ns: int) -> None:
        self._running = True
        try:
            self.run(until_ns)
        finally:
            self._running = False
        self._arm()

    def _arm(self) -> None:
        nxt = self.next_ns()
        if nxt is None or nxt >= self._wake_ns:
            return
        self._wake_ns = nxt
        delay = max(0.0, nxt / NS - self.env.now)
        Timeout(self.env, delay, nxt).callbacks.append(self._cb)

    def _woken(self, ev: Event) -> None:
        if ev.value == self._wake_ns:
            self._wake_ns = math.inf
        self._run_armed(max(to_ns(self.env.now), ev.value))
