"""Methods are declared once, in the registry: a method added by one file plus its
registry line is validated, built and run end to end with no other edit."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from ramensim.agents.consensus import ConsensusConfig, get_method, make_method, method_names
from ramensim.agents.consensus.registry import MethodSpec, register
from ramensim.config import validate
from ramensim.core.errors import InputError

REPO = Path(__file__).resolve().parents[2]


def test_builtin_methods_and_capabilities():
    assert method_names()[:6] == ("ramen", "dinno", "dsgd", "dsgt", "local", "centralised")
    assert get_method("ramen").sends_uncertainty and get_method("ramen").communicates
    assert not get_method("local").communicates and get_method("local").reference
    assert get_method("centralised").merges_frames
    assert not any(get_method(m).merges_frames for m in ("ramen", "dinno", "dsgd", "dsgt", "local"))


def test_unknown_method_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown; expected one of ramen, dinno"):
        make_method("nope", ConsensusConfig(), 4)
    with pytest.raises(InputError, match="method"):
        validate({"method": "nope"}, "x.yaml")


def test_registering_another_method_under_a_taken_name_is_refused():
    with pytest.raises(ValueError, match="already registered"):
        register(MethodSpec(name="ramen", build=lambda s, cfg, ctx: None))


def test_schema_lists_registered_methods():
    from ramensim.schema import Scenario

    enum = Scenario.model_json_schema()["properties"]["method"]["enum"]
    assert enum[:6] == ["ramen", "dinno", "dsgd", "dsgt", "local", "centralised"]


def test_a_method_added_in_one_file_runs_end_to_end(tmp_path):
    from tests.consensus import gossip_method  # noqa: F401 - registers 'gossip'
    from ramensim.sim import build_simulation
    from ramensim.lifecycle import run_scenario

    assert "gossip" in method_names()
    data = {"name": "gossip_tiny", "duration": 4, "method": "gossip", "agents": {"count": 2},
            "consensus": {"primal_steps": 3, "gossip": {"mix": 0.25}},
            "channel": {"success_rate": 1.0},
            "world": {"camera": {"width": 40, "height": 30, "fx": 30, "fy": 30, "cx": 19.5, "cy": 14.5}},
            "map": {"n_rays": 128}, "evaluation": {"voxel_m": 0.1, "n_samples": 5000, "cull": "frustum"},
            "recording": {"mode": "off"}}
    sc = validate(data, "gossip.yaml")
    assert sc.consensus.gossip.mix == 0.25
    assert build_simulation(sc).steps[0].method.mix == 0.25
    result = run_scenario(sc, tmp_path / "run")
    assert result.status == "ok" and result.method == "gossip"
    m = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert m["communication"]["delivered"] > 0
    for entry in m["per_agent"].values():
        assert entry["rounds"] > 0 and entry["completion_ratio_pct"] is not None
    with pytest.raises(InputError, match="mix"):
        validate({**data, "consensus": {"gossip": {"mix": 2.0}}}, "gossip.yaml")


def test_authors_preset_and_overrides():
    c = ConsensusConfig(preset="authors")
    assert (c.stale_policy, c.local_gradient_scale, c.first_round_steps) == ("omit_lost", 2.0, 200)
    assert c.ramen.count_observation_only is False and c.primal_update == "joint" and c.dual_update == "node"
    c = ConsensusConfig(preset="authors", stale_policy="latest", ramen={"rho": 1e-3})
    assert c.stale_policy == "latest" and c.ramen.rho == 1e-3 and c.ramen.count_observation_only is False
    assert ConsensusConfig().stale_policy == "latest" and ConsensusConfig().first_round_steps == 0


def test_first_round_steps_and_local_gradient_scale():
    import numpy as np
    import torch

    from ramensim.agents.copies import CopyStore
    from ramensim.agents.step import ConsensusStep
    from ramensim.agents.toy import make_least_squares

    prob = make_least_squares(1, 6, 10, np.random.default_rng(0))
    cfg = ConsensusConfig(primal_steps=3, first_round_steps=5)
    step = ConsensusStep(0, prob.learner(0), make_method("local", cfg, prob.n), CopyStore(0), "float32",
                         prob.theta0, lambda: 0, first_round_steps=cfg.first_round_steps)
    assert step.run_round(0.0).result.grad_evals == 8 and step.run_round(1.0).result.grad_evals == 3
    # a scale of 2 on grad L_obj with plain steps = twice the learning rate when no copy is used
    a, b = prob.learner(0, lr=0.05), prob.learner(0, lr=0.1)
    make_method("dinno", ConsensusConfig(primal_steps=4, local_gradient_scale=2.0), prob.n).round(a, [], 0)
    make_method("dinno", ConsensusConfig(primal_steps=4), prob.n).round(b, [], 0)
    assert torch.allclose(a.theta, b.theta, atol=1e-6)


def test_a_method_missing_a_hook_is_refused_naming_it():
    """Every hook of the ConsensusMethod protocol is declared there and checked when a method
    is built (no getattr fallbacks at the call sites)."""
    from ramensim.agents.consensus import ConsensusConfig
    from ramensim.agents.consensus.base import HOOKS
    from ramensim.agents.consensus.registry import MethodSpec, register, unregister

    class NoLinks:
        name, communicates = "nolinks", True

        def round(self, learner, copies, n_neighbours):
            raise AssertionError("not called")

        def payload(self, learner):
            return {}

    assert "link_payloads" in HOOKS
    register(MethodSpec(name="nolinks", build=lambda s, cfg, ctx: NoLinks()))
    try:
        with pytest.raises(ValueError, match="'nolinks'.*without link_payloads"):
            get_method("nolinks").make(ConsensusConfig(), 10)
    finally:
        unregister("nolinks")


def test_methods_declare_their_steps_per_round():
    assert [get_method(m).steps_per_round for m in ("ramen", "dinno", "local", "centralised")] == ["primal_steps"] * 4
    assert get_method("dsgd").steps_per_round == get_method("dsgt").steps_per_round == "one"
