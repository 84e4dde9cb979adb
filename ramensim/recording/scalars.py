"""Buffered scalar series, sent to Rerun in columns (``send_columns``) instead of one
``log`` call per number: a run produces tens of thousands of scalars and per-call
logging would dominate the recorder's cost."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import rerun as rr

SIM_TIME = "sim_time"
"""Timeline of simulated time (a duration, s)."""
EVENT = "event"
"""Timeline of the event sequence number (1 for the first event the recorder sees)."""


@dataclass
class _Series:
    t: list[float] = field(default_factory=list)
    seq: list[int] = field(default_factory=list)
    value: list[float] = field(default_factory=list)


class ScalarBuffer:
    """Points (sim time s, event number, value) per entity, waiting to be sent."""

    def __init__(self) -> None:
        self._series: dict[str, _Series] = {}
        self._pending = 0
        self.known: set[str] = set()
        """Every entity that ever received a point (for styling and the blueprint)."""

    def __len__(self) -> int:
        return self._pending

    def add(self, entity: str, t: float, seq: int, value: float) -> bool:
        """Buffer one point; True when ``entity`` is new (never seen before)."""
        s = self._series.get(entity)
        if s is None:
            s = self._series[entity] = _Series()
        s.t.append(float(t))
        s.seq.append(int(seq))
        s.value.append(float(value))
        self._pending += 1
        if entity in self.known:
            return False
        self.known.add(entity)
        return True

    def flush(self, rec: rr.RecordingStream) -> int:
        """Send every buffered series as one column chunk each (sorted by entity for a
        deterministic order); returns the number of points sent."""
        sent = 0
        for entity in sorted(self._series):
            s = self._series[entity]
            if not s.t:
                continue
            rec.send_columns(
                entity,
                indexes=[
                    rr.TimeColumn(SIM_TIME, duration=np.asarray(s.t, dtype=np.float64)),
                    rr.TimeColumn(EVENT, sequence=np.asarray(s.seq, dtype=np.int64)),
                ],
                columns=rr.Scalars.columns(scalars=np.asarray(s.value, dtype=np.float64)),
            )
            sent += len(s.t)
        self._series.clear()
        self._pending = 0
        return sent
