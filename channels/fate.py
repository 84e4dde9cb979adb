"""The fate of one message, decided when it is sent: one pure function, :func:`plan_fate`.

Given the radio's settings (:class:`Radio`), the link's state at send time (is there an edge,
when is its transmitter free, how many messages wait in it) and the message's random draws
(:class:`MessageDraws`), ``plan_fate`` says what becomes of the message (a
``ramensim.core.events.Fate``: delivered or one drop reason), when that happens (s), when its
transmission starts and when the transmitter is free again. The channel
(``ramensim.channels.channel``) owns the state (transmitter queues, message ids, SimPy events)
and applies the plan; nothing here changes it. The steps, in the order they are checked (the
channel's model, its module docstring):

1. at send time: an edge of the topology (``no_link``), an open window (``window_closed``),
   endpoints within range (``out_of_range``), and with the radio models a path-loss success
   above 0 (``out_of_range``); each drops the message at once;
2. the transmitter's queue: at most ``queue_limit`` messages may wait (``queue_overflow``,
   at once);
3. the transfer, from ``t_start`` (the transmitter's free time, or now): the window open at the
   start and until the last bit (``window_closed`` at the start or at the closing), in range at
   every checkpoint (``out_of_range`` at the first failed one), every packet through
   (``packet_loss``);
4. the message's Bernoulli (``loss``: lost when its uniform is >= the success probability),
   and its latency: delivered at t_end + latency.

Draws are asked for only by messages that pass steps 1 and 2, loss first, then latency, then
packets, so the ``send_order`` streams are consumed exactly as the channel always consumed
them, and keyed draws (``ramensim.channels.draws``) are a function of the link and send time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterator, Protocol

import numpy as np

from ramensim.channels.config import ChannelConfig
from ramensim.channels.packets import UniformStream, plan_transfer
from ramensim.channels.quality import LinkModels
from ramensim.channels.windows import Windows
from ramensim.core.events import Fate

# the codes of ramensim.core.events.Fate as plain ints (compared and logged on the hot path)
DELIVERED = int(Fate.DELIVERED)
LOSS, PACKET_LOSS, OUT_OF_RANGE = int(Fate.LOSS), int(Fate.PACKET_LOSS), int(Fate.OUT_OF_RANGE)
WINDOW_CLOSED, QUEUE_OVERFLOW, NO_LINK = int(Fate.WINDOW_CLOSED), int(Fate.QUEUE_OVERFLOW), int(Fate.NO_LINK)

InRange = Callable[[int, int, float], bool]
"""``in_range(a, b, t)``: whether agents a and b are within radio range at time t (s)."""


class MessageDraws(Protocol):
    """The random draws of one message, asked for lazily in this order (see the module docstring)."""

    def lost(self, p: float) -> bool:
        """Whether the message's Bernoulli says lost, for success probability ``p`` < 1."""

    def uniform(self) -> float:
        """The message's loss uniform itself (what ``lost`` compares; drawn once either way)."""

    def latency(self, trace_latency: float | None) -> float:
        """The propagation delay (s); a replayed trace's own latency when it gives one."""

    def packet_uniforms(self) -> UniformStream:
        """The uniforms of its packets (packet mode)."""


@dataclass(frozen=True, slots=True)
class Radio:
    """What ``plan_fate`` knows of the radio: its settings and the links' functions of time."""

    cfg: ChannelConfig
    windows: Windows | None
    """The links' windows; None when every link is always open."""
    in_range: InRange | None
    """The range test; None without ``range_m``."""
    models: LinkModels | None
    """Burst chains, path loss and trace replay (``channels.quality``); None for i.i.d. loss."""

    @property
    def simple(self) -> bool:
        """Message mode, always open, no range: a transfer's fate is known without checkpoints."""
        return self.cfg.mode != "packet" and self.windows is None and self.in_range is None


class Plan:
    """What becomes of one message (the result of :func:`plan_fate`); times in seconds."""

    __slots__ = ("fate", "t_done", "at_send", "t_start", "free_at", "queued", "wire_bytes", "packets", "retries")

    def __init__(self, fate: int, t_done: float, at_send: bool, t_start: float, free_at: float, queued: bool,
                 wire_bytes: int = 0, packets: int = 1, retries: int = 0) -> None:
        self.fate = fate
        """``Fate`` code: 0 delivered, else the drop reason."""
        self.t_done = t_done
        """When it is delivered or dropped."""
        self.at_send = at_send
        """Dropped at once by steps 1-2: never queued, no draws, the transmitter untouched."""
        self.t_start = t_start
        """When its transmission starts (the send time for a message dropped at send)."""
        self.free_at = free_at
        """When the transmitter is free after it (unchanged for a message that never went on the air)."""
        self.queued = queued
        """It waits behind another message (its start time joins the transmitter's queue)."""
        self.wire_bytes = wire_bytes
        """Bytes put on the air (payload, headers, retransmissions; a share of them if aborted)."""
        self.packets = packets
        self.retries = retries


def link_closed(radio: Radio, a: int, b: int, t: float) -> int:
    """Why an edge a - b of the topology carries nothing at time ``t`` (s): ``WINDOW_CLOSED``,
    ``OUT_OF_RANGE``, or 0 when it is open (step 1 after the edge, in this order)."""
    w = radio.windows
    if w is not None and not w.is_open(a, b, t):
        return WINDOW_CLOSED
    if radio.in_range is not None and not radio.in_range(a, b, t):
        return OUT_OF_RANGE
    return 0


def at_send(radio: Radio, src: int, dst: int, now: float, edge: bool, state: object = None
            ) -> tuple[int, float, float | None, tuple[tuple[int, float], ...]]:
    """Step 1 at send time ``now`` (s): ``(fate, success, trace_latency, named)``, fate 0 when
    the message may go on (then ``success`` is its probability of arriving, eq. Q-1,
    ``trace_latency`` a replayed trace's latency or None, and ``named`` the (reason code, factor)
    of the radio models that name their own drop reason), else the reason it drops at once.
    ``state`` (a ``ChannelState``) goes to the models that read it."""
    p = radio.cfg.success_rate
    if not edge:
        return NO_LINK, p, None, ()
    if radio.windows is not None or radio.in_range is not None:
        down = link_closed(radio, src, dst, now)
        if down:
            return down, p, None, ()
    trace_lat = None
    named: tuple[tuple[int, float], ...] = ()
    models = radio.models
    if models is not None:
        if models.extended:
            p, trace_lat, beyond, named = models.at_full(src, dst, now, state)
        else:
            p, trace_lat, beyond = models.at(src, dst, now)
        if beyond:
            return OUT_OF_RANGE, p, None, ()
    return 0, p, trace_lat, named


def lost_fate(p: float, named: tuple[tuple[int, float], ...], draws: MessageDraws) -> int:
    """The message's Bernoulli (step 4): 0 when it arrives, ``LOSS`` when its uniform u >= p,
    or the reason a radio model named when the message would have arrived without that model's
    factor (u < p / factor: the first such model in order)."""
    if p >= 1.0:
        return 0
    if not named:
        return LOSS if draws.lost(p) else 0
    u = draws.uniform()
    if u < p:
        return 0
    for code, factor in named:
        if factor > 0.0 and u < p / factor:
            return code
    return LOSS


def plan_fate(radio: Radio, src: int, dst: int, nbytes: int, now: float, edge: bool, free_at: float,
              waiting: int, draws: MessageDraws, state: object = None) -> Plan:
    """The fate of ``nbytes`` payload bytes sent on ``src -> dst`` at ``now`` (s), given whether
    the topology joins them (``edge``), when their transmitter is free (``free_at``, s) and how
    many messages wait in it at ``now`` (``waiting``). Steps 1-4 of the module docstring."""
    down, p, trace_lat, named = at_send(radio, src, dst, now, edge, state)
    if down:
        return Plan(down, now, True, now, free_at, False)
    cfg = radio.cfg
    queued = free_at > now
    if queued:
        if waiting >= cfg.queue_limit:
            return Plan(QUEUE_OVERFLOW, now, True, now, free_at, False)
        t_start = free_at
    else:
        t_start = now
    lost = lost_fate(p, named, draws)
    lat = draws.latency(trace_lat)
    if radio.simple:
        wire = nbytes + cfg.header_bytes
        t_end = t_start + wire * (8.0 / cfg.bandwidth_bps)
        return Plan(lost, t_end + lat, False, t_start, t_end, queued, wire)
    return _transfer(radio, src, dst, nbytes, now, t_start, free_at, queued, lat, lost, draws)


def _transfer(radio: Radio, a: int, b: int, nbytes: int, now: float, t_start: float, free_at: float,
              queued: bool, lat: float, lost: int, draws: MessageDraws) -> Plan:
    """Step 3 with windows, range or packets: when the transfer ends, or where it is cut."""
    cfg = radio.cfg
    w = radio.windows
    if queued and w is not None and not w.is_open(a, b, t_start):
        return Plan(WINDOW_CLOSED, t_start, False, t_start, free_at, queued)
    packet = cfg.mode == "packet"
    retransmit = cfg.reassembly == "retransmit"
    in_range = radio.in_range
    packets, retries = 1, 0
    if packet:
        plan = plan_transfer(nbytes, cfg.mtu_bytes, cfg.header_bytes, cfg.bandwidth_bps, cfg.packet_loss,
                             retransmit, cfg.max_retries, cfg.retry_delay_s, draws.packet_uniforms(),
                             in_range is not None)
        duration, ok, wire = plan.duration_s, plan.ok, plan.wire_bytes
        packets, retries, bounds = plan.packets, plan.retries, plan.boundaries_s
    else:
        wire = nbytes + cfg.header_bytes
        duration, ok, bounds = wire * (8.0 / cfg.bandwidth_bps), True, None
    t_end = t_start + duration

    abort_t, fate = math.inf, DELIVERED
    if w is not None:
        t_close = w.close_after(a, b, t_start)
        if t_end > t_close:
            abort_t, fate = t_close, WINDOW_CLOSED
    if in_range is not None:
        for c in checkpoints(t_start, t_end, bounds, cfg.range_check_resolution_s):
            if c > abort_t:
                break
            if not in_range(a, b, c):
                abort_t, fate = c, OUT_OF_RANGE
                break
    if fate:
        sent = int(round(wire * (abort_t - t_start) / duration)) if duration > 0 else 0
        return Plan(fate, abort_t, False, t_start, abort_t, queued, sent, packets, retries)
    if not ok:
        # retransmit: the sender gives up at t_end; all_or_nothing: the receiver finds the gap on arrival.
        return Plan(PACKET_LOSS, t_end if retransmit else t_end + lat, False, t_start, t_end, queued, wire,
                    packets, retries)
    return Plan(lost or DELIVERED, t_end + lat, False, t_start, t_end, queued, wire, packets, retries)


def checkpoints(t_start: float, t_end: float, bounds: np.ndarray | None, resolution_s: float) -> Iterator[float]:
    """Times (s) at which range is checked during a transfer: its start, its packet boundaries
    (``bounds``, offsets from the start; at most one per ``resolution_s``) and its end."""
    yield t_start
    if bounds is not None and bounds.size > 1:
        inner = t_start + bounds[:-1]
        if resolution_s > 0.0:
            bins = np.floor((inner - t_start) / resolution_s)
            inner = inner[np.flatnonzero(np.diff(bins, prepend=0.0) > 0)]
        yield from inner.tolist()
    yield t_end
