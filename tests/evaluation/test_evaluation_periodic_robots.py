"""``evaluation.periodic.robots``: a large team's periodic evaluations score a window of n maps
that moves on by n at every evaluation (each robot in turn), the final scores every map; by the
evaluator's rule and in a real run's timeline."""
from __future__ import annotations

import pytest

from ramensim.evaluation.config import EvalConfig
from ramensim.scoring import Evaluator


def _sampler(robots):
    ev = Evaluator.__new__(Evaluator)  # the sampling rule alone: no world needed
    ev.cfg = EvalConfig(periodic={"robots": robots})
    ev.periodic_taken = 0
    return ev


def test_the_window_moves_on_and_wraps_around():
    ev = _sampler(2)
    assert [ev.periodic_sample(range(5)) for _ in range(5)] == [[0, 1], [2, 3], [0, 4], [1, 2], [3, 4]]
    # over len(live) evaluations every robot is scored n times
    ev = _sampler(3)
    picks = [k for _ in range(8) for k in ev.periodic_sample(range(8))]
    assert sorted(picks) == sorted(list(range(8)) * 3)


def test_dead_maps_are_skipped_and_none_or_more_than_the_team_scores_all():
    ev = _sampler(2)
    assert ev.periodic_sample([0, 2, 5]) == [0, 2]
    assert ev.periodic_sample([0, 2, 5]) == [0, 5]
    assert _sampler(None).periodic_sample([0, 1, 2]) == [0, 1, 2]
    assert _sampler(4).periodic_sample([0, 1, 2]) == [0, 1, 2]


def test_the_setting_is_checked():
    with pytest.raises(Exception, match="robots"):
        EvalConfig(periodic={"robots": 0})


@pytest.mark.parametrize("lane", ["0", "1"])
def test_a_run_scores_the_window_periodically_and_every_map_at_the_end(tmp_path, monkeypatch, lane):
    import json

    from tests.e2e.tiny_runs import SCENARIO, TINY

    from ramensim import api

    monkeypatch.setenv("RAMENSIM_EVAL_LANE", lane)
    overrides = [*TINY, "agents.count=3", "duration=4", "evaluation.every_s=1", "evaluation.periodic.robots=1",
                 "evaluation.consensus_every_s=null"]
    out = api.run(SCENARIO, overrides, out=tmp_path / "run")
    result = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert out.status == "ok"
    scored = {}
    for e in result["timeline"]:
        if "completion_ratio_pct" in e:
            scored.setdefault(e["t"], []).append(e["agent"])
    # evaluations at t = 1, 2, 3: robots 0, 1, 2 in turn; the final scores all three
    assert [scored[t] for t in sorted(scored)] == [[0], [1], [2]]
    assert sorted(result["per_agent"]) == ["agent_0", "agent_1", "agent_2"]
