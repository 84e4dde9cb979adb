"""``ramensim archive --adopt`` (``ramensim.sweep.adopt``): a finished run of one sweep counts as a
point of another only when the two scenarios, with every default filled in, are equal (two sweep
files that reach the same scenario by different keys have different fingerprints); the adopted point
is then complete for the sweep, and bad sources are one paragraph and exit 2 with nothing written."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ramensim.sweep import store
from ramensim.sweep.spec import plan_sweep

REPO = Path(__file__).resolve().parents[2]
BASE = REPO / "scenarios" / "house_3agents.yaml"


class _Tool:
    """``main(argv)`` is ``ramensim archive --adopt ARGV`` as a script (``tools/adopt_runs.py``)."""

    @staticmethod
    def main(argv: list[str]) -> int:
        from ramensim.commands.archive import main

        return main(["--adopt", *argv])


@pytest.fixture
def adopt_tool():
    return _Tool


def _sweep(path: Path, name: str, fixed: dict, axes: dict) -> Path:
    path.write_text(yaml.safe_dump({"name": name, "base": str(BASE), "set": fixed, "axes": axes}, sort_keys=False))
    return path


def _finished(folder: Path, point, status: str = "ok") -> Path:
    """A finished run folder of ``point`` as a sweep leaves it (scenario, status, metrics)."""
    folder.mkdir(parents=True)
    (folder / "scenario.yaml").write_text(yaml.safe_dump(dict(point.data)))
    (folder / store.STATUS).write_text(json.dumps({"name": point.name, "status": status, "axes": point.axes,
                                                   "fingerprint": point.fingerprint}))
    (folder / store.METRICS).write_text(json.dumps({"per_agent": {}, "marker": point.name}))
    return folder


def test_same_scenario_by_other_keys_is_adopted_and_counts_as_done(tmp_path, adopt_tool):
    # the source leaves compute jitter at its default (0.0); the target sets it on an axis
    src_plan = plan_sweep(_sweep(tmp_path / "src.yaml", "src", {"duration": 30, "method": "ramen"},
                                 {"seed": [0, 1]}))
    target = _sweep(tmp_path / "dst.yaml", "dst", {"duration": 30},
                    {"seed": [0, 1], "agents.compute.jitter": [0.0, 0.5], "method": ["dinno", "ramen"]})
    plan = plan_sweep(target)
    runs = [_finished(tmp_path / "src" / p.name, p) for p in src_plan.points]
    out = tmp_path / "dst_out"
    assert adopt_tool.main([*map(str, runs), "--plan", str(target), "--into", str(out)]) == 0
    prints = {p.name: p.fingerprint for p in plan.points}
    for seed in (0, 1):
        name = f"seed={seed}__agents.compute.jitter=0.0__method=ramen"
        point = out / "runs" / name
        assert prints[name] != src_plan.points[seed].fingerprint  # the two files' fingerprints differ
        assert store.is_complete(point, prints[name])  # ... and the sweep counts the point as done
        status = store.read_status(point)
        assert status["adopted_from"]["fingerprint"] == src_plan.points[seed].fingerprint
        assert status["set"] == {"duration": 30} and status["axes"]["method"] == "ramen"
        assert json.loads((point / store.METRICS).read_text())["marker"] == f"seed={seed}"
    assert sorted(p.name for p in (out / "runs").iterdir()) == [
        "seed=0__agents.compute.jitter=0.0__method=ramen", "seed=1__agents.compute.jitter=0.0__method=ramen"]
    # a second call leaves the adopted points alone
    (out / "runs" / "seed=0__agents.compute.jitter=0.0__method=ramen" / store.METRICS).write_text('{"kept": 1}')
    assert adopt_tool.main([str(runs[0]), "--plan", str(target), "--into", str(out)]) == 0
    assert json.loads((out / "runs" / "seed=0__agents.compute.jitter=0.0__method=ramen" /
                       store.METRICS).read_text()) == {"kept": 1}


def test_other_scenario_or_unfinished_run_is_refused(tmp_path, adopt_tool, caplog):
    target = _sweep(tmp_path / "dst.yaml", "dst", {"duration": 30}, {"seed": [0], "method": ["dinno", "ramen"]})
    other = plan_sweep(_sweep(tmp_path / "o.yaml", "o", {"duration": 60, "method": "ramen"}, {"seed": [0]}))
    same = plan_sweep(_sweep(tmp_path / "s.yaml", "s", {"duration": 30, "method": "ramen"}, {"seed": [0]}))
    longer = _finished(tmp_path / "longer", other.points[0])
    out = tmp_path / "out"
    assert adopt_tool.main([str(longer), "--plan", str(target), "--into", str(out)]) == 2
    assert "equals no point of the plan" in caplog.text
    failed = _finished(tmp_path / "failed", same.points[0], status="failed")
    assert adopt_tool.main([str(failed), "--plan", str(target), "--into", str(out)]) == 2
    assert "no finished result" in caplog.text
    good = _finished(tmp_path / "good", same.points[0])
    # one bad source among good ones: nothing is written
    assert adopt_tool.main([str(good), str(longer), "--plan", str(target), "--into", str(out)]) == 2
    assert not out.exists()
