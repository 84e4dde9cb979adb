"""Fragmentation at the MTU and the fate of a packet-mode transfer.

A message of ``nbytes`` payload bytes is cut into ``k = max(1, ceil(nbytes / (mtu - h)))``
packets, each carrying a header of ``h`` bytes: ``k - 1`` full packets of ``mtu`` bytes and
a last one of ``nbytes - (k-1)(mtu-h) + h`` bytes; serialising a packet of ``s`` bytes takes
``8 s / bandwidth`` seconds. Every packet transmission is lost independently with
probability q.

* all_or_nothing: every packet is sent once (the sender has no feedback); the message
  survives iff none is lost, so P(message lost) = 1 - (1 - q)^k.
* retransmit (selective repeat, at most R retries per packet): a packet is resent after each
  loss, waiting ``retry_delay_s`` first, until it gets through or has failed R + 1 times, at
  which point the sender abandons the message. A packet fails for good with probability
  q^(R+1), so P(message lost) = 1 - (1 - q^(R+1))^k. Packet j is transmitted a + 1 times
  (a >= 1 retries) iff its first a transmissions are lost, so a transfer that no packet
  abandons makes k * sum_{a=1..R} q^a retries on average. Transfers are sampled exactly
  (one geometric draw per packet), not averaged.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class TransferPlan:
    """The outcome of putting one message on a link, relative to the start of transmission."""

    duration_s: float
    """Seconds the transmitter is busy: until the last bit, or until the sender gives up (retransmit)."""
    ok: bool
    """True if every packet got through (ignoring range and windows, which the channel checks)."""
    packets: int
    """Number of fragments of the message (count)."""
    retries: int
    """Packet retransmissions made (count)."""
    wire_bytes: int
    """Bytes put on the air, headers and retransmissions included."""
    boundaries_s: np.ndarray | None
    """Offsets (s) from the start of each packet transmission's end, in order (None if not asked)."""


def fragment(nbytes: int, mtu_bytes: int, header_bytes: int) -> tuple[int, int]:
    """``(k, last)``: number of packets and size in bytes of the last one (header included)."""
    per = mtu_bytes - header_bytes
    k = max(1, -(-nbytes // per))
    return k, nbytes - (k - 1) * per + header_bytes


class UniformStream:
    """Uniform draws in [0, 1) from a generator, handed out one at a time from blocks of
    ``block`` (the same values, in the same order, for the same sequence of calls: numpy draws
    a block's doubles one after the other, so the block size never changes a scalar draw; it
    only decides where :meth:`array`, which bypasses the block, continues)."""

    __slots__ = ("_rng", "_buf", "_i", "_block")

    def __init__(self, rng: np.random.Generator, block: int = 4096) -> None:
        self._rng = rng
        self._buf: list[float] = []
        self._i = 0
        self._block = block

    def __call__(self) -> float:
        i = self._i
        if i >= len(self._buf):
            self._buf = self._rng.random(self._block).tolist()
            i = 0
        self._i = i + 1
        return self._buf[i]

    def array(self, n: int) -> np.ndarray:
        """``n`` draws at once (straight from the generator)."""
        return self._rng.random(n)


_SMALL = 64
"""Transfers of at most this many packets are sampled with scalar draws (faster than numpy)."""


def plan_transfer(
    nbytes: int,
    mtu_bytes: int,
    header_bytes: int,
    bandwidth_bps: float,
    packet_loss: float,
    retransmit: bool,
    max_retries: int,
    retry_delay_s: float,
    uniform: UniformStream,
    want_boundaries: bool,
) -> TransferPlan:
    """Sample the fate of one packet-mode transfer (see the module docstring for the model).

    all_or_nothing uses one uniform U per message: no packet is lost iff U < (1-q)^k.
    retransmit uses one uniform U_j per packet: its attempts are the geometric
    G_j = 1 + floor(ln(1 - U_j) / ln q) (P(G_j > a) = q^a), capped at R + 1.
    """
    k, last = fragment(nbytes, mtu_bytes, header_bytes)
    s_full = 8.0 * mtu_bytes / bandwidth_bps
    s_last = 8.0 * last / bandwidth_bps
    q = packet_loss
    wire = (k - 1) * mtu_bytes + last
    if not retransmit or q == 0.0:
        ok = q == 0.0 or (q < 1.0 and uniform() < (1.0 - q) ** k)
        bounds = None
        if want_boundaries:
            bounds = np.arange(1, k + 1, dtype=np.float64) * s_full
            bounds[-1] = (k - 1) * s_full + s_last
        return TransferPlan(8.0 * wire / bandwidth_bps, ok, k, 0, wire, bounds)

    cap = max_retries + 1
    lnq = math.log(q) if q < 1.0 else 0.0
    if k <= _SMALL and not want_boundaries:
        # Scalar path: walk the packets until one is abandoned.
        duration = 0.0
        wire_sent = 0
        retries = 0
        ok = True
        for j in range(k):
            if q >= 1.0:
                g = cap + 1
            else:
                u = uniform()
                g = 1 + int(math.floor(math.log1p(-u) / lnq)) if u > 0.0 else 1
            size_b = mtu_bytes if j < k - 1 else last
            if g > cap:
                duration += cap * (8.0 * size_b / bandwidth_bps + retry_delay_s)
                wire_sent += cap * size_b
                retries += cap - 1
                ok = False
                break
            duration += g * 8.0 * size_b / bandwidth_bps + (g - 1) * retry_delay_s
            wire_sent += g * size_b
            retries += g - 1
        return TransferPlan(duration, ok, k, retries, wire_sent, None)

    # Vector path.
    if q >= 1.0:
        attempts = np.full(k, cap + 1, dtype=np.int64)
    else:
        u = uniform.array(k)
        attempts = 1 + np.floor(np.log1p(-u) / lnq).astype(np.int64)
    failed = np.flatnonzero(attempts > cap)
    ok = failed.size == 0
    sent = k if ok else int(failed[0]) + 1
    att = np.minimum(attempts[:sent], cap)
    size = np.full(sent, s_full)
    nb = np.full(sent, mtu_bytes, dtype=np.int64)
    if sent == k:
        size[-1] = s_last
        nb[-1] = last
    # Failed attempts of each packet: att - 1, or all cap of them for the abandoned packet.
    fails = att - 1
    if not ok:
        fails[-1] = cap
    duration = float((att * size + fails * retry_delay_s).sum())
    bounds = None
    if want_boundaries:
        # One boundary at the end of every attempt (after its retry wait, if it failed).
        waits = np.full(int(att.sum()), retry_delay_s)
        waits[np.cumsum(att) - 1] = 0.0
        if not ok:
            waits[-1] = retry_delay_s
        bounds = np.cumsum(np.repeat(size, att) + waits)
    retries = int(att.sum()) - sent
    return TransferPlan(duration, ok, k, retries, int((att * nb).sum()), bounds)


def message_loss_probability(k: int, q: float, retransmit: bool, max_retries: int) -> float:
    """P(message lost) over ``k`` packets with per-packet loss ``q`` (see the module docstring)."""
    if retransmit:
        return 1.0 - (1.0 - q ** (max_retries + 1)) ** k
    return 1.0 - (1.0 - q) ** k


def expected_retries(k: int, q: float, max_retries: int) -> float:
    """Mean retransmissions of ``k`` packets if none were abandoned early: k * sum_{a=1..R} q^a."""
    return k * sum(q**a for a in range(1, max_retries + 1))
