"""Measured run costs (ramensim.costs) and the time ``ramensim sweep --dry-run`` estimates from
them (issue 29: '--dry-run with an estimated time from measured run costs')."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from ramensim import costs
from ramensim.cli import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def ledger(tmp_path, monkeypatch) -> Path:
    path = tmp_path / "costs.jsonl"
    monkeypatch.setenv(costs.LEDGER_ENV, str(path))
    monkeypatch.delenv(costs.PARALLEL_ENV, raising=False)
    return path


def _entry(scenario: str, method: str, sim_s: float, wall_s: float, parallel: int = 1) -> dict:
    return {"scenario": scenario, "method": method, "agents": 3, "sim_s": sim_s, "wall_s": wall_s,
            "parallel": parallel}


def test_a_finished_run_is_recorded_and_a_failed_one_is_not(ledger, monkeypatch):
    costs.record("office_3agents", "ramen", 3, 60.0, 90.0, "ok")
    monkeypatch.setenv(costs.PARALLEL_ENV, "2")
    costs.record("office_3agents", "dinno", 3, 60.0, 120.0, "diverged")
    costs.record("office_3agents", "dsgd", 3, 12.0, 30.0, "interrupted")  # a part of a run: no pace
    costs.record("office_3agents", "dsgd", 3, 60.0, 30.0, "failed")
    with open(ledger, "a") as fh:
        fh.write("not json\n{\"sim_s\": 0}\n")  # skipped when read
    got = costs.load()
    assert [(e["method"], e["parallel"]) for e in got] == [("ramen", 1), ("dinno", 2)]
    assert got[0]["wall_s"] == 90.0 and got[0]["sim_s"] == 60.0


def test_record_never_fails_a_run(tmp_path, monkeypatch):
    monkeypatch.setenv(costs.LEDGER_ENV, str(tmp_path / "a_file" / "costs.jsonl"))
    (tmp_path / "a_file").write_text("not a folder")
    costs.record("office_3agents", "ramen", 3, 60.0, 90.0, "ok")  # no exception


def test_pace_prefers_same_method_duration_and_parallelism():
    entries = [_entry("house", "ramen", 600, 2400), _entry("house", "ramen", 60, 300),
               _entry("house", "ramen", 600, 1200, parallel=2), _entry("house", "dinno", 600, 1800),
               _entry("office", "ramen", 60, 60)]
    assert costs.pace(entries, "house", "ramen", 1, 600) == (4.0, 1)  # same duration, 1 at once
    assert costs.pace(entries, "house", "ramen", 2, 600) == (2.0, 1)  # measured 2 at once
    assert costs.pace(entries, "house", "ramen", 1, 60) == (5.0, 1)  # a short run's own pace
    assert costs.pace(entries, "house", "dinno", 2, 600) == (3.0, 1)
    assert costs.pace(entries, "house", "dsgt", 1, 600) == (4.0, 3)  # the scenario's, 1 at once
    assert costs.pace(entries, "kitchen", "ramen", 1, 600) is None


def test_estimate_sums_points_over_the_workers():
    entries = [_entry("house", "ramen", 600, 1200, parallel=2), _entry("house", "dinno", 600, 600, parallel=2)]
    est = costs.estimate([("a", "house", "ramen", 600.0), ("b", "house", "dinno", 600.0),
                          ("c", "office", "ramen", 60.0)], workers=2, entries=entries)
    assert est.wall_s == (1200 + 600) / 2 and est.measured == 2 and est.unknown == ["c"]


def test_dry_run_prints_the_estimate(ledger, tmp_path, capsys):
    sweep = ROOT / "scenarios" / "sweeps" / "quick" / "comm_rate.yaml"
    assert main(["sweep", str(sweep), "--dry-run", "--out", str(tmp_path / "out")]) == 0
    assert "no estimate of the time" in capsys.readouterr().out
    name = "office_3agents"
    with open(ledger, "w") as fh:
        for method, wall in (("ramen", 120.0), ("dinno", 60.0)):
            fh.write(json.dumps(_entry(name, method, 60.0, wall, parallel=2)) + "\n")
    assert main(["sweep", str(sweep), "--dry-run", "--workers", "2", "--out", str(tmp_path / "out")]) == 0
    out = " ".join(capsys.readouterr().out.split())
    # 6 RAMEN points of 60 s at 2 s/s and 6 DiNNO points at 1 s/s, two at a time: 540 s
    assert "estimated wall time: 9:00 for 12 point(s) on 2 worker(s)" in out
