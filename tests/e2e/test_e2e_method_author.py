"""What a method author needs (issue 67, items 1-3): rounds that know the time and their copies'
ages, a non-finite diagnostic that is only a diagnostic, and a robot's exception that stays
with that robot (``run.on_robot_error``), with ``ramensim run``'s exit codes."""
from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from ramensim.cli import main
from ramensim.config import load_scenario
from ramensim.lifecycle import run_scenario

from tiny_runs import SCENARIO, TINY

PLUGIN = textwrap.dedent('''
    """Test methods: a staleness-aware gossip that records what its rounds were told, and one
    whose robot 1 raises in its third round."""
    import math

    import torch
    from pydantic import BaseModel, ConfigDict

    from ramensim.agents.consensus.base import check_theta, finish
    from ramensim.agents.consensus.registry import MethodSpec, register

    SEEN = []

    class Settings(BaseModel):
        model_config = ConfigDict(extra="forbid")
        fail_agent: int = -1

    class AgeGossip:
        communicates = True

        def __init__(self, name, n, agent, fail_agent):
            self.name, self.n, self.agent, self.fail_agent, self.k = name, n, agent, fail_agent, 0

        def round(self, learner, copies, n_neighbours, ctx):
            self.k += 1
            if self.agent == self.fail_agent and self.k == 3:
                raise ZeroDivisionError("the third round of robot 1")
            theta = check_theta(learner, self.n, self.name)
            scalars, grad = learner.loss_and_grad()
            learner.optimizer_step(grad)
            with torch.no_grad():
                for c in copies:  # weight by freshness: 1 / (1 + age)
                    w = 0.5 / (1.0 + ctx.ages[c.agent])
                    theta.mul_(1 - w).add_(c.theta, alpha=w)
            SEEN.append((self.agent, ctx.now, dict(ctx.ages), dict(ctx.received_at)))
            mean_age = sum(ctx.ages.values()) / len(ctx.ages) if ctx.ages else math.nan  # NaN with no copy
            return finish({"loss": float(scalars["loss"]), "copies_used": float(len(copies)),
                           "mean_age": mean_age, "grad_evals": 1.0}, theta)

        def payload(self, learner, ctx):
            return {"theta": learner.theta.detach().clone(), "now": torch.tensor([ctx.now])}

        def link_payloads(self):
            return {}

    register(MethodSpec(name="age_gossip", settings=Settings,
                        build=lambda s, cfg, ctx: AgeGossip("age_gossip", ctx.n, ctx.agent, s.fail_agent),
                        memory_vectors=(1, 1), description="gossip weighted by copy age (test)"))
''')


def _plugin(tmp_path: Path, name: str = "age_gossip") -> Path:
    """The plugin file, its method registered as ``name`` (one name per test: one process)."""
    p = tmp_path / f"{name}.py"
    p.write_text(PLUGIN.replace('"age_gossip"', f'"{name}"'))
    return p


@pytest.mark.timeout(600)
def test_rounds_know_the_time_and_the_ages_and_nan_diagnostics_do_not_kill(tmp_path):
    plugin = _plugin(tmp_path)
    sc = load_scenario(SCENARIO, [*TINY, "duration=4", "method=age_gossip", "evaluation.every_s=null",
                                  "channel.latency.kind=constant", "channel.latency.mean_s=0.3"],
                       plugins=[str(plugin)])
    result = run_scenario(sc, tmp_path / "run")
    assert result.status == "ok", result.error  # the first round's NaN mean_age is a diagnostic
    import sys

    seen = next(m for m in list(sys.modules.values()) if getattr(m, "__file__", None) == str(plugin)).SEEN
    assert seen and all(a.diverged is False and a.failed_reason is None for a in result.per_agent.values())
    later = [(agent, now, ages, got) for agent, now, ages, got in seen if ages]
    assert later, "no round used a copy"
    for agent, now, ages, got in later:
        for j, age in ages.items():
            assert age >= 0.3 - 1e-9  # a copy is at least the latency old
            assert got[j] <= now and now - age <= got[j]  # stamped before it arrived, before now
    # ages grow between two rounds that hold the same copy
    by_agent = {}
    for agent, now, ages, _ in later:
        by_agent.setdefault(agent, []).append((now, ages))
    assert any(b[1].get(j, -1) > a[1].get(j, 1e9) for rounds in by_agent.values()
               for a, b in zip(rounds, rounds[1:]) for j in a[1])


@pytest.mark.timeout(600)
def test_one_robots_exception_stays_with_it_and_the_exit_code_says_so(tmp_path, capsys):
    plugin = _plugin(tmp_path, "age_gossip_iso")
    args = ["run", str(SCENARIO), "--plugin", str(plugin), "--out", str(tmp_path / "iso"),
            *[x for kv in [*TINY, "duration=4", "method=age_gossip_iso", "consensus.age_gossip_iso.fail_agent=1",
                           "evaluation.every_s=null"] for x in ("--set", kv)]]
    assert main(args) == 3
    m = json.loads((tmp_path / "iso" / "metrics.json").read_text())
    bad, good = m["per_agent"]["agent_1"], m["per_agent"]["agent_0"]
    assert bad["failed_reason"].startswith("ZeroDivisionError: the third round of robot 1 (")
    assert "age_gossip_iso.py:" in bad["failed_reason"]  # the plugin's file:line
    assert bad["rounds"] == 2 and good["rounds"] > 2 and good["completion_ratio_pct"] is not None
    assert "failed" in capsys.readouterr().out
    # stop: the first exception ends the run (exit 1)
    stop = [*args[:-1], args[-1]]
    stop[stop.index(str(tmp_path / "iso"))] = str(tmp_path / "stop")
    assert main([*stop, "--set", "run.on_robot_error=stop"]) == 1
    m = json.loads((tmp_path / "stop" / "metrics.json").read_text())
    assert m["status"] == "failed" and "ZeroDivisionError" in m["error"]
