"""Radio models are declared once in a registry (channels/radios.py); LinkModels asks the ones
that are on, in registration order (eq. Q-1). A model registered the way a plugin does it
(docs/EXTENDING.md) is validated from its channel.<name> block, dumps back there, and
changes exactly the success probability it returns."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import BaseModel, ConfigDict, Field

from channel_traffic import log_bytes, run_traffic
from ramensim.channels import ChannelConfig
from ramensim.channels.radios import (_CHANNEL_KEYS, RadioModelSpec, active_models, get_radio, radio_names,
                                      register_radio, unregister_radio)
from ramensim.core.events import LinkQuality


class _Factor(BaseModel):
    model_config = ConfigDict(extra="forbid")
    factor: float = Field(1.0, ge=0.0, le=1.0)


class _Constant:
    def __init__(self, s: _Factor) -> None:
        self.s = s

    def quality(self, src: int, dst: int, t: float) -> tuple[float, int, float]:
        return self.s.factor, -1, math.nan


@pytest.fixture
def constant_model():
    spec = register_radio(RadioModelSpec(name="constant_factor", settings=_Factor, role="factor",
                                         build=lambda s, ctx: _Constant(s)))
    yield spec
    unregister_radio("constant_factor")


def test_builtins_registered_in_order_and_channel_keys_listed():
    assert radio_names()[:3] == ("burst", "path_loss", "trace")
    assert [get_radio(n).role for n in ("burst", "path_loss", "trace")] == ["base", "factor", "override"]
    assert _CHANNEL_KEYS == set(ChannelConfig.model_fields) - {"burst", "path_loss", "trace"}
    assert active_models(ChannelConfig()) == []
    assert [s.name for s in active_models(ChannelConfig(path_loss={"enabled": True}, burst={"kind": "gilbert_elliott",
                                                                                             "mean_bad_s": 1.0}))] \
        == ["burst", "path_loss"]


def test_a_taken_name_is_refused():
    with pytest.raises(ValueError, match="'burst' is already registered"):
        register_radio(RadioModelSpec(name="burst", build=lambda s, ctx: None))
    with pytest.raises(ValueError, match="key of the channel block"):
        register_radio(RadioModelSpec(name="success_rate", build=lambda s, ctx: None))


def test_plugin_block_validated_and_dumped_back(constant_model):
    cfg = ChannelConfig.model_validate({"constant_factor": {"factor": 0.25}})
    assert cfg.radios["constant_factor"].factor == 0.25
    dumped = cfg.model_dump(mode="json")
    assert dumped["constant_factor"] == {"factor": 0.25} and "radios" not in dumped
    assert ChannelConfig.model_validate(dumped) == cfg
    with pytest.raises(ValueError, match="channel.constant_factor.factor"):
        ChannelConfig.model_validate({"constant_factor": {"factor": 2.0}})
    with pytest.raises(ValueError, match="extra_forbidden|Extra inputs"):
        ChannelConfig.model_validate({"constant_fact": {"factor": 0.5}})


def test_a_factor_of_one_leaves_the_message_log_unchanged(make, tmp_path, constant_model):
    """The model is built and asked for every message (events prove it), yet with factor 1 the
    channel's draws and log are byte for byte those of the plain channel."""
    env, plain, _ = make(n=3, seed=5, success_rate=0.6)
    run_traffic(env, plain, 3, 200, traffic_seed=1)
    events = []
    env, with_model, _ = make(n=3, seed=5, success_rate=0.6, emit=events.append,
                              constant_factor={"factor": 1.0})
    run_traffic(env, with_model, 3, 200, traffic_seed=1)
    assert with_model.models is not None and "constant_factor" in with_model.models.models
    assert any(isinstance(e, LinkQuality) for e in events)
    assert log_bytes(plain, tmp_path / "a.csv") == log_bytes(with_model, tmp_path / "b.csv")


def test_a_factor_multiplies_the_success_rate(make, constant_model):
    """success = success_rate * factor (eq. Q-1): 0.8 x 0.5 = 0.4 of 20,000 messages (99 % band)."""
    env, ch, _ = make(n=2, seed=3, success_rate=0.8, constant_factor={"factor": 0.5})

    def proc():
        for _ in range(20_000):
            ch.send(0, 1, None, 100, env.now)
            yield env.timeout(0.5)

    env.process(proc())
    env.run()
    delivered = ch.log.summary()["total"]["delivered"]
    sd = math.sqrt(20_000 * 0.4 * 0.6)
    assert abs(delivered - 8_000) < 2.6 * sd
    env, ch0, _ = make(n=2, seed=3, success_rate=0.8, constant_factor={"factor": 0.0})
    ch0.send(0, 1, None, 100, 0.0)
    env.run()
    assert ch0.log.summary()["total"]["delivered"] == 0
    assert np.isclose(ch0.models.at(0, 1, 1.0)[0], 0.0) and ch0.models.at(0, 1, 1.0)[2]  # out of range


def test_a_factor_model_may_set_the_latency(make):
    """A fourth element of a factor model's answer is the message's propagation delay (s)."""
    spec = register_radio(RadioModelSpec(name="slow_link", settings=_Factor, role="factor",
                                         build=lambda s, ctx: type("Slow", (), {"quality": staticmethod(
                                             lambda src, dst, t: (1.0, -1, math.nan, 0.25))})()))
    try:
        env, ch, inbox = make(n=2, seed=1, success_rate=1.0, slow_link={})
        ch.send(0, 1, None, 100, 0.0)
        env.run()
        (t, _), = inbox[1]
        serialise = (100 + ChannelConfig().header_bytes) * 8.0 / ChannelConfig().bandwidth_bps
        assert t == pytest.approx(0.25 + serialise, abs=1e-12)
        env, ch, inbox = make(n=2, seed=1, success_rate=1.0)
        ch.send(0, 1, None, 100, 0.0)
        env.run()
        assert inbox[1][0][0] != pytest.approx(0.25 + serialise, abs=1e-12)
    finally:
        unregister_radio(spec.name)
