"""Keyed random draws: a message's fate depends on its link and send time, not on the traffic.

With ``channel.draws: keyed`` (the default) every random number the channel uses for one
message (its loss uniform, its latency, its packets' uniforms) comes from a generator seeded
by

    key = (root seed, stream, src, dst, slot, k),   slot = round(t_sent / 1 us)       (D-1)

where ``k`` counts the messages already sent on ``src -> dst`` in the same slot (0 for the
first). Two runs with the same seed, say RAMEN and DiNNO, that send on a link at the same
simulated time therefore meet the same outcome there (lost or not, the same latency), however
many other messages either of them sent before; a method that sends ten times as often gets
fresh, independent draws at its other send times. Times are rounded to the microsecond so
that send times computed by different float sums of the same round costs still match.

With ``channel.loss_unit: edge_round`` (the authors' model) the loss uniform is instead keyed
by the undirected edge and the round index

    key = (root seed, stream, min(a, b), max(a, b), floor(t_sent / round_s + 1e-6))   (D-2)

so both directions of an edge share one Bernoulli per round (``loss_round_s``), and every
message of that round on that edge shares its fate.

``channel.draws: send_order`` keeps the earlier scheme (one stream per kind of draw, consumed
in send order), which reproduces runs made before the keyed draws.

``KeyedMessage`` and ``SendOrder`` hand one message's draws to ``channels.fate.plan_fate``
(its ``MessageDraws``) under each scheme.
"""
from __future__ import annotations

import math

import numpy as np

from ramensim.channels.latency import LatencySampler
from ramensim.channels.packets import UniformStream

RESOLUTION_S = 1e-6
"""Send times within this many seconds (rounded to the nearest multiple) share a slot (s)."""

LOSS, LATENCY, PACKETS, EDGE_LOSS = 1, 2, 3, 4
"""Stream ids in the key (D-1, D-2): one per kind of draw, so the kinds never share numbers."""

_EDGE_EPS = 1e-6
_TO_UNIT = 2.0**-53
_UBLOCK = 4096


def keyed_child(parent: np.random.SeedSequence, *key: int) -> np.random.SeedSequence:
    """A child of ``parent`` named by ``key`` (non-negative ints): the same key always gives the
    same child, whatever was spawned or drawn before (unlike ``SeedSequence.spawn``)."""
    return np.random.SeedSequence(parent.entropy, spawn_key=tuple(parent.spawn_key) + tuple(key))


class KeyedDraws:
    """Seeded draws keyed by (stream, link, send time): see the module docstring (D-1, D-2).

    ``message_key(src, dst, t)`` must be called once per message, at non-decreasing times per
    link (the channel's send times), before any draw for that message.
    """

    __slots__ = ("_root", "_last", "_round_s")

    def __init__(self, seed_seq: np.random.SeedSequence, loss_round_s: float = 1.0) -> None:
        self._root = seed_seq
        self._last: dict[tuple[int, int], tuple[int, int]] = {}
        self._round_s = loss_round_s

    def message_key(self, src: int, dst: int, t: float) -> tuple[int, int, int, int]:
        """(src, dst, slot, k) of the next message sent on ``src -> dst`` at ``t`` (s) (D-1)."""
        slot = int(round(t / RESOLUTION_S))
        last = self._last.get((src, dst))
        k = last[1] + 1 if last is not None and last[0] == slot else 0
        self._last[(src, dst)] = (slot, k)
        return (src, dst, slot, k)

    def _seq(self, stream: int, key: tuple[int, ...]) -> np.random.SeedSequence:
        return keyed_child(self._root, stream, *key)

    def uniform(self, stream: int, key: tuple[int, ...]) -> float:
        """One uniform in [0, 1) for ``key`` in ``stream`` (53 random bits of its seed state)."""
        x = int(self._seq(stream, key).generate_state(1, np.uint64)[0])
        return (x >> 11) * _TO_UNIT

    def generator(self, stream: int, key: tuple[int, ...]) -> np.random.Generator:
        """A generator of its own for ``key`` in ``stream``, for draws of any number or kind."""
        return np.random.Generator(np.random.PCG64(self._seq(stream, key)))

    def edge_round(self, a: int, b: int, t: float) -> tuple[int, int, int]:
        """(min, max, round index) of the undirected edge {a, b} at send time ``t`` (s) (D-2)."""
        r = math.floor(t / self._round_s + _EDGE_EPS)
        return (a, b, r) if a < b else (b, a, r)

    def loss_uniform(self, key: tuple[int, int, int, int], edge_round: bool, t: float) -> float:
        """The uniform compared with the success probability for the message ``key`` sent at ``t`` (s):
        per message (D-1), or shared by the edge's two directions in the round (D-2)."""
        if edge_round:
            return self.uniform(EDGE_LOSS, self.edge_round(key[0], key[1], t))
        return self.uniform(LOSS, key)


class KeyedMessage:
    """One message's draws under keyed draws (``channels.fate.MessageDraws``): each a function
    of the message's key (D-1) or its edge and round (D-2), whatever the traffic."""

    __slots__ = ("_draws", "_key", "_edge_round", "_t", "_latency")

    def __init__(self, draws: KeyedDraws, key: tuple[int, int, int, int], edge_round: bool, t: float,
                 latency: LatencySampler) -> None:
        self._draws = draws
        self._key = key
        self._edge_round = edge_round
        self._t = t
        self._latency = latency

    def lost(self, p: float) -> bool:
        """Lost when the message's loss uniform is >= ``p``."""
        return self._draws.loss_uniform(self._key, self._edge_round, self._t) >= p

    def uniform(self) -> float:
        """The message's loss uniform (the one ``lost`` compares)."""
        return self._draws.loss_uniform(self._key, self._edge_round, self._t)

    def latency(self, trace_latency: float | None) -> float:
        """The trace's latency, else the constant one, else a draw from the message's own generator (s)."""
        if trace_latency is not None:
            return trace_latency
        if self._latency.constant is not None:
            return self._latency.constant
        return self._latency.draw(self._draws.generator(LATENCY, self._key))

    def packet_uniforms(self) -> UniformStream:
        """The packets' uniforms from the message's own generator, in blocks of 64: a transfer
        asks for one per packet (at most 64 one by one, more as one array), so a block of 4,096
        would draw thousands it never uses (the values are the same either way)."""
        return UniformStream(self._draws.generator(PACKETS, self._key), block=64)


class SendOrder:
    """The draws of ``channel.draws: send_order`` (``channels.fate.MessageDraws``): three
    streams, for loss, latency and packets, each consumed in the order messages ask, one loss
    uniform per message with success probability < 1 and one latency per message when it varies
    (even when a trace gives the latency), so one stream's draws never shift another's."""

    __slots__ = ("_loss_rng", "_u", "_ui", "_latency", "_packets")

    def __init__(self, loss_rng: np.random.Generator, latency: LatencySampler, packets: UniformStream) -> None:
        self._loss_rng = loss_rng
        self._u: list[float] = []
        self._ui = 0
        self._latency = latency
        self._packets = packets

    def lost(self, p: float) -> bool:
        """Lost when the loss stream's next uniform is >= ``p`` (uniforms drawn 4,096 at a time)."""
        return self.uniform() >= p

    def uniform(self) -> float:
        """The loss stream's next uniform (what ``lost`` compares)."""
        i = self._ui
        if i >= len(self._u):
            self._u = self._loss_rng.random(_UBLOCK).tolist()
            i = 0
        self._ui = i + 1
        return self._u[i]

    def latency(self, trace_latency: float | None) -> float:
        """The latency stream's next delay (s), replaced by the trace's latency when it gives one."""
        lat = self._latency()
        return lat if trace_latency is None else trace_latency

    def packet_uniforms(self) -> UniformStream:
        """The packet stream shared by every message."""
        return self._packets
