"""Every message accounted for: a compact columnar log, its CSV and its summary.

Rows are appended as tuples on the hot path and packed into a numpy structured array every
``_CHUNK`` rows (74 bytes a message). Times are simulated seconds, sizes bytes.
"""
from __future__ import annotations

import io
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ramensim.core.events import CUSTOM_BASE, DROP_REASONS, MEDIUM_REASONS, reason_name

STATUS = ("delivered", "dropped")
"""Status codes of the ``status`` column (index = code)."""

REASON_CODES = ("",) + DROP_REASONS
"""Reason codes of the ``reason`` column (index = code = ``Fate`` value; 0 = none)."""

DTYPE = np.dtype(
    [
        ("id", "i8"), ("src", "i4"), ("dst", "i4"), ("nbytes", "i8"), ("wire_bytes", "i8"),
        ("t_sent", "f8"), ("t_start", "f8"), ("t_done", "f8"), ("stamp", "f8"),
        ("status", "u1"), ("reason", "u1"), ("packets", "i4"), ("retries", "i4"),
    ]
)
"""One row per message, in the order of the tuple the channel appends."""

CSV_COLUMNS = (
    "id", "src", "dst", "nbytes", "wire_bytes", "t_sent", "t_start", "t_done", "stamp",
    "status", "reason", "latency", "age", "packets", "retries",
)
"""Columns of ``MessageLog.write_csv``; latency = t_done - t_sent and age = t_done - stamp are
given for delivered messages and left empty for dropped ones."""

_CHUNK = 1 << 16


def _stats(x: np.ndarray) -> dict[str, float | None]:
    """mean, p50 and p95 of ``x`` (None when empty)."""
    if x.size == 0:
        return {"mean": None, "p50": None, "p95": None}
    p50, p95 = np.percentile(x, [50.0, 95.0])
    return {"mean": float(x.mean()), "p50": float(p50), "p95": float(p95)}


def _group_summary(r: np.ndarray, shared: bool = False) -> dict[str, Any]:
    delivered = r["status"] == 0
    d = r[delivered]
    lat = d["t_done"] - d["t_sent"]
    age = d["t_done"] - d["stamp"]
    counts = np.bincount(r["reason"], minlength=len(REASON_CODES))
    n = int(r.size)
    nd = int(delivered.sum())
    return {
        "sent": n,
        "delivered": nd,
        "dropped": n - nd,
        "dropped_by_reason": {**{name: int(counts[i]) for i, name in enumerate(REASON_CODES)
                                 if i and (shared or name not in MEDIUM_REASONS)},
                              **{reason_name(c): int(counts[c]) for c in range(CUSTOM_BASE, counts.size) if counts[c]}},
        "delivered_fraction": (nd / n) if n else None,
        "bytes_sent": int(r["nbytes"].sum()),
        "bytes_delivered": int(d["nbytes"].sum()),
        "wire_bytes": int(r["wire_bytes"].sum()),
        "latency_s": _stats(lat),
        "age_s": _stats(age),
    }


def _reason(code: int) -> str:
    return REASON_CODES[code] if code < len(REASON_CODES) else reason_name(code)


def _fmt(x: float) -> str:
    """Shortest round-trip text of a float (deterministic across runs)."""
    return repr(float(x))


class MessageLog:
    """Every message the channel handled: id, src, dst, sizes, times, status, reason, packets, retries."""

    def __init__(self, shared: bool = False) -> None:
        self.shared = shared
        """The channel has a shared medium: the summary lists its drop reasons (collision, retry_limit)."""
        self.medium: Callable[[], dict[str, Any]] | None = None
        """The shared medium's account (``SharedMedium.summary`` at the time asked), written into the
        totals as ``medium`` (metrics.json's ``communication.medium``); None on private links (no such key)."""
        self._rows: list[tuple] = []
        self._chunks: list[np.ndarray] = []

    def append(self, row: tuple) -> None:
        """Add one finished message as a tuple in ``DTYPE`` order (the channel's hot path)."""
        rows = self._rows
        rows.append(row)
        if len(rows) >= _CHUNK:
            self._pack()

    def _pack(self) -> None:
        if self._rows:
            self._chunks.append(np.fromiter(self._rows, dtype=DTYPE, count=len(self._rows)))
            self._rows = []

    def __len__(self) -> int:
        return sum(c.size for c in self._chunks) + len(self._rows)

    def records(self) -> np.ndarray:
        """All finished messages as a structured array (``DTYPE``), sorted by id."""
        self._pack()
        if not self._chunks:
            return np.zeros(0, dtype=DTYPE)
        if len(self._chunks) > 1:
            self._chunks = [np.concatenate(self._chunks)]
        r = self._chunks[0]
        return r[np.argsort(r["id"], kind="stable")]

    def write_csv(self, path: str | Path) -> None:
        """Write one row per message (``CSV_COLUMNS``), sorted by id, with round-trip float text."""
        r = self.records()
        buf = io.StringIO()
        buf.write(",".join(CSV_COLUMNS) + "\n")
        cols = [r[name].tolist() for name in DTYPE.names]
        for (mid, src, dst, nb, wb, ts, tst, td, st, status, reason, pk, rt) in zip(*cols):
            if status == 0:
                lat, age = _fmt(td - ts), _fmt(td - st)
            else:
                lat = age = ""
            buf.write(
                f"{mid},{src},{dst},{nb},{wb},{_fmt(ts)},{_fmt(tst)},{_fmt(td)},{_fmt(st)},"
                f"{STATUS[status]},{_reason(reason)},{lat},{age},{pk},{rt}\n"
            )
        Path(path).write_text(buf.getvalue(), encoding="utf-8")

    def summary(self) -> dict[str, Any]:
        """Counts by status and reason, delivered fraction, bytes, latency and age (mean, p50,
        p95; delivered messages only) for all messages (``"total"``) and per directed link
        (``"links"``, keyed ``"src->dst"`` in numeric order)."""
        r = self.records()
        out: dict[str, Any] = {"total": _group_summary(r, self.shared), "links": {}}
        if r.size:
            order = np.lexsort((r["dst"], r["src"]))
            rs = r[order]
            key = rs["src"].astype(np.int64) * (1 << 32) + rs["dst"]
            cuts = np.flatnonzero(np.diff(key)) + 1
            for g in np.split(rs, cuts):
                out["links"][f"{int(g['src'][0])}->{int(g['dst'][0])}"] = _group_summary(g, self.shared)
        if self.medium is not None:  # metrics.json: communication.medium
            out["total"]["medium"] = self.medium()
        return out

