"""How far a run's consensus error falls: its peak after the start-up transient against the mean
of its last readings (docs/ALGORITHM.md section 5, "Fall of the consensus error").

The readings are a run's periodic consensus probes (metrics.json ``consensus_timeline``: the
simulated time ``t`` in s and the error under ``key``, CE-1 ``consensus_error`` or CE-2
``consensus_error_weighted``, parameter units). The robots train alone until the first exchange
reaches their maps, and their disagreement grows meanwhile (a local run's keeps growing: 0.09 at
2 s to 0.27 at 10 s on Table I's first trial), so the first readings measure how long the first
message took, not what consensus does. The start-up transient is that rise: the readings before
the first one lower than its predecessor. The **peak** is the largest reading from that one on;
the **settled** value is the mean of the readings in the last ``last_s`` seconds of the run
(``t ≥ t_end - last_s``), not one sample; the **fall** is peak / settled.

The opposite reading, the **growth** (:func:`consensus_growth`), is settled / trough, the trough
the lowest reading from the end of the start-up transient on: maps that agreed and then drift
apart (a dual ascent faster than its inexact, delayed primal steps: docs/CONSENSUS.md,
"Under-relaxed dual steps") have a growth far above 1. :data:`DRIFT` is the growth read as maps
drifting apart.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

LAST_S = 60.0
"""Window of the settled value (s): the last minute, 30 readings at the default 2-s probes."""
DRIFT = 10.0
"""Growth (dimensionless) read as maps drifting apart: an order of magnitude, the size of the
"falls ≥ 10x" claims. Over the 319 runs archived by 2026-11-27 whose error falls after start-up,
the largest growth is 6.4x (the paper's update at 5 % success; DiNNO in Fig. 1's 30-s windows up
to 5.0x); RAMEN with ``consensus.dual_step`` 0.5 at 100 % success and 1 at 50 % grew 29x and 280x
in 300 s (docs/results/sensitivity.md)."""


@dataclass(frozen=True)
class Fall:
    """``peak`` (at ``t_peak`` s) over ``settled`` (the mean of ``n_settled`` readings from
    ``t_settled`` s on)."""
    peak: float
    t_peak: float
    settled: float
    n_settled: int
    t_settled: float

    @property
    def ratio(self) -> float:
        return self.peak / self.settled if self.settled > 0 else math.inf


def readings(timeline: Any, key: str) -> list[tuple[float, float]]:
    """``(t, value)`` of every probe of ``timeline`` with a finite ``t`` and ``key``, in time order
    (anything else in the list is skipped)."""
    out = []
    if isinstance(timeline, Sequence) and not isinstance(timeline, (str, bytes)):
        for p in timeline:
            if isinstance(p, Mapping):
                t, v = p.get("t"), p.get(key)
                if all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x) for x in (t, v)):
                    out.append((float(t), float(v)))
    return sorted(out)


def _after_start_up(timeline: Any, key: str, t_end: float | None,
                    last_s: float) -> tuple[list[tuple[float, float]], list[float], float] | None:
    """The readings from the end of the start-up transient on, the settled window's values and the
    run's end (s); None when the error never falls or no reading lies in the last ``last_s`` s."""
    got = readings(timeline, key)
    first_fall = next((i for i in range(1, len(got)) if got[i][1] < got[i - 1][1]), None)
    if first_fall is None:
        return None
    end = got[-1][0] if t_end is None or not math.isfinite(t_end) else float(t_end)
    last = [v for t, v in got if t >= end - last_s]
    return (got[first_fall:], last, end) if last else None


def consensus_fall(timeline: Any, key: str = "consensus_error", t_end: float | None = None,
                   last_s: float = LAST_S) -> Fall | None:
    """The fall of ``key`` over a run's probes (module docstring); ``t_end``: the run's end (s,
    default its last probe). None when the error never falls (no reading below its predecessor)
    or no reading lies in the last ``last_s`` s."""
    split = _after_start_up(timeline, key, t_end, last_s)
    if split is None:
        return None
    after, last, end = split
    t_peak, peak = max(after, key=lambda tv: tv[1])
    return Fall(peak=peak, t_peak=t_peak, settled=sum(last) / len(last), n_settled=len(last),
                t_settled=end - last_s)


@dataclass(frozen=True)
class Growth:
    """``settled`` (the mean of the readings from ``t_settled`` s on) over ``trough`` (the lowest
    reading after the start-up transient, at ``t_trough`` s)."""
    trough: float
    t_trough: float
    settled: float
    t_settled: float

    @property
    def ratio(self) -> float:
        return self.settled / self.trough if self.trough > 0 else math.inf


def consensus_growth(timeline: Any, key: str = "consensus_error", t_end: float | None = None,
                     last_s: float = LAST_S) -> Growth | None:
    """How far ``key`` rose from its trough after the start-up transient to its settled value
    (module docstring; the transient and the settled window as in :func:`consensus_fall`). None
    when the error never falls or no reading lies in the last ``last_s`` s."""
    split = _after_start_up(timeline, key, t_end, last_s)
    if split is None:
        return None
    after, last, end = split
    t_trough, trough = min(after, key=lambda tv: tv[1])
    return Growth(trough=trough, t_trough=t_trough, settled=sum(last) / len(last), t_settled=end - last_s)
