"""Buffered message lines: every delivered or lost message becomes a line between the two
agents that shows for a while, then disappears. Rows are collected per directed-link
entity and sent in columns (``send_columns``); a line "disappears" by a row with no
strip at the time its display ends, unless a newer message replaced it before then."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import rerun as rr

from ramensim.recording.scalars import EVENT, SIM_TIME


@dataclass
class _Rows:
    t: list[float] = field(default_factory=list)
    seq: list[int] = field(default_factory=list)
    strip: list[np.ndarray | None] = field(default_factory=list)
    color: list[tuple[int, int, int]] = field(default_factory=list)
    label: list[str] = field(default_factory=list)


class MessageLineBuffer:
    """Line rows (sim time s, event number, strip or None) per entity, waiting to be sent."""

    def __init__(self, display_s: float) -> None:
        self.display_s = float(display_s)
        self._rows: dict[str, _Rows] = {}
        self._ends: dict[str, float] = {}
        self.known: set[str] = set()
        """Every entity that ever received a line (static styling is logged once)."""

    def __len__(self) -> int:
        return sum(len(r.t) for r in self._rows.values())

    def _row(self, entity: str) -> _Rows:
        r = self._rows.get(entity)
        if r is None:
            r = self._rows[entity] = _Rows()
        return r

    def add(self, entity: str, t: float, seq: int, p: np.ndarray, q: np.ndarray, color: tuple[int, int, int],
            label: str) -> bool:
        """A line from p to q (m) shown from ``t`` (s) for ``display_s``; True when the
        entity is new. Any earlier line on the entity is replaced (its end is dropped)."""
        self.expire(t, seq)
        r = self._row(entity)
        r.t.append(float(t))
        r.seq.append(int(seq))
        r.strip.append(np.stack([p, q]).astype(np.float32))
        r.color.append(color)
        r.label.append(label)
        self._ends[entity] = float(t) + self.display_s
        if entity in self.known:
            return False
        self.known.add(entity)
        return True

    def expire(self, until: float, seq: int) -> None:
        """Add the end rows of lines whose display ended at or before ``until`` (s)."""
        for entity in sorted(e for e, end in self._ends.items() if end <= until):
            r = self._row(entity)
            r.t.append(self._ends.pop(entity))
            r.seq.append(int(seq))
            r.strip.append(None)

    def flush(self, rec: rr.RecordingStream) -> int:
        """Send every buffered row as one column chunk per entity; returns rows sent."""
        sent = 0
        for entity in sorted(self._rows):
            r = self._rows[entity]
            if not r.t:
                continue
            lengths = np.array([0 if s is None else 1 for s in r.strip], dtype=np.int64)
            strips = [s for s in r.strip if s is not None]
            cols = rr.LineStrips3D.columns(
                strips=np.stack(strips) if strips else np.zeros((0, 2, 3), dtype=np.float32),
                colors=np.asarray(r.color, dtype=np.uint8).reshape(-1, 3),
                labels=r.label,
            ).partition(lengths)
            rec.send_columns(
                entity,
                indexes=[rr.TimeColumn(SIM_TIME, duration=np.asarray(r.t, dtype=np.float64)),
                         rr.TimeColumn(EVENT, sequence=np.asarray(r.seq, dtype=np.int64))],
                columns=cols,
            )
            sent += len(r.t)
        self._rows.clear()
        return sent
