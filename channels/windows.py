"""Communication windows: when an undirected link {a, b} may carry messages (times in seconds).

Windows are half-open intervals ``[t0, t1)``: open at ``t0``, closed at ``t1``. The rule the
channel applies is documented on ``WindowConfig``.
"""
from __future__ import annotations

import math
from bisect import bisect_right

from ramensim.channels.config import WindowConfig, parse_pair_key

_EPS = 1e-9
"""Tolerance (s) when a time computed as phase + k*period lands a rounding error short of an opening."""


def _merge(intervals: list[tuple[float, float]]) -> tuple[list[float], list[float]]:
    """Sorted, merged ``[t0, t1)`` intervals as parallel lists of starts and ends."""
    starts: list[float] = []
    ends: list[float] = []
    for t0, t1 in sorted((float(a), float(b)) for a, b in intervals):
        if starts and t0 <= ends[-1]:
            ends[-1] = max(ends[-1], t1)
        else:
            starts.append(t0)
            ends.append(t1)
    return starts, ends


class Windows:
    """Open/closed state of every link's window, with the next opening and the current close."""

    def __init__(self, cfg: WindowConfig, n_agents: int) -> None:
        self.kind = cfg.kind
        self.always = cfg.kind == "always" or (cfg.kind == "periodic" and cfg.open_s >= cfg.period_s)
        """True when every link is open at every time."""
        self._period = cfg.period_s
        self._open = cfg.open_s
        self._phase = cfg.phase_s
        self._pairs: dict[tuple[int, int], tuple[list[float], list[float]]] = {}
        self._default: tuple[list[float], list[float]] = ([], [])
        if cfg.kind == "schedule":
            for key, intervals in cfg.schedule.items():
                pair = parse_pair_key(key)
                if pair is None:
                    self._default = _merge(intervals)
                    continue
                for agent in pair:
                    if agent >= n_agents:
                        raise ValueError(
                            f"channel.windows.schedule key {key!r} names agent {agent}, but the "
                            f"scenario has {n_agents} agents (ids 0..{n_agents - 1})."
                        )
                self._pairs[pair] = _merge(intervals)

    def _lists(self, a: int, b: int) -> tuple[list[float], list[float]]:
        return self._pairs.get((a, b) if a < b else (b, a), self._default)

    def _periodic_start(self, t: float) -> float:
        """Start (s) of the periodic window period that contains ``t``."""
        k = math.floor((t - self._phase) / self._period)
        start = self._phase + k * self._period
        nxt = start + self._period
        if nxt - t <= _EPS:  # t is an opening up to rounding
            return nxt
        return start

    def is_open(self, a: int, b: int, t: float) -> bool:
        """Whether link {a, b} is open at time ``t`` (s)."""
        if self.always:
            return True
        if self.kind == "periodic":
            return t < self._periodic_start(t) + self._open
        starts, ends = self._lists(a, b)
        i = bisect_right(starts, t) - 1
        return i >= 0 and t < ends[i]

    def close_after(self, a: int, b: int, t: float) -> float:
        """When the window open at ``t`` closes (s): ``inf`` if it never does, ``t`` if it is closed at ``t``."""
        if self.always:
            return math.inf
        if self.kind == "periodic":
            end = self._periodic_start(t) + self._open
            return end if t < end else t
        starts, ends = self._lists(a, b)
        i = bisect_right(starts, t) - 1
        return ends[i] if i >= 0 and t < ends[i] else t

    def next_open(self, a: int, b: int, t: float) -> float | None:
        """The earliest time >= ``t`` (s) at which link {a, b} is open; None if never again."""
        if self.always:
            return t
        if self.kind == "periodic":
            if self._open <= 0.0:
                return None
            start = self._periodic_start(t)
            return t if t < start + self._open else max(t, start + self._period)
        starts, ends = self._lists(a, b)
        i = bisect_right(starts, t) - 1
        if i >= 0 and t < ends[i]:
            return t
        return starts[i + 1] if i + 1 < len(starts) else None
