"""802.11 DCF: CSMA/CA with slotted binary exponential backoff, on an integer clock (ns).

Each radio (a *station*) sends the frames queued in it, one at a time, as 802.11's
distributed coordination function does:

1. **Carrier sense.** A station senses the medium busy while it hears a signal (any frame of a
   station within hearing, ``hears``), while it sends, and until its NAV (the reservation an RTS
   or CTS it decoded announced) expires.
2. **Backoff.** After every frame (delivered, failed or dropped) a station draws a counter
   uniformly from ``0 .. W_i - 1`` slots, ``W_i = 2^min(i, m) W`` at backoff stage i
   (``cw_min`` = W, ``max_stage`` = m). The counter runs down by one for every slot the medium
   stays idle once it has been idle for DIFS, is frozen while the medium is busy, and the frame
   goes on the air when it reaches 0 (a station with nothing to send keeps counting: post-backoff).
   A frame that arrives at a station whose counter is 0 goes when the medium has been idle DIFS.
3. **Access.** Basic: DATA, then after SIFS the receiver's ACK. RTS/CTS: RTS, SIFS, CTS,
   SIFS, DATA, SIFS, ACK; a station that decodes an RTS or CTS not addressed to it sets its NAV
   to the end of the exchange. A receiver answers only a frame it decoded, while not busy in an
   exchange of its own and (for an RTS) with no NAV set. Broadcast: DATA alone, no ACK, no retry.
4. **Collisions.** A frame is decoded by a listener iff no other signal reaches that listener at
   any time while it does and the listener does not send meanwhile (half duplex). Hidden
   terminals follow: two senders that do not hear each other collide at a receiver both reach.
5. **Failure.** A unicast exchange fails when its RTS or DATA is not decoded by the receiver, or
   its CTS or ACK not by the sender; the sender learns it when the failed frame ends (Bianchi's
   assumption, which his collision time T_c encodes: no ACK timeout beyond the frame). It then
   enters stage i + 1 and retries, until ``retry_limit`` retransmissions have failed, when the
   frame is dropped (``retry_limit``); with ``retry_limit`` None it never gives up.

Every signal propagates ``prop`` ns to every listener. Events at one instant run in the order:
signals ending, exchange decisions, backoffs ending (transmissions starting), signals arriving,
so a station whose counter ends in the slot in which another station's frame reaches it still
sends (it cannot have sensed it), and two signals that only touch do not collide.

Durations (eq. M-2): a frame of b bits lasts ``phy + ceil(b / rate)``; data b = MAC header +
8 x payload; ACK, RTS, CTS their sizes.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ramensim.channels.medium.clock import NS, EventClock

# event priorities at one instant (see the module docstring)
_END, _DECIDE, _EXPIRE, _ARRIVE = 0, 1, 2, 3

DATA, RTS, CTS, ACK = 0, 1, 2, 3

OK, COLLIDED, DROPPED_RETRY, UNHEARD, LOST = 0, 1, 2, 3, 4
"""Outcomes of a frame at one receiver: decoded; lost to a collision (broadcast); the sender
gave up after ``retry_limit`` retransmissions; the receiver did not hear the sender at all; the
radio's loss took it (broadcast with ``p_ok`` < 1)."""


@dataclass(frozen=True, slots=True)
class DcfParams:
    """The DCF's timing (integer ns) and sizes (bits), its window and its retry limit."""

    rate_bps: float
    slot_ns: int
    sifs_ns: int
    difs_ns: int
    prop_ns: int
    phy_ns: int
    mac_header_bits: int
    ack_bits: int
    rts_bits: int
    cts_bits: int
    cw_min: int
    max_stage: int
    retry_limit: int | None
    rts_cts: bool

    def airtime_ns(self, bits: int) -> int:
        """A frame of ``bits`` bits after the PHY header: phy + ceil(bits / rate) (ns, eq. M-2)."""
        return self.phy_ns + -(-bits * NS // int(self.rate_bps)) if float(self.rate_bps).is_integer() \
            else self.phy_ns + int(np.ceil(bits * NS / self.rate_bps))

    def data_ns(self, payload_bytes: int) -> int:
        """A data frame carrying ``payload_bytes`` (ns)."""
        return self.airtime_ns(self.mac_header_bits + 8 * payload_bytes)


class Frame:
    """One data frame queued at ``src`` for ``dsts`` (one receiver, or several when broadcast)."""

    __slots__ = ("src", "dsts", "payload_bytes", "broadcast", "job", "retries", "t_first_ns", "p_ok")

    def __init__(self, src: int, dsts: tuple[int, ...], payload_bytes: int, broadcast: bool, job: object = None,
                 p_ok: float = 1.0):
        self.src = src
        self.dsts = dsts
        self.payload_bytes = payload_bytes
        self.broadcast = broadcast
        self.job = job
        self.retries = 0
        self.t_first_ns = -1
        """When its first attempt went on the air (ns); -1 before."""
        self.p_ok = p_ok
        """Probability that a receiver that decodes it (no collision) keeps it: the radio's loss per
        frame (``channel.medium.loss: frame``); 1 = the air alone decides."""


class _Signal:
    """One frame on the air: who sent it, for whom, until when, and where it was not decodable."""

    __slots__ = ("src", "kind", "to", "t0", "t1", "listeners", "corrupt", "nav_end")

    def __init__(self, src: int, kind: int, to: tuple[int, ...], t0: int, t1: int,
                 listeners: tuple[int, ...], nav_end: int) -> None:
        self.src = src
        self.kind = kind
        self.to = to
        self.t0 = t0
        self.t1 = t1
        self.listeners = listeners
        self.corrupt: set[int] = set()
        self.nav_end = nav_end


class Station:
    """One radio's DCF state and its counters."""

    __slots__ = ("i", "rng", "queue", "frame", "counter", "stage", "in_exchange", "tx_on", "incoming", "nav_until",
                 "busy", "idle_since", "gen", "busy_since", "busy_ns", "tx_ns", "attempts", "failures", "drops",
                 "delivered_frames", "delivered_bits")

    def __init__(self, i: int, rng: np.random.Generator) -> None:
        self.i = i
        self.rng = rng
        self.queue: deque[Frame] = deque()
        self.frame: Frame | None = None
        self.counter = 0
        self.stage = 0
        self.in_exchange = False
        self.tx_on = 0
        self.incoming: set[_Signal] = set()
        self.nav_until = 0
        self.busy = False
        self.idle_since = 0
        self.gen = 0
        self.busy_since = 0
        self.busy_ns = 0
        """Time it sensed the medium busy, its own sending included (ns)."""
        self.tx_ns = 0
        """Time it was sending (ns)."""
        self.attempts = 0
        """Unicast exchanges started (an RTS or a DATA frame) and broadcast frames sent."""
        self.failures = 0
        """Unicast exchanges that failed (collisions, hidden terminals, an unheard receiver) and
        broadcast frames that collided at one receiver or more."""
        self.drops = 0
        """Frames given up after retry_limit retransmissions."""
        self.delivered_frames = 0
        self.delivered_bits = 0
        """Payload bits of its frames decoded by a receiver (a broadcast counts each receiver)."""


FrameDone = Callable[[Frame, int, dict[int, int]], None]
"""``done(frame, t_ns, outcome)``: the frame finished at ``t_ns``; ``outcome[dst]`` is OK,
COLLIDED, DROPPED_RETRY or UNHEARD for each of its receivers."""

Hears = Callable[[int, int], Sequence[int]]
"""``hears(src, t_ns)``: the stations that hear ``src`` at ``t_ns`` (src excluded)."""

StateHook = Callable[[int, str, int], None]
"""``hook(station, state, t_ns)``: the radio changed state (transmitting, deferring, idle, collided)."""


class Dcf:
    """The DCF of ``n`` stations on ``clock``; see the module docstring for the model."""

    def __init__(self, clock: EventClock, n: int, p: DcfParams, rngs: Sequence[np.random.Generator],
                 hears: Hears, done: FrameDone, hook: StateHook | None = None,
                 loss_rng: np.random.Generator | None = None) -> None:
        self.clock = clock
        self._loss_rng = loss_rng
        """Draws of the radio's loss per frame (frames with p_ok < 1 only)."""
        self.p = p
        self.hears = hears
        self.done = done
        self.hook = hook
        self.st = [Station(i, rngs[i]) for i in range(n)]
        self._ack_ns = p.airtime_ns(p.ack_bits)
        self._rts_ns = p.airtime_ns(p.rts_bits)
        self._cts_ns = p.airtime_ns(p.cts_bits)
        for s in self.st:  # power-on: a backoff from stage 0, counted from t = 0
            s.counter = self._draw(s)
            s.idle_since = clock.now_ns
            self._schedule(s)

    def close(self, now_ns: int) -> None:
        """Bring the busy counters up to ``now_ns`` (the end of a run)."""
        for s in self.st:
            if s.busy:
                s.busy_ns += now_ns - s.busy_since
                s.busy_since = now_ns

    # -- the frames a station is given ----------------------------------------------------------

    def push(self, i: int, frame: Frame) -> None:
        """Queue ``frame`` at station ``i`` (now)."""
        s = self.st[i]
        s.queue.append(frame)
        if s.frame is None:
            self._next_frame(s)

    def _next_frame(self, s: Station) -> None:
        if s.frame is None and s.queue:
            s.frame = s.queue.popleft()
            if s.counter == 0 and not s.in_exchange:
                self._schedule(s)

    # -- sensing ----------------------------------------------------------------------------------

    def _sensed_busy(self, s: Station) -> bool:
        return bool(s.tx_on or s.incoming or self.clock.now_ns < s.nav_until)

    def _update(self, s: Station) -> None:
        """Apply a change of what ``s`` senses: freeze its backoff when the medium turns busy,
        count from DIFS after it turns idle."""
        now = self.clock.now_ns
        busy = self._sensed_busy(s)
        if busy == s.busy:
            return
        s.busy = busy
        if busy:
            s.busy_since = now
            if not s.in_exchange:
                self._freeze(s, now)
                if self.hook is not None and s.frame is not None:
                    self.hook(s.i, "deferring", now)
        else:
            s.busy_ns += now - s.busy_since
            s.idle_since = now
            self._schedule(s)

    def _freeze(self, s: Station, now: int) -> None:
        s.gen += 1  # the pending expiry, if any, is void
        elapsed = now - (s.idle_since + self.p.difs_ns)
        if elapsed > 0 and s.counter:
            s.counter = max(0, s.counter - elapsed // self.p.slot_ns)

    def _schedule(self, s: Station) -> None:
        """Arm the end of ``s``'s backoff, if it counts now."""
        if s.in_exchange or s.busy or (s.counter == 0 and s.frame is None):
            return
        s.gen += 1
        t = s.idle_since + self.p.difs_ns + s.counter * self.p.slot_ns
        self.clock.at(max(t, self.clock.now_ns), _EXPIRE, self._expire, s, s.gen)

    def _expire(self, s: Station, gen: int) -> None:
        if gen != s.gen:
            return
        s.counter = 0
        if s.frame is not None:
            self._start_exchange(s)

    def _nav_check(self, s: Station) -> None:
        """A NAV set by a decoded RTS or CTS may have expired: re-sense."""
        self._update(s)

    # -- signals ----------------------------------------------------------------------------------

    def _send(self, s: Station, kind: int, to: tuple[int, ...], dur: int, nav_end: int) -> _Signal:
        """Put a frame of ``dur`` ns on the air from ``s`` now; returns its signal."""
        clock = self.clock
        now = clock.now_ns
        sig = _Signal(s.i, kind, to, now, now + dur, tuple(self.hears(s.i, now)), nav_end)
        for other in s.incoming:  # half duplex: what it was receiving is lost to it
            other.corrupt.add(s.i)
        s.tx_on += 1
        s.tx_ns += dur
        self._update(s)
        if self.hook is not None:
            self.hook(s.i, "transmitting", now)
        prop = self.p.prop_ns
        for j in sig.listeners:
            clock.at(now + prop, _ARRIVE, self._arrive, j, sig)
            clock.at(now + dur + prop, _END, self._leave, j, sig)
        clock.at(now + dur + prop, _END, self._tx_off, s)
        return sig

    def _arrive(self, j: int, sig: _Signal) -> None:
        r = self.st[j]
        if r.incoming or r.tx_on:
            sig.corrupt.add(j)
            for other in r.incoming:
                other.corrupt.add(j)
        r.incoming.add(sig)
        self._update(r)

    def _leave(self, j: int, sig: _Signal) -> None:
        r = self.st[j]
        r.incoming.discard(sig)
        if sig.nav_end > 0 and j not in sig.to and j not in sig.corrupt and sig.nav_end > r.nav_until:
            r.nav_until = sig.nav_end
            self.clock.at(sig.nav_end, _END, self._nav_check, r)
        self._update(r)

    def _tx_off(self, s: Station) -> None:
        s.tx_on -= 1
        self._update(s)

    def _decoded(self, sig: _Signal, j: int) -> bool:
        return j in sig.listeners and j not in sig.corrupt

    # -- exchanges --------------------------------------------------------------------------------

    def _start_exchange(self, s: Station) -> None:
        f = s.frame
        assert f is not None
        p = self.p
        s.in_exchange = True
        s.attempts += 1
        now = self.clock.now_ns
        if f.t_first_ns < 0:
            f.t_first_ns = now
        data = p.data_ns(f.payload_bytes)
        if f.broadcast:
            sig = self._send(s, DATA, f.dsts, data, 0)
            self.clock.at(sig.t1 + p.prop_ns, _DECIDE, self._broadcast_end, s, sig)
            return
        dst = f.dsts[0]
        if p.rts_cts:
            tail = (p.sifs_ns + self._cts_ns + p.prop_ns + p.sifs_ns + data + p.prop_ns + p.sifs_ns
                    + self._ack_ns + p.prop_ns)
            sig = self._send(s, RTS, (dst,), self._rts_ns, now + self._rts_ns + p.prop_ns + tail)
            self.clock.at(sig.t1 + p.prop_ns, _DECIDE, self._rts_end, s, sig, data)
        else:
            sig = self._send(s, DATA, (dst,), data, 0)
            self.clock.at(sig.t1 + p.prop_ns, _DECIDE, self._data_end, s, sig)

    def _can_answer(self, r: Station, sig: _Signal, need_no_nav: bool) -> bool:
        if not self._decoded(sig, r.i) or r.in_exchange or r.tx_on:
            return False
        return not (need_no_nav and self.clock.now_ns < r.nav_until)

    def _rts_end(self, s: Station, sig: _Signal, data: int) -> None:
        r = self.st[sig.to[0]]
        if not self._can_answer(r, sig, True):
            self._fail(s, sig)
            return
        p = self.p
        nav = self.clock.now_ns + p.sifs_ns + self._cts_ns + p.prop_ns + p.sifs_ns + data + p.prop_ns + p.sifs_ns \
            + self._ack_ns + p.prop_ns
        self.clock.at(self.clock.now_ns + p.sifs_ns, _EXPIRE, self._answer, r, s, CTS, self._cts_ns, nav, data)

    def _answer(self, r: Station, s: Station, kind: int, dur: int, nav_end: int, data: int) -> None:
        """The receiver ``r`` answers ``s`` with a CTS or an ACK (after SIFS, whatever it senses)."""
        sig = self._send(r, kind, (s.i,), dur, nav_end)
        nxt = self._cts_end if kind == CTS else self._ack_end
        self.clock.at(sig.t1 + self.p.prop_ns, _DECIDE, nxt, s, sig, data)

    def _cts_end(self, s: Station, sig: _Signal, data: int) -> None:
        if not self._decoded(sig, s.i):
            self._fail(s, sig)
            return
        self.clock.at(self.clock.now_ns + self.p.sifs_ns, _EXPIRE, self._data_after_cts, s, data)

    def _data_after_cts(self, s: Station, data: int) -> None:
        f = s.frame
        assert f is not None
        sig = self._send(s, DATA, f.dsts, data, 0)
        self.clock.at(sig.t1 + self.p.prop_ns, _DECIDE, self._data_end, s, sig)

    def _kept(self, frame: Frame) -> bool:
        """The radio's loss of one decoded frame (``p_ok``), drawn in event order."""
        if frame.p_ok >= 1.0 or self._loss_rng is None:
            return True
        return bool(self._loss_rng.random() < frame.p_ok)

    def _data_end(self, s: Station, sig: _Signal) -> None:
        r = self.st[sig.to[0]]
        f = s.frame
        assert f is not None
        if not self._can_answer(r, sig, False) or not self._kept(f):
            self._fail(s, sig)
            return
        self.clock.at(self.clock.now_ns + self.p.sifs_ns, _EXPIRE, self._answer, r, s, ACK, self._ack_ns, 0, 0)

    def _ack_end(self, s: Station, sig: _Signal, _data: int) -> None:
        if not self._decoded(sig, s.i):
            self._fail(s, sig)
            return
        f = s.frame
        assert f is not None
        s.delivered_frames += 1
        s.delivered_bits += 8 * f.payload_bytes
        self._finish(s, {f.dsts[0]: OK}, stage=0)

    def _broadcast_end(self, s: Station, sig: _Signal) -> None:
        f = s.frame
        assert f is not None
        out: dict[int, int] = {}
        for d in f.dsts:
            if d not in sig.listeners:
                out[d] = UNHEARD
            elif d in sig.corrupt:
                out[d] = COLLIDED
            elif not self._kept(f):
                out[d] = LOST
            else:
                out[d] = OK
                s.delivered_bits += 8 * f.payload_bytes
        if any(v == OK for v in out.values()):
            s.delivered_frames += 1
        if any(v == COLLIDED for v in out.values()):
            s.failures += 1
        self._finish(s, out, stage=0)

    def _fail(self, s: Station, sig: _Signal) -> None:
        f = s.frame
        assert f is not None
        s.failures += 1
        if self.hook is not None:
            self.hook(s.i, "collided", self.clock.now_ns)
        dst = f.dsts[0]
        if dst not in sig.listeners and sig.src == s.i:
            self._finish(s, {dst: UNHEARD}, stage=0)  # the receiver hears nothing of it: no retry helps now
            return
        f.retries += 1
        limit = self.p.retry_limit
        if limit is not None and f.retries > limit:
            s.drops += 1
            self._finish(s, {dst: DROPPED_RETRY}, stage=0)
            return
        s.stage += 1
        s.in_exchange = False
        s.counter = self._draw(s)
        s.idle_since = self.clock.now_ns if not s.busy else s.idle_since
        self._schedule(s)

    def _finish(self, s: Station, outcome: dict[int, int], stage: int) -> None:
        f = s.frame
        assert f is not None
        s.frame = None
        s.stage = stage
        s.in_exchange = False
        s.counter = self._draw(s)
        now = self.clock.now_ns
        if not s.busy:
            s.idle_since = now
        if self.hook is not None:
            self.hook(s.i, "idle", now)
        self.done(f, now, outcome)
        if s.frame is None and s.queue:
            s.frame = s.queue.popleft()
        self._schedule(s)

    def _draw(self, s: Station) -> int:
        w = self.p.cw_min << min(s.stage, self.p.max_stage)
        return int(s.rng.integers(w)) if w > 1 else 0
