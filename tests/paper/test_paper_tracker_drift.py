"""``ramensim paper tracker-drift`` (``ramensim.paper.tracker_drift``; docs/results/dsgt.md, DSGT's
cause analysis) on a tiny run: the probe only reads (the run's results are those of the same run
without it), it records every robot's every round, and the gradient-tracking invariant
``sum y = sum g`` holds exactly until the first neighbour copy is mixed in."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
TINY = ["agents.count=2", "world.camera.width=16", "world.camera.height=12", "world.camera.fx=12",
        "world.camera.fy=12", "world.camera.cx=7.5", "world.camera.cy=5.5", "evaluation.voxel_m=0.2",
        "evaluation.n_samples=1000", "evaluation.cull=frustum", "evaluation.every_s=null", "map.n_rays=64",
        "recording.mode=off", "duration=1.2", "channel.success_rate=0.5", "channel.bandwidth_bps=1.0e12",
        "agents.compute.jitter=0.0"]


class _Tool:
    """The study's command: ``main(argv)`` is ``ramensim paper tracker-drift ARGV`` as a script."""

    @staticmethod
    def main(argv: list[str]) -> int:
        from ramensim.commands.paper import main

        return main(["tracker-drift", *argv])


@pytest.fixture
def drift_tool():
    return _Tool


def test_probe_is_passive_and_records_every_round(tmp_path, drift_tool):
    import ramensim

    scenario = REPO / "scenarios" / "house_3agents.yaml"
    sets = []
    for s in TINY:
        sets += ["--set", s]
    assert drift_tool.main([str(scenario), *sets, "--every-s", "0.5", "--out", str(tmp_path / "probe")]) == 0
    plain = ramensim.run(scenario, overrides=["method=dsgt", *TINY], out=tmp_path / "plain")
    probed = ramensim.RunOutput.load(tmp_path / "probe" / "run")
    assert probed.per_agent == plain.per_agent
    assert probed.communication == plain.communication
    assert probed.consensus_error == plain.consensus_error

    records = json.loads((tmp_path / "probe" / "tracker_drift.json").read_text())["records"]
    for k, agent in enumerate(plain.per_agent.values()):
        # every round begun is recorded; the last one may end after the run's horizon
        assert sum(r["agent"] == k for r in records) in (agent.rounds, agent.rounds + 1)
    first_copy = next(i for i, r in enumerate(records) if r["copies"] > 0)
    before = [r for r in records[:first_copy] if r["robots"] == 2]
    assert before and all(r["drift"] < 1e-6 for r in before)
    assert max(r["drift"] for r in records[first_copy:]) > 1e-3
    text = (tmp_path / "probe" / "tracker_drift.md").read_text()
    assert "| t (s) | round | drift | ||sum y - sum g|| |" in text


def test_bad_scenario_is_one_clear_error(tmp_path, drift_tool, caplog):
    scenario = REPO / "scenarios" / "house_3agents.yaml"
    assert drift_tool.main([str(scenario), "--set", "channel.success_rate=2", "--out", str(tmp_path)]) == 2
    assert "channel.success_rate" in caplog.text and "less than or equal to 1" in caplog.text
    assert not (tmp_path / "tracker_drift.json").exists()


def _sets(*extra: str) -> list[str]:
    out = []
    for s in [*TINY, *extra]:
        out += ["--set", s]
    return out


def test_matched_lag_tracker_keeps_the_invariant_the_method_as_built_loses(tmp_path, drift_tool):
    """In step with nothing lost the copies are one round old: the method as built mixes them
    with its newest own tracker and the two sums part; the counterfactual mixes its own tracker
    of the copies' round and keeps them equal to float precision."""
    scenario = str(REPO / "scenarios" / "house_3agents.yaml")
    lossless = _sets("channel.success_rate=1.0")
    assert drift_tool.main([scenario, *lossless, "--out", str(tmp_path / "built")]) == 0
    assert drift_tool.main([scenario, *lossless, "--matched-lag", "--out", str(tmp_path / "matched")]) == 0
    built, matched = (json.loads((tmp_path / d / "tracker_drift.json").read_text())["records"]
                      for d in ("built", "matched"))
    def team(records):  # the instants every robot has made the same number of rounds
        return [r for r in records if r["team_round_done"] and r["robots"] == 2]

    assert any(r["copies"] > 0 for r in team(matched))
    assert max(r["drift"] for r in team(matched)) < 1e-5
    assert max(r["drift"] for r in team(built) if r["copies"] > 0) > 1e-3
    assert "matched-lag tracker" in (tmp_path / "matched" / "tracker_drift.md").read_text()


def test_matched_lag_refuses_a_lossy_run_with_one_clear_error(tmp_path, drift_tool, caplog):
    scenario = str(REPO / "scenarios" / "house_3agents.yaml")
    assert drift_tool.main([scenario, *_sets("duration=0.8"), "--matched-lag", "--out", str(tmp_path)]) == 1
    assert "needs the robots in step and nothing lost" in caplog.text
    assert (tmp_path / "tracker_drift.json").is_file()  # what was recorded before is kept
