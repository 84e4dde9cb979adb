"""Radio models see the channel's state and name their own losses (issue 67, item 7)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import simpy
from pydantic import BaseModel, ConfigDict

from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig
from ramensim.channels.radios import RadioModelSpec, register_radio, unregister_radio


class _Settings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    busy_factor: float = 1e-12  # > 0: a factor of 0 would be out of range (dropped at send)


class _Congestion:
    """Loses every message sent while others wait at its sender ('congested'); records what it saw."""

    def __init__(self, s: _Settings) -> None:
        self.s, self.seen = s, []

    def quality(self, src, dst, t, state):
        self.seen.append((src, dst, t, state))
        factor = 1.0 if state.queue_sender == 0 else self.s.busy_factor
        return factor, -1, math.nan, None, "congested"


@pytest.fixture
def congestion():
    built = []

    def build(s, ctx):
        built.append(_Congestion(s))
        return built[-1]

    register_radio(RadioModelSpec(name="congestion", settings=_Settings, role="factor", build=build,
                                  reasons=("congested",), description="test: loss grows with the queue"))
    yield built
    unregister_radio("congestion")


def _run(medium: dict, built):
    env = simpy.Environment()
    cfg = ChannelConfig.model_validate({"bandwidth_bps": 8e6, "header_bytes": 0, "latency": {"mean_s": 0.0},
                                        "success_rate": 1.0, "congestion": {}, "medium": medium})
    ch = Channel(env, cfg, Topology(TopologyConfig(kind="complete"), 3), 3, np.random.default_rng(0),
                 position=lambda a, t: np.zeros(3))

    def robot(i):
        for _ in range(5):
            for j in (x for x in range(3) if x != i):
                ch.send(i, j, None, 500_000, env.now)  # 0.5 s each at 8 Mbit/s: queues build
            yield env.timeout(0.25)

    for i in range(3):
        env.process(robot(i))
    env.run(until=60)
    return ch, built[-1].seen


@pytest.mark.parametrize("medium", [{"kind": "links", }, {"kind": "shared", "access": "fair"}])
def test_a_model_sees_queues_and_load_and_names_its_losses(congestion, medium, tmp_path):
    ch, seen = _run(medium, congestion)
    ch.log.write_csv(tmp_path / "m.csv")
    assert ",dropped,congested," in (tmp_path / "m.csv").read_text()
    assert len(seen) == 30
    first = [st for src, dst, t, st in seen if t == 0.0 and src == 0]
    assert first[0].queue_sender == 0 and first[0].offered_bps == 0.0
    assert max(st.queue_sender for *_, st in seen) >= 1 and max(st.bytes_sender for *_, st in seen) >= 500_000
    assert all(st.bytes_sender == 500_000 * st.queue_sender and st.queue_link <= st.queue_sender for *_, st in seen)
    assert max(st.offered_bps for *_, st in seen) >= 8 * 1_000_000  # two 0.5-MB messages within a second
    if medium["kind"] == "shared":
        assert any(st.medium_busy for *_, st in seen) and all(st.medium_waiting is not None for *_, st in seen)
    else:
        assert all(st.medium_busy is None for *_, st in seen)
    r = ch.log.summary()["total"]
    lost_by_queue = sum(1 for *_, st in seen if st.queue_sender > 0)
    assert r["dropped_by_reason"]["congested"] == lost_by_queue > 0
    assert r["dropped_by_reason"]["loss"] == 0
    rows = ch.log.records()
    assert (rows["status"] == 0).sum() == 30 - lost_by_queue


def test_named_reasons_take_only_the_loss_their_factor_causes():
    """One uniform per message: lost by the model iff it would have arrived without its factor."""
    from ramensim.channels.fate import LOSS, lost_fate

    class U:
        def __init__(self, u):
            self.u = u

        def uniform(self):
            return self.u

        def lost(self, p):
            return self.u >= p

    named = ((200, 0.5),)  # p = 0.8 (base) * 0.5 (the model) = 0.4
    assert lost_fate(0.4, named, U(0.3)) == 0  # arrives
    assert lost_fate(0.4, named, U(0.6)) == 200  # would have arrived at 0.8: the model's
    assert lost_fate(0.4, named, U(0.9)) == LOSS  # lost even without the model
    assert lost_fate(1.0, named, U(0.99)) == 0
