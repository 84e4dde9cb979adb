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
planned when the message is sent, by one pure function (``ramensim.channels.fate.plan_fate``,
where every drop reason above is decided), and a single SimPy event per message, at the time
it is delivered or dropped, logs it, emits the event and calls the receiver (SimPy's public API
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
from ramensim.channels.draws import KeyedDraws, KeyedMessage, SendOrder, keyed_child
from ramensim.channels.fate import (
    NO_LINK,
    OUT_OF_RANGE,
    QUEUE_OVERFLOW,
    WINDOW_CLOSED,
    Radio,
    at_send,
    link_closed,
    lost_fate,
    plan_fate,
)
from ramensim.core.events import (
    EventSink,
    LinkChange,
    MessageDelivered,
    MessageDropped,
    MessageSent,
    null_sink,
    reason_name,
)
from ramensim.channels.latency import LatencySampler
from ramensim.channels.medium.shared import SharedMedium
from ramensim.channels.message import DELIVERED, DROPPED, Message
from ramensim.channels.packets import UniformStream
from ramensim.channels.pathloss import FirstHit
from ramensim.channels.quality import LinkModels, models_active
from ramensim.channels.radios import ChannelState
from ramensim.channels.topology import Position, Topology
from ramensim.channels.windows import Windows

log = logging.getLogger(__name__)



class _Tx:
    """A transmitter: when it is free (s), the start times (s) of the messages waiting in it and
    their payload sizes (bytes)."""

    __slots__ = ("free_at", "waiting", "sizes")

    def __init__(self) -> None:
        self.free_at = -math.inf
        self.waiting: deque[float] = deque()
        self.sizes: deque[int] = deque()


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
        shared = cfg.medium.kind == "shared"
        self.log = MessageLog(shared=shared)
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
        self._latency = LatencySampler(cfg.latency, lat_rng)
        self._send_order = SendOrder(loss_rng, self._latency, UniformStream(pkt_rng))
        """The draws of ``draws: send_order`` (unused with keyed draws)."""
        self._r2 = None if cfg.range_m is None else cfg.range_m**2
        self._radio = Radio(cfg, None if self.windows.always else self.windows,
                            None if self._r2 is None else self._in_range, self.models)
        """What ``plan_fate`` needs of this radio."""
        self._per_agent = cfg.transmitter == "agent"
        self._txs: list[_Tx | None] = [None] * (n_agents if self._per_agent else n_agents * n_agents)
        self._receivers: list[Callable[[Message], None] | None] = [None] * n_agents
        self._next_id = 0
        self._static = not topology.dynamic
        self._adj = [frozenset(topology.neighbours(i)) for i in range(n_agents)] if self._static else []
        self._finish_cb = self._finish
        self._hop_cb = self._hop
        self._wants_state = self.models is not None and self.models.wants_state
        """A radio model reads the channel's state (``ChannelState``) at each send."""
        self._offered: list[deque[tuple[float, int]]] = [deque() for _ in range(n_agents)]
        self.medium: SharedMedium | None = None
        """The shared air (``channel.medium.kind: shared``); None when every link owns its bandwidth."""
        if shared:
            if self.models is not None and self.models.trace is not None:
                _refuse_full_trace(self.models.trace, topology)
            self.medium = SharedMedium(env, cfg, n_agents, np.random.default_rng(keyed_child(rng.bit_generator.seed_seq, 3_000_017)),
                                       position, first_hit, self._medium_done, _radio_hook(emit) if self._emit_on else None)
            self.log.medium = self.medium_summary
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
            return NO_LINK
        return link_closed(self._radio, a, b, t)

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
        edge = dst in self._adj[src] if self._static else self.topology.has_edge(src, dst, now)
        keyed = self._draws
        draws = self._send_order if keyed is None else KeyedMessage(
            keyed, keyed.message_key(src, dst, now), self._edge_round, now, self._latency)
        state = self._state_of(src, dst, now, nbytes) if self._wants_state else None
        if self.medium is not None:  # the radio's own queue, on the shared air
            return self._send_shared(msg, edge, draws, state)
        tx_key = src if self._per_agent else src * n + dst
        tx = self._txs[tx_key]
        if tx is None:
            tx = self._txs[tx_key] = _Tx()
        free_at = tx.free_at
        waiting = tx.waiting
        if free_at > now:
            while waiting and waiting[0] <= now:
                waiting.popleft()
                tx.sizes.popleft()
        plan = plan_fate(self._radio, src, dst, nbytes, now, edge, free_at, len(waiting), draws, state)
        if plan.at_send:
            return self._drop_now(msg, plan.fate)
        if plan.queued:
            waiting.append(plan.t_start)
            tx.sizes.append(nbytes)
        tx.free_at = plan.free_at
        msg.t_start = plan.t_start
        msg.wire_bytes = plan.wire_bytes
        msg.packets = plan.packets
        msg.retries = plan.retries
        msg._fate = plan.fate
        self._at(plan.t_done, msg)
        return msg

    def _state_of(self, src: int, dst: int, now: float, nbytes: int) -> ChannelState:
        """What a radio model that reads the channel's state sees of ``src -> dst`` now (the
        message being sent excluded), and the sender's offered load over the last second."""
        recent = self._offered[src]
        while recent and recent[0][0] <= now - 1.0:
            recent.popleft()
        offered = 8.0 * sum(b for _, b in recent)
        recent.append((now, nbytes))
        if self.medium is not None:
            jobs = self.medium.waiting_jobs(src)
            sizes = [j.nbytes for j in jobs]
            to_dst = [j.nbytes for j in jobs if dst in j.msgs]
            return ChannelState(len(to_dst), len(sizes), sum(to_dst), sum(sizes), offered,
                                self.medium.senses_busy(src), len(sizes))

        def waiting_of(tx: _Tx | None) -> tuple[int, int]:
            if tx is None:
                return 0, 0
            pairs = [(t, b) for t, b in zip(tx.waiting, tx.sizes) if t > now]
            return len(pairs), sum(b for _, b in pairs)

        n = self.n_agents
        if self._per_agent:
            q, b = waiting_of(self._txs[src])
            return ChannelState(q, q, b, b, offered)
        ql, bl = waiting_of(self._txs[src * n + dst])
        both = [waiting_of(self._txs[src * n + j]) for j in range(n) if j != src]
        return ChannelState(ql, sum(x for x, _ in both), bl, sum(y for _, y in both), offered)

    def _send_shared(self, msg: Message, edge: bool, draws: Any, state: Any = None) -> Message:
        """``send`` on the shared medium: step 1 and the queue now, the loss coin and the latency
        drawn now (as on private links), the air decided by the medium (``channels/medium``)."""
        medium = self.medium
        assert medium is not None
        src, dst, now = msg.src, msg.dst, msg.t_sent
        down, p, trace_lat, named = at_send(self._radio, src, dst, now, edge, state)
        if down:
            return self._drop_now(msg, down)
        if not medium.accepts(msg, self.cfg.queue_limit):
            return self._drop_now(msg, QUEUE_OVERFLOW)
        per_frame = self.cfg.medium.loss == "frame"
        msg._fate = 0 if per_frame else lost_fate(p, named, draws)
        msg.latency_draw = draws.latency(trace_lat)
        medium.submit(msg, msg.nbytes + self.cfg.header_bytes, p if per_frame else 1.0)
        return msg

    def _medium_done(self, msg: Message, t_start: float, t_end: float, fate: int, wire: int, frames: int,
                     retries: int) -> None:
        """The medium is done with ``msg`` at ``t_end`` (s): a drop of the air's, or the last bit
        out; then the window and range at the end (the transfer's rule of step 3), the loss coin
        and the latency decide the rest."""
        msg.t_start = t_start if t_start >= 0 else t_end
        msg.wire_bytes = wire
        msg.packets = frames
        msg.retries = retries
        a, b = msg.src, msg.dst
        if not fate and self._radio.windows is not None:
            w = self._radio.windows
            if not w.is_open(a, b, msg.t_start) or w.close_after(a, b, msg.t_start) < t_end:
                fate = WINDOW_CLOSED
        if not fate and self._r2 is not None and not self._in_range(a, b, t_end):
            fate = OUT_OF_RANGE
        if fate:
            msg._fate = fate
            self._at(max(t_end, self.env.now), msg)
            return
        self._at(max(t_end + msg.latency_draw, self.env.now), msg)

    def medium_summary(self) -> dict[str, Any] | None:
        """metrics.json's ``medium`` section (``SharedMedium.summary``), None on private links."""
        return None if self.medium is None else self.medium.summary(self.env.now)

    def _bad_send(self, src: int, dst: int, nbytes: int) -> None:
        if src == dst:
            raise ValueError(f"channel.send: src and dst are both agent {src}; an agent does not send to itself.")
        if nbytes < 0:
            raise ValueError(f"channel.send: nbytes = {nbytes} from agent {src} to {dst}; a size is >= 0 bytes.")
        self._check_agent(src, "send")
        self._check_agent(dst, "send")

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
            msg.reason = REASON_CODES[fate] if fate < len(REASON_CODES) else reason_name(fate)
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
        names = {NO_LINK: "topology", WINDOW_CLOSED: "window", OUT_OF_RANGE: "range"}
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


def _refuse_full_trace(trace: Any, topology: Topology) -> None:
    """A trace that lists every link would decide every message's delivery and latency, so the
    shared medium would decide nothing: refuse the pair (issue 66, item 7)."""
    pairs = topology.candidate_pairs()
    listed = set(trace.links)
    if pairs and all((a, b) in listed and (b, a) in listed for a, b in pairs):
        raise ValueError(
            "channel.trace lists every link of the topology, and channel.medium.kind is 'shared': the trace "
            "would decide every message's delivery and latency and the shared medium nothing. Use one of them: "
            "remove channel.trace.path, or set channel.medium.kind: links (the trace then decides the links it "
            "lists, as always).")


def _radio_hook(emit: EventSink) -> Callable[[int, str, int], None]:
    """The medium's radio states as ``RadioState`` events on the bus (the recording's timeline)."""
    from ramensim.core.events import RadioState

    last: dict[int, str] = {}

    def hook(agent: int, state: str, t_ns: int) -> None:
        if last.get(agent) != state:  # changes only: a deferring radio is told once per wait
            last[agent] = state
            emit(RadioState(t_ns / 1e9, agent, state))

    return hook

