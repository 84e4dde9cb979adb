"""The radio that agents' messages travel through, inside one ``simpy.Environment`` (seconds).

Model, per message (``send``):

1. At send time the link must exist: an edge of the topology (``no_link``), an open window
   (``window_closed``) and, with ``range_m``, endpoints within range (``out_of_range``).
   Failing any of these drops the message at once.
2. The message joins its transmitter's FIFO queue (one transmitter per directed link, or per
   sender with ``transmitter: agent``). At most ``queue_limit`` messages may wait behind the
   one on the air; one more is dropped (``queue_overflow``). A link busy sending a 16 MB
   map is busy: serialising S wire bytes takes 8 S / ``bandwidth_bps`` seconds.
3. Transmission starts when the transmitter frees up; the window must still be open then.
   Serialisation must end before the window closes, else the transfer is aborted at the
   closing time (``window_closed``). With ``range_m`` the endpoints must be in range at the
   start and the end of the transmission, and in packet mode at packet boundaries (at most
   every ``range_check_resolution_s``); the first failed check aborts it (``out_of_range``).
   An aborted transfer frees the transmitter at the abort time.
4. After the last bit, the message propagates for a latency drawn from ``latency`` and
   arrives, unless it is lost: with probability 1 - ``success_rate`` (``loss``), or in
   packet mode when a fragment is lost (``packet_loss``; see ``ramensim.channels.packets``).
   With the radio models of ``ramensim.channels.quality`` (``burst``, ``path_loss``,
   ``trace``) the success probability is decided per link and send time instead (eq. Q-1):
   a Gilbert-Elliott chain per link, times the path-loss success from distance and walls (a
   link with path-loss success 0 drops at send time, ``out_of_range``), or a replayed trace
   that also gives the latency.

The sender never waits: ``send`` returns the ``Message`` at once. Because the channel's
outcome depends only on the seeded draws, the window schedule and the positions, it is
planned when the message is sent and a single SimPy event per message, at the time it is
delivered or dropped, logs it, emits the event and calls the receiver (SimPy's public API
only; see ``Channel._at`` for how times stay exact). This requires
``position(agent, t)`` to be a pure function of (agent, t) (e.g. a planned trajectory): it
may be called for times later than ``env.now``.

Randomness (``channel.draws``): by default every draw of a message (its loss uniform, its
latency, its packets' uniforms) comes from a generator keyed by its link and send time
(``ramensim.channels.draws``, eq. D-1), so two runs with one seed that send on a link at the
same time meet the same outcome there whatever else they sent: methods are compared on the
same channel. ``loss_unit: edge_round`` keys the loss uniform by the undirected edge and the
round instead (eq. D-2: the authors' one Bernoulli per edge per round). With ``draws:
send_order`` (runs made before 2026-11-24) three child generators spawned from ``rng``, for
message loss, latency and packets, are each drawn a fixed number of times per accepted
message (one uniform for loss when success_rate < 1, one latency when it varies), so the
draws of one stream do not shift when another setting changes, but a method that sends more
messages sees another realisation of the same link. The radio models draw from a further
child (one generator per link's Gilbert-Elliott chain, keyed by the link, so its state path
does not depend on the traffic either), and use the same loss uniform per message.
"""
from __future__ import annotations

import logging
import math
from collections import deque
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np
import simpy
from simpy.events import Event, Timeout

from ramensim.channels.accounting import REASON_CODES, MessageLog
from ramensim.channels.config import ChannelConfig
from ramensim.channels.draws import LATENCY, PACKETS, KeyedDraws, keyed_child
from ramensim.core.events import (
    EventSink,
    Fate,
    LinkChange,
    MessageDelivered,
    MessageDropped,
    MessageSent,
    null_sink,
)
from ramensim.channels.latency import LatencySampler
from ramensim.channels.message import DELIVERED, DROPPED, Message
from ramensim.channels.packets import UniformStream, plan_transfer
from ramensim.channels.pathloss import FirstHit
from ramensim.channels.quality import LinkModels, models_active
from ramensim.channels.topology import Position, Topology
from ramensim.channels.windows import Windows

log = logging.getLogger(__name__)

# the drop reasons of ramensim.core.events.Fate as plain ints (the hot path compares and logs them)
_LOSS, _PACKET_LOSS, _OUT_OF_RANGE, _WINDOW, _OVERFLOW, _NO_LINK = (
    int(Fate.LOSS), int(Fate.PACKET_LOSS), int(Fate.OUT_OF_RANGE), int(Fate.WINDOW_CLOSED), int(Fate.QUEUE_OVERFLOW),
    int(Fate.NO_LINK))

_UBLOCK = 4096


class _Tx:
    """A transmitter: when it is free (s) and the start times (s) of the messages waiting in it."""

    __slots__ = ("free_at", "waiting")

    def __init__(self) -> None:
        self.free_at = -math.inf
        self.waiting: deque[float] = deque()


class Channel:
    """Packet-level radio between ``n_agents`` agents; see the module docstring for the model.

    ``position(agent, t) -> ndarray(3)`` (metres) is needed for ``range_m`` and disk topologies.
    ``emit`` receives ``MessageSent`` (every ``send`` call), ``MessageDelivered``,
    ``MessageDropped`` and, with ``link_monitor_period_s``, ``LinkChange`` events.
    """

    def __init__(
        self,
        env: simpy.Environment,
        cfg: ChannelConfig,
        topology: Topology,
        n_agents: int,
        rng: np.random.Generator,
        position: Position | None = None,
        emit: EventSink = null_sink,
        first_hit: FirstHit | None = None,
        base_dir: Path | None = None,
    ) -> None:
        if topology.n_agents != n_agents:
            raise ValueError(
                f"channel: the topology was built for {topology.n_agents} agents but the channel "
                f"for {n_agents}; build both for the scenario's number of agents."
            )
        if cfg.range_m is not None and position is None:
            raise ValueError(
                f"channel.range_m = {cfg.range_m} m needs agent positions, but no "
                "position(agent, t) callable was given to the Channel."
            )
        self.env = env
        self.cfg = cfg
        self.topology = topology
        self.n_agents = n_agents
        self.windows = Windows(cfg.windows, n_agents)
        self.log = MessageLog()
        """Every finished message (delivered or dropped)."""
        self._log_append = self.log.append
        self._position = position
        self._emit = emit
        self._emit_on = emit is not null_sink
        loss_rng, lat_rng, pkt_rng = rng.spawn(3)
        self._draws: KeyedDraws | None = None
        """Draws keyed by link and send time (eq. D-1, D-2); None with ``draws: send_order``."""
        if cfg.draws == "keyed":
            self._draws = KeyedDraws(keyed_child(rng.bit_generator.seed_seq, 2_000_003), cfg.loss_round_s)
        self._edge_round = cfg.loss_unit == "edge_round"
        self.models: LinkModels | None = None
        """Burst chains, path loss and trace replay (``ramensim.channels.quality``); None for i.i.d. loss only."""
        if models_active(cfg):
            self.models = LinkModels(cfg, n_agents, rng.spawn(1)[0], position, first_hit,
                                     emit if self._emit_on else None, base_dir)
        self._pkt_u = UniformStream(pkt_rng)
        self._loss_rng = loss_rng
        self._u: list[float] = []
        self._ui = 0
        self._latency = LatencySampler(cfg.latency, lat_rng)
        self._p = cfg.success_rate
        self._spb = 8.0 / cfg.bandwidth_bps
        self._header = cfg.header_bytes
        self._qlimit = cfg.queue_limit
        self._r2 = None if cfg.range_m is None else cfg.range_m**2
        self._packet = cfg.mode == "packet"
        self._retransmit = cfg.reassembly == "retransmit"
        self._simple = not self._packet and self.windows.always and self._r2 is None
        self._per_agent = cfg.transmitter == "agent"
        self._txs: list[_Tx | None] = [None] * (n_agents if self._per_agent else n_agents * n_agents)
        self._receivers: list[Callable[[Message], None] | None] = [None] * n_agents
        self._next_id = 0
        self._static = not topology.dynamic
        self._adj = [frozenset(topology.neighbours(i)) for i in range(n_agents)] if self._static else []
        self._lat_const = self._latency.constant
        self._finish_cb = self._finish
        self._hop_cb = self._hop
        if cfg.link_monitor_period_s is not None:
            env.process(self._monitor(cfg.link_monitor_period_s))

    # --- wiring -------------------------------------------------------------------------

    def attach(self, agent: int, on_receive: Callable[[Message], None]) -> None:
        """Deliver messages for ``agent`` to ``on_receive(msg)`` (called at the arrival time)."""
        self._check_agent(agent, "attach")
        self._receivers[agent] = on_receive

    def _check_agent(self, agent: int, what: str) -> None:
        if not 0 <= agent < self.n_agents:
            raise ValueError(
                f"channel.{what}: agent id {agent} is out of range; the scenario has "
                f"{self.n_agents} agents (ids 0..{self.n_agents - 1})."
            )

    # --- link state -----------------------------------------------------------------------

    @property
    def n_sent(self) -> int:
        """Messages handed to the channel so far, settled or not (the log holds the settled)."""
        return self._next_id

    def neighbours(self, agent: int) -> list[int]:
        """Topology neighbours of ``agent`` at ``env.now`` (windows and range not applied)."""
        return self.topology.neighbours(agent, self.env.now)

    def reachable(self, agent: int) -> list[int]:
        """Neighbours whose link is up now: edge, open window and in range."""
        t = self.env.now
        return [j for j in self.topology.neighbours(agent, t) if self._link_down(agent, j, t) == 0]

    def link_up(self, a: int, b: int, t: float | None = None) -> bool:
        """Whether {a, b} can carry a message at time ``t`` (s; default now)."""
        return self._link_down(a, b, self.env.now if t is None else t) == 0

    def window_open(self, a: int, b: int, t: float) -> bool:
        """Whether the window of link {a, b} is open at time ``t`` (s)."""
        return self.windows.is_open(a, b, t)

    def window_close_after(self, a: int, b: int, t: float) -> float:
        """When the window of {a, b} open at ``t`` closes (s): inf if never, ``t`` if closed."""
        return self.windows.close_after(a, b, t)

    def next_window_open(self, a: int, b: int, t: float) -> float | None:
        """Earliest time >= ``t`` (s) at which the window of {a, b} is open; None if never."""
        return self.windows.next_open(a, b, t)

    def queue_length(self, src: int, dst: int) -> int:
        """Messages now waiting (not yet on the air) in the transmitter of ``src -> dst``."""
        tx = self._txs[src if self._per_agent else src * self.n_agents + dst]
        if tx is None:
            return 0
        now = self.env.now
        return sum(1 for t in tx.waiting if t > now)

    def busy_until(self, src: int, dst: int) -> float:
        """When the transmitter of ``src -> dst`` will have sent everything queued so far (s)."""
        tx = self._txs[src if self._per_agent else src * self.n_agents + dst]
        return max(self.env.now, tx.free_at) if tx is not None else self.env.now

    def _in_range(self, a: int, b: int, t: float) -> bool:
        pos = self._position
        d = np.asarray(pos(a, t), dtype=np.float64) - np.asarray(pos(b, t), dtype=np.float64)  # type: ignore[misc]
        return float(d @ d) <= self._r2  # type: ignore[operator]

    def _link_down(self, a: int, b: int, t: float) -> int:
        """0 if {a, b} is up at t, else the reason code (no_link, window_closed, out_of_range)."""
        if not self.topology.has_edge(a, b, t):
            return _NO_LINK
        if not self.windows.always and not self.windows.is_open(a, b, t):
            return _WINDOW
        if self._r2 is not None and not self._in_range(a, b, t):
            return _OUT_OF_RANGE
        return 0

    # --- sending ----------------------------------------------------------------------------

    def broadcast(self, src: int, payload: Any, nbytes: int, stamp: float, reachable_only: bool = False) -> list[Message]:
        """``send`` to every current topology neighbour of ``src`` (only those whose link is up
        now, with ``reachable_only``); one message per neighbour, in id order."""
        dsts = self.reachable(src) if reachable_only else self.topology.neighbours(src, self.env.now)
        return [self.send(src, d, payload, nbytes, stamp) for d in dsts]

    def send(self, src: int, dst: int, payload: Any, nbytes: int, stamp: float) -> Message:
        """Queue ``payload`` (``nbytes`` bytes, state taken at ``stamp`` s) for ``src -> dst``.

        Never blocks; returns the message, whose ``status`` changes when it is delivered or
        dropped. Raises ``ValueError`` for agent ids out of range, src == dst or nbytes < 0.
        """
        n = self.n_agents
        if not (0 <= src < n and 0 <= dst < n) or src == dst or nbytes < 0:
            self._bad_send(src, dst, nbytes)
        env = self.env
        now = env.now
        mid = self._next_id
        self._next_id = mid + 1
        msg = Message(mid, src, dst, payload, nbytes, stamp, now)
        if self._emit_on:
            self._emit(MessageSent(now, mid, src, dst, nbytes, stamp))
        draws = self._draws
        dkey = draws.message_key(src, dst, now) if draws is not None else None
        if self._static:
            if dst not in self._adj[src]:
                return self._drop_now(msg, _NO_LINK)
        elif not self.topology.has_edge(src, dst, now):
            return self._drop_now(msg, _NO_LINK)
        if not self._simple:
            if not self.windows.always and not self.windows.is_open(src, dst, now):
                return self._drop_now(msg, _WINDOW)
            if self._r2 is not None and not self._in_range(src, dst, now):
                return self._drop_now(msg, _OUT_OF_RANGE)
        p = self._p
        trace_lat = None
        if self.models is not None:
            p, trace_lat, beyond = self.models.at(src, dst, now)
            if beyond:
                return self._drop_now(msg, _OUT_OF_RANGE)

        key = src if self._per_agent else src * n + dst
        tx = self._txs[key]
        if tx is None:
            tx = self._txs[key] = _Tx()
        t_start = tx.free_at
        if t_start > now:
            waiting = tx.waiting
            while waiting and waiting[0] <= now:
                waiting.popleft()
            if len(waiting) >= self._qlimit:
                return self._drop_now(msg, _OVERFLOW)
            waiting.append(t_start)
        else:
            t_start = now

        # Draws of an accepted message (see the module docstring).
        lost = False
        lat = self._lat_const
        pkt_u = self._pkt_u
        if dkey is not None:
            if p < 1.0:
                lost = draws.loss_uniform(dkey, self._edge_round, now) >= p  # type: ignore[union-attr]
            if lat is None and trace_lat is None:
                lat = self._latency.draw(draws.generator(LATENCY, dkey))  # type: ignore[union-attr]
            if self._packet:
                pkt_u = UniformStream(draws.generator(PACKETS, dkey))  # type: ignore[union-attr]
        else:
            if p < 1.0:
                i = self._ui
                if i >= len(self._u):
                    self._u = self._loss_rng.random(_UBLOCK).tolist()
                    i = 0
                self._ui = i + 1
                lost = self._u[i] >= p
            if lat is None:
                lat = self._latency()
        if trace_lat is not None:
            lat = trace_lat

        msg.t_start = t_start
        if self._simple:
            wire = nbytes + self._header
            msg.wire_bytes = wire
            t_end = t_start + wire * self._spb
            tx.free_at = t_end
            if lost:
                msg._fate = _LOSS
            t = t_end + lat
            d = t - now
            if now + d == t:  # exact, as nearly always (see _at)
                Timeout(env, d, msg).callbacks.append(self._finish_cb)
            else:
                self._at(t, msg)
        else:
            self._plan(msg, tx, now, t_start, lat, lost, pkt_u)
        return msg

    def _bad_send(self, src: int, dst: int, nbytes: int) -> None:
        if src == dst:
            raise ValueError(f"channel.send: src and dst are both agent {src}; an agent does not send to itself.")
        if nbytes < 0:
            raise ValueError(f"channel.send: nbytes = {nbytes} from agent {src} to {dst}; a size is >= 0 bytes.")
        self._check_agent(src, "send")
        self._check_agent(dst, "send")

    def _plan(self, msg: Message, tx: _Tx, now: float, t_start: float, lat: float, lost: bool,
              pkt_u: UniformStream) -> None:
        """Decide the fate and time of a message that is not on the fast path (windows, range,
        packets); ``pkt_u`` gives the packets' uniforms."""
        cfg = self.cfg
        a, b = msg.src, msg.dst
        w = self.windows
        if t_start > now and not w.always and not w.is_open(a, b, t_start):
            msg._fate = _WINDOW
            self._at(t_start, msg)
            return
        want_bounds = self._packet and self._r2 is not None
        if self._packet:
            plan = plan_transfer(
                msg.nbytes, cfg.mtu_bytes, self._header, cfg.bandwidth_bps, cfg.packet_loss,
                self._retransmit, cfg.max_retries, cfg.retry_delay_s, pkt_u, want_bounds,
            )
            duration, ok, wire = plan.duration_s, plan.ok, plan.wire_bytes
            msg.packets, msg.retries = plan.packets, plan.retries
            bounds = plan.boundaries_s
        else:
            wire = msg.nbytes + self._header
            duration, ok, bounds = wire * self._spb, True, None
        t_end = t_start + duration

        abort_t, fate = math.inf, 0
        if not w.always:
            t_close = w.close_after(a, b, t_start)
            if t_end > t_close:
                abort_t, fate = t_close, _WINDOW
        if self._r2 is not None:
            for c in self._checkpoints(t_start, t_end, bounds):
                if c > abort_t:
                    break
                if not self._in_range(a, b, c):
                    abort_t, fate = c, _OUT_OF_RANGE
                    break

        if fate:
            msg.wire_bytes = int(round(wire * (abort_t - t_start) / duration)) if duration > 0 else 0
            tx.free_at = abort_t
            msg._fate = fate
            self._at(abort_t, msg)
            return
        msg.wire_bytes = wire
        tx.free_at = t_end
        if not ok:
            msg._fate = _PACKET_LOSS
            # retransmit: the sender gives up at t_end; all_or_nothing: the receiver finds the gap on arrival.
            self._at(t_end if self._retransmit else t_end + lat, msg)
            return
        if lost:
            msg._fate = _LOSS
        self._at(t_end + lat, msg)

    def _checkpoints(self, t_start: float, t_end: float, bounds: np.ndarray | None) -> Iterator[float]:
        """Times (s) at which range is checked: start, packet boundaries (thinned to the
        resolution) and end."""
        yield t_start
        if bounds is not None and bounds.size > 1:
            inner = t_start + bounds[:-1]
            res = self.cfg.range_check_resolution_s
            if res > 0.0:
                bins = np.floor((inner - t_start) / res)
                inner = inner[np.flatnonzero(np.diff(bins, prepend=0.0) > 0)]
            yield from inner.tolist()
        yield t_end

    # --- finishing --------------------------------------------------------------------------

    def _at(self, t: float, msg: Message) -> None:
        """Deliver or drop the message at time ``t`` (s), exactly, with SimPy's public API.

        SimPy schedules relative delays: a ``Timeout`` of d fires at ``now + d``. With
        d = ``t - now`` that is exactly ``t`` whenever t <= 2 now (Sterbenz) and nearly always
        otherwise, and the message is one ``Timeout`` (priority NORMAL, first in first out
        among the events due at ``t``). Otherwise ``now + d`` is a rounding tie for every d
        near ``t - now`` and no delay lands on ``t`` (sent at 0.13 s, due at 1.7 s: it would
        fire at 1.6999999999999997 s; 30 of 367,000 messages in the runs of docs/KERNEL.md).
        Then the message first hops to the next representable time after ``now``, where the
        tie is gone, and is scheduled from there (``_hop`` calls ``_at`` again). So it is never
        early or late (a transfer aborted when its window closes is dropped at the closing, not
        an ulp before, while the window is still open) and keeps its place among the events due
        at ``t``, except events that others schedule for exactly ``t`` at the very instant it
        was sent.
        """
        env = self.env
        now = env.now
        d = t - now
        if now + d == t:
            Timeout(env, d, msg).callbacks.append(self._finish_cb)
        else:
            Timeout(env, math.nextafter(now, math.inf) - now, (t, msg)).callbacks.append(self._hop_cb)

    def _hop(self, ev: Event) -> None:
        self._at(*ev.value)

    def _drop_now(self, msg: Message, fate: int) -> Message:
        msg._fate = fate
        self._record(msg, self.env.now)
        return msg

    def _finish(self, ev: Event) -> None:
        self._record(ev.value, self.env.now)

    def _record(self, msg: Message, t: float) -> None:
        msg.t_done = t
        fate = msg._fate
        self._log_append(
            (msg.id, msg.src, msg.dst, msg.nbytes, msg.wire_bytes, msg.t_sent, msg.t_start, t,
             msg.stamp, 1 if fate else 0, fate, msg.packets, msg.retries)
        )
        if fate:
            msg.status = DROPPED
            msg.reason = REASON_CODES[fate]
            if self._emit_on:
                self._emit(MessageDropped(t, msg.id, msg.src, msg.dst, msg.nbytes, msg.stamp, msg.reason))
            return
        msg.status = DELIVERED
        if self._emit_on:
            self._emit(
                MessageDelivered(t, msg.id, msg.src, msg.dst, msg.nbytes, msg.stamp, t - msg.t_sent, t - msg.stamp)
            )
        cb = self._receivers[msg.dst]
        if cb is not None:
            cb(msg)
        else:
            log.debug("message %d delivered to agent %d, which has no receiver attached", msg.id, msg.dst)

    # --- link monitor -----------------------------------------------------------------------

    def _monitor(self, period: float) -> Iterator[simpy.Event]:
        """Poll every candidate link each ``period`` s; emit LinkChange on each change (cause:
        initial, topology, window or range)."""
        names = {_NO_LINK: "topology", _WINDOW: "window", _OUT_OF_RANGE: "range"}
        pairs = self.topology.candidate_pairs()
        state: dict[tuple[int, int], int] = {}
        while True:
            t = self.env.now
            for a, b in pairs:
                down = self._link_down(a, b, t)
                prev = state.get((a, b))
                if prev is None:
                    if down == 0:
                        self._emit(LinkChange(t, a, b, True, "initial"))
                elif (prev == 0) != (down == 0):
                    cause = names[down] if down else names[prev]
                    self._emit(LinkChange(t, a, b, down == 0, cause))
                state[(a, b)] = down
            yield self.env.timeout(period)
