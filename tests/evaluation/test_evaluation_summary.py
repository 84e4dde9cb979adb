"""Aggregation over agents/trials, consensus error, airtime, and the config model."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from ramensim.evaluation.config import EvalConfig
from ramensim.evaluation.summary import airtime_summary, consensus_error, summarize_agents, summarize_runs


def test_summarize_agents_mean_std_and_nan():
    per_agent = {
        0: {"completion_ratio_pct": 80.0, "artifacts_cm": 2.0, "reason": None},
        1: {"completion_ratio_pct": 60.0, "artifacts_cm": 4.0, "reason": None},
        2: {"completion_ratio_pct": math.nan, "artifacts_cm": math.nan, "reason": "empty"},
    }
    s = summarize_agents(per_agent)
    assert s["completion_ratio_pct"]["mean"] == 70.0
    assert s["completion_ratio_pct"]["std"] == 10.0  # population std of {80, 60}
    assert s["completion_ratio_pct"]["n"] == 2 and s["completion_ratio_pct"]["n_nan"] == 1
    assert "reason" not in s
    assert summarize_agents(per_agent, ddof=1)["artifacts_cm"]["std"] == pytest.approx(math.sqrt(2.0))


def test_summarize_runs_pools_agents_and_trials():
    runs = [{0: {"holes_cm": 1.0}, 1: {"holes_cm": 3.0}}, {0: {"holes_cm": 5.0}, 1: {"holes_cm": 7.0}}]
    s = summarize_runs(runs)["holes_cm"]
    assert s["mean"] == 4.0 and s["n"] == 4 and s["n_trials"] == 2
    assert s["std"] == pytest.approx(np.std([1.0, 3.0, 5.0, 7.0]))
    assert s["min"] == 1.0 and s["max"] == 7.0


def test_consensus_error_known_answers():
    assert consensus_error([np.ones(5), np.ones(5)]) == 0.0
    # two agents differing by 2 in every coordinate: RMS pairwise difference = 2
    assert consensus_error([np.zeros(4), np.full(4, 2.0)]) == pytest.approx(2.0)
    # three scalars 0, 1, 3: pair diffs 1, 3, 2 -> sqrt((1 + 9 + 4) / 3)
    assert consensus_error([np.array([0.0]), np.array([1.0]), np.array([3.0])]) == pytest.approx(math.sqrt(14 / 3))
    assert consensus_error([np.ones(3)]) == 0.0


def test_consensus_error_matches_brute_force_and_accepts_tensors():
    rng = np.random.default_rng(0)
    thetas = [rng.normal(size=(7, 3)) for _ in range(5)]
    brute = [np.mean((a - b) ** 2) for i, a in enumerate(thetas) for b in thetas[i + 1:]]
    assert consensus_error(thetas) == pytest.approx(math.sqrt(np.mean(brute)))
    torch = pytest.importorskip("torch")
    assert consensus_error([torch.from_numpy(t).requires_grad_() for t in thetas]) == pytest.approx(
        consensus_error(thetas))
    with pytest.raises(ValueError, match="same number"):
        consensus_error([np.zeros(3), np.zeros(4)])


def test_airtime_summary():
    s = airtime_summary([100, 100, 100, 100], [100, 100], {"loss": [100], "window_closed": [100]}, 10.0)
    assert s["bytes_sent"] == 400 and s["bytes_delivered"] == 200 and s["bytes_dropped"] == 200
    assert s["delivery_ratio"] == 0.5 and s["sent_rate_Bps"] == 40.0
    assert s["dropped_by_reason"] == {"loss": 1, "window_closed": 1}
    assert math.isnan(airtime_summary([], [], [], 1.0)["delivery_ratio"])
    with pytest.raises(ValueError, match="duration_s"):
        airtime_summary([], [], [], 0.0)


def test_eval_config_defaults_and_validation():
    c = EvalConfig()
    assert c.voxel_m == 0.02 and c.n_samples == 200_000 and c.threshold_m == 0.05
    assert c.cull == "none" and c.every_s == 30.0
    for field in EvalConfig.model_fields.values():
        assert field.description, "every field needs a one-line docstring"
    with pytest.raises(ValidationError):
        EvalConfig(voxel_m=0.0)
    with pytest.raises(ValidationError):
        EvalConfig(cull="everything")
    with pytest.raises(ValidationError):
        EvalConfig(unknown_key=1)


def test_finite_values_keep_only_finite_numbers_in_order():
    from ramensim.evaluation.summary import finite_mean, finite_values

    got = finite_values([74.5, float("nan"), None, "73", True, np.float32(72.0), float("inf"), -1])
    assert got == [74.5, 72.0, -1.0]
    assert finite_mean([1.0, float("nan"), 2.0]) == 1.5
    assert math.isnan(finite_mean([float("nan"), None]))
    assert math.isnan(finite_mean(None))
