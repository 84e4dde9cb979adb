"""Trace replay: a link's delivery and latency taken from a recorded radio log (CSV).

The file has a header line and one row per observation::

    time,from,to,delivered,latency
    0.0,0,1,1,0.004
    0.5,0,1,0,
    ...

``time`` (s, >= 0, non-decreasing down the file), ``from``/``to`` (agent ids), ``delivered``
(1/0 or true/false) and ``latency`` (s, the propagation delay after the last bit; may be
empty on a row that was not delivered). Lines starting with ``#`` and blank lines are
skipped. A message sent at time t on a listed link takes the link's latest row at or before
the trace time of t (sample and hold): it is delivered iff that row was, with that row's
latency (instead of the ``latency`` distribution and the loss draw). The trace time of t
is, with ``end: clip``, t clamped to [first, last] time of the file; with ``end: loop``,
first + (t - first) mod P, P = ``period_s`` or (last - first + the smallest positive time
step of the file). Links the file does not list keep the channel's other loss and latency
settings.
"""
from __future__ import annotations

import bisect
import math
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from ramensim.channels.radios import RadioModelSpec, register_radio


class TraceConfig(BaseModel):
    """Trace replay (``channel.trace``, ``ramensim.channels.trace``): delivery and latency of
    the links a CSV file lists (time, from, to, delivered, latency), sample and hold."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    path: str | None = Field(None, min_length=1, max_length=4096)
    """CSV trace file, relative to the scenario's folder (path); None = no replay."""
    end: Literal["loop", "clip"] = "loop"
    """After the trace's last time: start over (loop) or hold the last row (clip) (loop | clip)."""
    period_s: float | None = Field(None, gt=0.0, le=1.0e9, allow_inf_nan=False)
    """Loop period in seconds; None = last - first time of the file + its smallest time step."""


HEADER = ("time", "from", "to", "delivered", "latency")
_TRUE = {"1", "true", "yes"}
_FALSE = {"0", "false", "no"}
MAX_ROWS = 2_000_000
"""Most rows a trace may hold (bounded input)."""
MAX_BYTES = 64 * 1024 * 1024
"""Largest trace file read (bytes)."""


def _seconds(path: Path, no: int, name: str, text: str) -> float:
    """A cell holding a time in seconds: a finite number >= 0, else one paragraph naming the line."""
    try:
        v = float(text)
    except ValueError:
        raise _bad(path, no, f"{name} {text!r} is not a number (seconds).") from None
    if not math.isfinite(v) or v < 0.0:
        raise _bad(path, no, f"{name} {text!r} is not a finite number >= 0 (seconds).")
    return v


def _bad(path: Path, line: int, what: str) -> ValueError:
    return ValueError(f"channel.trace.path {str(path)!r}, line {line}: {what}")


def read_trace(path: Path, n_agents: int) -> dict[tuple[int, int], tuple[list[float], list[bool], list[float]]]:
    """Rows per directed link ``(from, to)`` -> (times s, delivered, latencies s), validated.

    Raises ``ValueError`` naming the file and line for a missing file, a wrong header,
    unknown agents, unsorted times, non-finite or negative numbers, or a delivered row
    without a latency; and for a file over :data:`MAX_BYTES` bytes or :data:`MAX_ROWS` rows.
    """
    try:
        with open(path, "rb") as fh:  # bounded: a huge file or a device never fills memory
            raw = fh.read(MAX_BYTES + 1)
        if len(raw) > MAX_BYTES:
            raise ValueError(f"channel.trace.path {str(path)!r}: the trace is longer than {MAX_BYTES} bytes; "
                             f"expected at most {MAX_BYTES} bytes (split or thin the trace).")
        text = raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"channel.trace.path {str(path)!r}: cannot read the trace ({exc}).") from None
    links: dict[tuple[int, int], tuple[list[float], list[bool], list[float]]] = {}
    header_seen = False
    last_t = -math.inf
    rows = 0
    for no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c.strip() for c in line.split(",")]
        if not header_seen:
            if tuple(c.lower() for c in cells) != HEADER:
                raise _bad(path, no, f"the header is {line!r}; expected the columns {','.join(HEADER)}.")
            header_seen = True
            continue
        if len(cells) != len(HEADER):
            raise _bad(path, no, f"{len(cells)} columns in {line!r}; expected {len(HEADER)} ({','.join(HEADER)}).")
        rows += 1
        if rows > MAX_ROWS:
            raise _bad(path, no, f"more than {MAX_ROWS} rows; split the trace.")
        t_s, a_s, b_s, ok_s, lat_s = cells
        t = _seconds(path, no, "time", t_s)
        if t < last_t:
            raise _bad(path, no, f"time {t_s} s is earlier than the previous row's {last_t:g} s; the rows must "
                                 f"be sorted by time.")
        last_t = t
        ids = []
        for name, s in (("from", a_s), ("to", b_s)):
            try:
                v = int(s)
            except ValueError:
                raise _bad(path, no, f"{name} {s!r} is not an agent id (an integer).") from None
            if not 0 <= v < n_agents:
                raise _bad(path, no, f"{name} = {v} is an unknown agent; the scenario has {n_agents} "
                                     f"agents (ids 0..{n_agents - 1}).")
            ids.append(v)
        if ids[0] == ids[1]:
            raise _bad(path, no, f"from and to are both agent {ids[0]}; a link joins two agents.")
        flag = ok_s.lower()
        if flag not in _TRUE | _FALSE:
            raise _bad(path, no, f"delivered {ok_s!r} is not 1/0 or true/false.")
        ok = flag in _TRUE
        if lat_s == "":
            if ok:
                raise _bad(path, no, "a delivered row needs a latency (seconds).")
            lat = math.nan
        else:
            lat = _seconds(path, no, "latency", lat_s)
        ts, oks, lats = links.setdefault((ids[0], ids[1]), ([], [], []))
        ts.append(t)
        oks.append(ok)
        lats.append(lat)
    if not header_seen:
        raise ValueError(f"channel.trace.path {str(path)!r}: the file is empty; expected the header "
                         f"{','.join(HEADER)} and at least one row.")
    if rows == 0:
        raise ValueError(f"channel.trace.path {str(path)!r}: no rows after the header.")
    return links


class TraceReplay:
    """Delivery and latency of listed links at a time, from a trace file (see the module docstring)."""

    def __init__(self, cfg: TraceConfig, n_agents: int, base_dir: Path | None = None) -> None:
        p = Path(cfg.path).expanduser()
        if not p.is_absolute() and base_dir is not None:
            p = Path(base_dir) / p
        self.path = p
        self.links = read_trace(p, n_agents)
        times = sorted({t for ts, _, _ in self.links.values() for t in ts})
        self.first, self.last = times[0], times[-1]
        steps = [b - a for a, b in zip(times, times[1:]) if b > a]
        self.period = cfg.period_s if cfg.period_s is not None else \
            (self.last - self.first) + (min(steps) if steps else 1.0)
        self.loop = cfg.end == "loop"

    def trace_time(self, t: float) -> float:
        """The time of the trace (s) replayed at simulated time ``t`` (s)."""
        if self.loop:
            if self.first <= t < self.first + self.period:
                return t  # inside the first period: exactly t (no rounding)
            return self.first + (t - self.first) % self.period
        return min(max(t, self.first), self.last)

    def lookup(self, src: int, dst: int, t: float) -> tuple[bool, float] | None:
        """(delivered, latency s) of ``src -> dst`` at simulated time ``t`` (s); None when the
        trace does not list the link."""
        rows = self.links.get((src, dst))
        if rows is None:
            return None
        ts, oks, lats = rows
        i = bisect.bisect_right(ts, self.trace_time(t)) - 1
        if i < 0:
            i = 0  # before the link's first row: its first row holds
        return oks[i], lats[i]

    def quality(self, src: int, dst: int, t: float) -> tuple[float, float | None] | None:
        """As an ``override`` radio model: (1, latency s) or (0, None) on a listed link, None
        on a link the trace does not list (the other models decide)."""
        row = self.lookup(src, dst, t)
        if row is None:
            return None
        return (1.0, row[1]) if row[0] else (0.0, None)


register_radio(RadioModelSpec(
    name="trace", settings=TraceConfig, role="override", active=lambda s: s.path is not None,
    build=lambda s, ctx: TraceReplay(s, ctx.n_agents, ctx.base_dir),
    description="delivery and latency of listed links replayed from a CSV radio log"))
