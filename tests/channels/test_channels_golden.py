"""The i.i.d. channel's message logs are pinned byte for byte, in both draw schemes.

``GOLDEN`` (``draws: send_order``): the SHA-256 prefixes were written by the channel before
the radio models of issue 18 (commit 3c26a33) and are still reproduced: adding burst loss,
path loss, trace replay and the keyed draws left the send-order logs unchanged, so runs made
before the keyed draws can be reproduced (docs/RADIO.md). ``KEYED`` (the default since
2026-11-24, eq. D-1) pins the keyed draws from their first commit. A change of any draw, time
or column of the i.i.d. channel fails here.
"""
from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest
import simpy
from channel_traffic import log_bytes, run_traffic

from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig


def _pos(agent: int, t: float) -> np.ndarray:
    return np.array([agent * 3.0 + 4.0 * math.sin(0.1 * t + agent), 0.0, 0.0])


CONFIGS = {
    "default": {},
    "iid0.5": dict(success_rate=0.5),
    "message": dict(success_rate=0.6, latency={"kind": "lognormal", "mean_s": 0.01, "std_s": 0.005}, range_m=9.0,
                    bandwidth_bps=1e5),
    "packet": dict(mode="packet", packet_loss=0.02, reassembly="retransmit", mtu_bytes=500,
                   latency={"kind": "normal", "mean_s": 0.01, "std_s": 0.01}, bandwidth_bps=1e5,
                   windows={"kind": "periodic", "period_s": 5.0, "open_s": 3.0}, queue_limit=3),
    "disk": dict(success_rate=0.3, latency={"kind": "exponential", "mean_s": 0.02}),
}

GOLDEN = {
    ("default", 0): (3200, "95d523defb17986f"), ("default", 7): (3200, "95d523defb17986f"),
    ("iid0.5", 0): (3200, "7cded93a305dde6d"), ("iid0.5", 7): (3200, "a3a3692aba135e7f"),
    ("message", 0): (3200, "45ffa15867d40ab7"), ("message", 7): (3200, "db6cc4d36793e745"),
    ("packet", 0): (3200, "244000d870c3ee1f"), ("packet", 7): (3200, "c4d55e58eb68f91f"),
    ("disk", 0): (3890, "84d41ff1e44fec8a"), ("disk", 7): (3890, "d0928f240b8c1382"),
}


def _digest(tmp_path, name: str, seed: int, draws: str) -> tuple[int, str]:
    env = simpy.Environment()
    tcfg = TopologyConfig(kind="disk", disk_radius_m=8.0) if name == "disk" else TopologyConfig(kind="ring")
    cfg = ChannelConfig(**CONFIGS[name], draws=draws)
    ch = Channel(env, cfg, Topology(tcfg, 4, _pos), 4, np.random.default_rng(seed), _pos)
    assert ch.models is None  # the radio models are off by default
    run_traffic(env, ch, 4, 400, traffic_seed=123, max_bytes=50000)
    return len(ch.log), hashlib.sha256(log_bytes(ch, tmp_path / "log.csv")).hexdigest()[:16]

KEYED = {
    ("default", 0): (3200, "95d523defb17986f"), ("default", 7): (3200, "95d523defb17986f"),
    ("iid0.5", 0): (3200, "a4c07aaebbb5dcf8"), ("iid0.5", 7): (3200, "2a5a6cc36768cbc4"),
    ("message", 0): (3200, "01dc6874e34f0b3b"), ("message", 7): (3200, "928af896bd7d4e63"),
    ("packet", 0): (3200, "8d3b4b970f83bc34"), ("packet", 7): (3200, "a4d7d6ba407acc1a"),
    ("disk", 0): (3890, "68d55983a894b1a2"), ("disk", 7): (3890, "e063884369b82107"),
}


@pytest.mark.parametrize("name,seed", list(GOLDEN))
def test_send_order_channel_message_log_is_pinned(tmp_path, name: str, seed: int) -> None:
    assert _digest(tmp_path, name, seed, "send_order") == GOLDEN[(name, seed)]


@pytest.mark.parametrize("name,seed", list(KEYED))
def test_keyed_channel_message_log_is_pinned(tmp_path, name: str, seed: int) -> None:
    assert ChannelConfig().draws == "keyed"  # the default
    assert _digest(tmp_path, name, seed, "keyed") == KEYED[(name, seed)]
