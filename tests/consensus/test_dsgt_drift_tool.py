"""``tools/dsgt_tracker_drift.py`` (docs/RESULTS.md, DSGT's cause analysis) on a tiny run: the
probe only reads (the run's results are those of the same run without it), it records every
robot's every round, and the gradient-tracking invariant ``sum y = sum g`` holds exactly until
the first neighbour copy is mixed in."""
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


@pytest.fixture
def drift_tool(monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "tools"))
    import dsgt_tracker_drift
    return dsgt_tracker_drift


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
