"""Shared builders for the channel tests (fixture ``make``)."""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import simpy

from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig


def _make(n: int = 2, topology: str = "complete", seed: int = 0, position=None, emit=None, topo_kw=None,
          first_hit=None, **cfg: Any):
    """(env, channel, inbox) with every agent attached; inbox[i] lists (t, msg) received by i."""
    env = simpy.Environment()
    topo = Topology(TopologyConfig(kind=topology, **(topo_kw or {})), n, position)
    kw = {} if emit is None else {"emit": emit}
    if first_hit is not None:
        kw["first_hit"] = first_hit
    ch = Channel(env, ChannelConfig(**cfg), topo, n, np.random.default_rng(seed), position, **kw)
    inbox: list[list] = [[] for _ in range(n)]
    for i in range(n):
        ch.attach(i, lambda msg, i=i: inbox[i].append((env.now, msg)))
    return env, ch, inbox


@pytest.fixture
def make():
    """The channel builder ``make(n, topology, seed, position, emit, topo_kw, first_hit, **ChannelConfig)``."""
    return _make
