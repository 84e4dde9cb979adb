"""Inner loop allocates nothing; divergence gives NaN scalars, never an exception; the factory and config."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from pydantic import ValidationError
from torch.profiler import ProfilerActivity, profile

from ramensim.agents.consensus import ConsensusConfig, make_method
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.agents.toy import make_least_squares


def _alloc_bytes(fn) -> int:
    with profile(activities=[ProfilerActivity.CPU], profile_memory=True) as prof:
        fn()
    return sum(e.cpu_memory_usage for e in prof.events() if e.cpu_memory_usage > 0)


@pytest.mark.parametrize("name", ["ramen", "dinno"])
def test_inner_consensus_step_allocates_nothing(name):
    n = 4096
    prob = make_least_squares(2, n, 4, np.random.default_rng(0))
    lr = prob.learner(0)
    m = make_method(name, ConsensusConfig(primal_steps=1), n)
    copy = NeighbourCopy(1, {"theta": prob.theta0 + 1.0, "visits": torch.ones(n, dtype=torch.int64)}, 0.0, 0.0)
    m.round(lr, [copy], 1)
    grad = torch.randn(n)
    m._add_consensus_grad(grad, lr.theta)  # warm
    assert _alloc_bytes(lambda: m._add_consensus_grad(grad, lr.theta)) == 0
    assert _alloc_bytes(lambda: grad.mul(2.0)) > 0  # the probe does see allocations


@pytest.mark.parametrize("name", ["ramen", "dinno", "dsgd", "dsgt", "local"])
def test_divergence_gives_nan_not_exception(name):
    prob = make_least_squares(2, 8, 10, np.random.default_rng(0))
    lr = prob.learner(0, lr=1e30)  # absurd step: overflows
    cfg = ConsensusConfig(preset="paper", primal_steps=3, dsgd={"alpha": 1e30}, dsgt={"alpha": 1e30})
    m = make_method(name, cfg, prob.n)
    copy = NeighbourCopy(1, {"theta": prob.theta0, "visits": torch.ones(8, dtype=torch.int64),
                             "y": torch.zeros(8), "degree": torch.tensor([1], dtype=torch.int32)}, 0.0, 0.0)
    s = {}
    for _ in range(6):
        s = m.round(lr, [copy], 1)
    assert s.diverged and math.isnan(s.loss)


def test_factory_and_payloads():
    prob = make_least_squares(2, 8, 10, np.random.default_rng(0))
    cfg = ConsensusConfig()
    lr = prob.learner(0)
    assert isinstance(lr, Learner)
    keys = {"ramen": {"theta", "visits"}, "dinno": {"theta"}, "dsgd": {"theta", "degree"},
            "dsgt": {"theta", "y", "degree"}, "local": set(), "centralised": set()}
    for name, k in keys.items():
        m = make_method(name, cfg, prob.n, degree=2)
        p = m.payload(lr)
        assert set(p) == k and m.communicates == bool(k)
        if "theta" in p:
            assert p["theta"] is not lr.theta and torch.equal(p["theta"], lr.theta)
    with pytest.raises(ValueError, match="unknown"):
        make_method("admm", cfg, 8)


def test_config_defaults_and_validation():
    c = ConsensusConfig()
    assert c.primal_steps == 10 and c.stale_policy == "latest" and c.encoding == "float32"
    assert c.ramen.resolved_beta_u() == 1e-4 and c.ramen.resolved_beta_l() == pytest.approx(1e-7)
    assert c.ramen.count_observation_only
    with pytest.raises(ValidationError):
        ConsensusConfig(ramen={"rho": 1e-4, "beta_l": 1e-3})  # beta_l > beta_u
    with pytest.raises(ValidationError):
        ConsensusConfig(stale_policy="newest")
    with pytest.raises(ValidationError):
        ConsensusConfig(primal_steps=0)
    with pytest.raises(ValidationError):
        ConsensusConfig(extra_key=1)
    for model in (c, c.ramen, c.dinno, c.dsgd, c.dsgt):
        for name, f in type(model).model_fields.items():
            assert f.description, f"{type(model).__name__}.{name} has no docstring"


def test_copy_of_wrong_size_is_a_clear_error():
    prob = make_least_squares(2, 8, 10, np.random.default_rng(0))
    m = make_method("ramen", ConsensusConfig(), prob.n)
    bad = NeighbourCopy(3, {"theta": torch.zeros(5), "visits": torch.zeros(5, dtype=torch.int64)}, 0.0, 0.0)
    with pytest.raises(ValueError, match="agent 3"):
        m.round(prob.learner(0), [bad], 1)
    no_visits = NeighbourCopy(4, {"theta": torch.zeros(8)}, 0.0, 0.0)
    with pytest.raises(ValueError, match="visits"):
        m.round(prob.learner(0), [no_visits], 1)
