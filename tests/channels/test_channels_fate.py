"""``channels.fate.plan_fate``: the fate of one message as a pure function (issue 26).

Every drop reason is produced by ``plan_fate`` alone, from a hand-built radio and link state
(no SimPy, no channel); the draws are asked for only by messages that pass the send-time
checks, in the order loss, latency, packets; and the same inputs give the same plan without
changing anything (keyed draws). The channel applying the plans keeps its logs byte for byte
(tests/channels/test_channels_golden.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ramensim.channels import ChannelConfig
from ramensim.channels.config import WindowConfig
from ramensim.channels.draws import KeyedDraws, KeyedMessage
from ramensim.channels.fate import Radio, checkpoints, plan_fate
from ramensim.channels.latency import LatencySampler
from ramensim.channels.packets import UniformStream
from ramensim.channels.windows import Windows
from ramensim.core.events import Fate


class Draws:
    """Scripted draws that record what was asked, in order."""

    def __init__(self, lost: bool = False, latency: float = 0.01, packet_u: float = 0.5) -> None:
        self._lost, self._lat, self._u = lost, latency, packet_u
        self.asked: list[str] = []

    def lost(self, p: float) -> bool:
        self.asked.append("lost")
        return self._lost

    def latency(self, trace_latency: float | None) -> float:
        self.asked.append("latency")
        return self._lat if trace_latency is None else trace_latency

    def packet_uniforms(self) -> UniformStream:
        self.asked.append("packets")
        return UniformStream(np.random.default_rng(0))


def radio(windows: dict | None = None, in_range=None, **cfg) -> Radio:
    c = ChannelConfig(**cfg)
    w = Windows(WindowConfig(**windows), 2) if windows else None
    return Radio(c, w, in_range, None)


BW = 8_000.0  # bits/s: 1,000 bytes take 1 s on the air
HDR = ChannelConfig().header_bytes


def test_delivered_now_when_the_transmitter_is_free():
    d = Draws()
    plan = plan_fate(radio(bandwidth_bps=BW), 0, 1, 1000 - HDR, 5.0, True, -math.inf, 0, d)
    assert (plan.fate, plan.at_send, plan.queued) == (Fate.DELIVERED, False, False)
    assert plan.t_start == 5.0 and plan.free_at == pytest.approx(6.0) and plan.t_done == pytest.approx(6.01)
    assert plan.wire_bytes == 1000
    assert d.asked == ["latency"]  # success 1: no loss uniform is drawn


def test_queued_behind_the_transmitter():
    d = Draws()
    plan = plan_fate(radio(bandwidth_bps=BW, queue_limit=2), 0, 1, 1000 - HDR, 5.0, True, 7.0, 1, d)
    assert plan.queued and plan.t_start == 7.0 and plan.free_at == pytest.approx(8.0)
    assert plan.fate == Fate.DELIVERED and plan.t_done == pytest.approx(8.01)


@pytest.mark.parametrize("case, fate", [
    ("no edge", Fate.NO_LINK),
    ("window closed", Fate.WINDOW_CLOSED),
    ("out of range", Fate.OUT_OF_RANGE),
    ("queue full", Fate.QUEUE_OVERFLOW),
])
def test_dropped_at_send_asks_no_draw_and_leaves_the_transmitter(case, fate):
    kw: dict = dict(bandwidth_bps=BW, queue_limit=2)
    edge, free_at, waiting = True, -math.inf, 0
    if case == "no edge":
        edge = False
    elif case == "window closed":
        kw["windows"] = dict(kind="periodic", period_s=10.0, open_s=2.0)  # open [0, 2) of every 10 s
    elif case == "out of range":
        kw["in_range"] = lambda a, b, t: False
    else:
        free_at, waiting = 9.0, 2
    d = Draws()
    plan = plan_fate(radio(**kw), 0, 1, 100, 5.0, edge, free_at, waiting, d)
    assert plan.fate == fate and plan.at_send and plan.t_done == 5.0
    assert plan.free_at == free_at and not plan.queued and plan.wire_bytes == 0
    assert d.asked == []


def test_loss_after_the_transfer():
    d = Draws(lost=True)
    plan = plan_fate(radio(bandwidth_bps=BW, success_rate=0.5), 0, 1, 1000 - HDR, 0.0, True, -math.inf, 0, d)
    assert plan.fate == Fate.LOSS and not plan.at_send and plan.t_done == pytest.approx(1.01)
    assert d.asked == ["lost", "latency"]


def test_window_closed_when_the_queued_message_would_start():
    w = dict(kind="periodic", period_s=10.0, open_s=2.0)
    plan = plan_fate(radio(windows=w, bandwidth_bps=BW), 0, 1, 100, 1.0, True, 3.0, 0, Draws())
    assert plan.fate == Fate.WINDOW_CLOSED and plan.t_done == 3.0 and plan.queued
    assert plan.free_at == 3.0 and plan.wire_bytes == 0  # the transmitter is not used


def test_window_closes_during_the_transfer():
    w = dict(kind="periodic", period_s=10.0, open_s=2.0)
    plan = plan_fate(radio(windows=w, bandwidth_bps=BW), 0, 1, 4000 - HDR, 1.0, True, -math.inf, 0, Draws())
    assert plan.fate == Fate.WINDOW_CLOSED and plan.t_done == 2.0 and plan.free_at == 2.0
    assert plan.wire_bytes == 1000  # a quarter of the 4 s transfer was on the air


def test_out_of_range_at_a_checkpoint():
    plan = plan_fate(radio(in_range=lambda a, b, t: t < 1.5, bandwidth_bps=BW), 0, 1, 4000 - HDR, 1.0, True,
                     -math.inf, 0, Draws())
    assert plan.fate == Fate.OUT_OF_RANGE and plan.t_done == 5.0  # checked at the start and at the end
    plan = plan_fate(radio(in_range=lambda a, b, t: t < 1.5, bandwidth_bps=BW, mode="packet", mtu_bytes=500),
                     0, 1, 4000, 1.0, True, -math.inf, 0, Draws())
    assert plan.fate == Fate.OUT_OF_RANGE and 1.5 <= plan.t_done < 2.0  # the first packet boundary after 1.5 s


def test_packet_loss_asks_for_the_packets_after_loss_and_latency():
    d = Draws()
    plan = plan_fate(radio(bandwidth_bps=BW, mode="packet", packet_loss=1.0, success_rate=0.9), 0, 1, 2000,
                     0.0, True, -math.inf, 0, d)
    assert plan.fate == Fate.PACKET_LOSS and plan.packets > 1
    assert d.asked == ["lost", "latency", "packets"]


def test_checkpoints_thin_packet_boundaries_to_the_resolution():
    bounds = np.array([0.1, 0.2, 0.25, 0.9, 1.0])
    assert list(checkpoints(10.0, 11.0, bounds, 0.5)) == [10.0, 10.9, 11.0]
    assert list(checkpoints(10.0, 11.0, bounds, 0.0)) == [10.0, 10.1, 10.2, 10.25, 10.9, 11.0]
    assert list(checkpoints(10.0, 11.0, None, 0.5)) == [10.0, 11.0]


def test_same_inputs_same_plan_with_keyed_draws():
    """Pure: a keyed message's plan depends on its link and send time only; asking twice, or
    after other links' messages, gives the same plan."""
    cfg = dict(success_rate=0.5, latency={"kind": "lognormal", "mean_s": 0.01, "std_s": 0.005},
               mode="packet", packet_loss=0.2, reassembly="retransmit", mtu_bytes=300)
    r = radio(bandwidth_bps=BW, **cfg)
    sampler = LatencySampler(r.cfg.latency, np.random.default_rng(99))
    seq = np.random.SeedSequence(4)

    def plan_at(t: float, noise: int):
        keyed = KeyedDraws(seq)
        for k in range(noise):  # traffic on other links first
            keyed.message_key(1, 0, t)
        msg = KeyedMessage(keyed, keyed.message_key(0, 1, t), False, t, sampler)
        p = plan_fate(r, 0, 1, 3000, t, True, -math.inf, 0, msg)
        return (p.fate, p.t_done, p.t_start, p.free_at, p.wire_bytes, p.packets, p.retries)

    plans = [plan_at(t, 0) for t in np.arange(0.0, 20.0, 0.5)]
    assert plans == [plan_at(t, 3) for t in np.arange(0.0, 20.0, 0.5)]
    assert len({p[0] for p in plans}) > 1  # the draws vary: some lost, some not
