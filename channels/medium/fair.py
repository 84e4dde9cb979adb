"""A fluid fair share of the air: the active senders a radio hears split the rate (processor sharing).

Each radio sends the frames queued in it one at a time, as a fluid. While radio i sends, its
rate is

    r_i(t) = R / (1 + #{ j sending at t : i and j hear each other at t })         (M-1)

(R = ``channel.bandwidth_bps``, hearing of eq. M-3), so n senders that all hear each other get
R / n each and never more than R together, and senders out of each other's hearing reuse the
air. Nothing collides and nothing backs off: this is the ideal scheduler DCF approaches, cheap
enough for 100 robots (one event per frame that starts or ends, and one per hearing step while
anything is sent). A frame of b bits ends when the integral of r_i reaches b; a receiver that
does not hear the sender when the frame starts does not get it (``UNHEARD``).
"""
from __future__ import annotations

import math
import numpy as np

from ramensim.channels.medium.clock import NS, EventClock
from ramensim.channels.medium.dcf import OK, UNHEARD, Frame, FrameDone, StateHook, Station
from ramensim.channels.medium.hearing import Hearing

_EPS_BITS = 1e-6


class Fair:
    """Eq. M-1 for ``n`` radios on ``clock``; ``bits(frame)`` is what a frame puts on the air."""

    def __init__(self, clock: EventClock, n: int, rate_bps: float, hearing: Hearing, done: FrameDone,
                 hook: StateHook | None = None, header_bits: int = 0) -> None:
        self.clock = clock
        self.n = n
        self.rate = float(rate_bps)
        self.hearing = hearing
        self.done = done
        self.hook = hook
        self.header_bits = header_bits
        self.st = [Station(i, np.random.default_rng(0)) for i in range(n)]
        self._remaining = np.zeros(n)
        self._rates = np.zeros(n)
        self._active = np.zeros(n, dtype=bool)
        self._listeners: list[tuple[int, ...]] = [()] * n
        self._t_last = clock.now_ns
        self._gen = 0

    def push(self, i: int, frame: Frame) -> None:
        s = self.st[i]
        s.queue.append(frame)
        if s.frame is None:
            self._advance()
            self._start(s)
            self._replan()

    def _start(self, s: Station) -> None:
        if s.frame is not None or not s.queue:
            return
        f = s.frame = s.queue.popleft()
        now = self.clock.now_ns
        f.t_first_ns = now
        s.attempts += 1
        self._active[s.i] = True
        self._remaining[s.i] = 8.0 * f.payload_bytes + self.header_bits
        self._listeners[s.i] = self.hearing.listeners(s.i, now)
        if self.hook is not None:
            self.hook(s.i, "transmitting", now)

    def _advance(self) -> None:
        """Bring every sender's remaining bits and the busy/tx counters up to now."""
        now = self.clock.now_ns
        dt = now - self._t_last
        if dt <= 0:
            return
        self._t_last = now
        act = self._active
        if not act.any():
            return
        self._remaining[act] -= self._rates[act] * (dt / NS)
        h = self.hearing.matrix(now - 1)
        heard = act | (h[:, act].any(axis=1))
        for i in np.flatnonzero(heard).tolist():
            self.st[i].busy_ns += dt
        for i in np.flatnonzero(act).tolist():  # airtime: the share of the rate it had
            self.st[i].tx_ns += int(round(dt * self._rates[i] / self.rate))

    def _replan(self) -> None:
        """Eq. M-1 for the senders now, and the next event: a frame's end or a hearing step."""
        now = self.clock.now_ns
        act = self._active
        self._gen += 1
        if not act.any():
            return
        h = self.hearing.matrix(now)
        share = 1.0 + (h[:, act].sum(axis=1))
        self._rates = np.where(act, self.rate / share, 0.0)
        idx = np.flatnonzero(act)
        t_end = idx[np.argmin(self._remaining[idx] / self._rates[idx])]
        dt_ns = max(1, math.ceil(max(self._remaining[t_end], 0.0) / self._rates[t_end] * NS))
        t = now + dt_ns
        nxt = self.hearing.next_change_ns(now)
        if nxt is not None and nxt < t:
            t = nxt
        self.clock.at(t, 1, self._tick, self._gen)

    def _tick(self, gen: int) -> None:
        if gen != self._gen:
            return
        self._advance()
        now = self.clock.now_ns
        act = self._active
        # frames whose remaining bits are (numerically) spent end now
        thresh = np.maximum(self._rates, 1.0) * (1.0 / NS) + _EPS_BITS
        ended = np.flatnonzero(act & (self._remaining <= thresh)).tolist()
        for i in ended:
            s = self.st[i]
            f = s.frame
            assert f is not None
            self._active[i] = False
            self._remaining[i] = 0.0
            heard = set(self._listeners[i])
            out = {d: (OK if d in heard else UNHEARD) for d in f.dsts}
            ok = sum(1 for v in out.values() if v == OK)
            s.delivered_bits += 8 * f.payload_bytes * ok
            s.delivered_frames += 1 if ok else 0
            s.frame = None
            if self.hook is not None:
                self.hook(i, "idle", now)
            self.done(f, now, out)
            self._start(s)
        self._replan()

    def busy(self, i: int) -> bool:
        """Whether radio ``i`` sends, or hears a radio that sends, now."""
        act = self._active
        return bool(act[i] or (self.hearing.matrix(self.clock.now_ns)[i] & act).any())

    def close(self, now_ns: int) -> None:
        """Bring the counters up to ``now_ns`` (the end of a run)."""
        self._advance()
