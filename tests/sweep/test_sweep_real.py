"""A tiny sweep through the real scenario schema and the real ``run_scenario`` (random decoders
while the shipped ones are missing); then the report is drawn from its folder."""
from __future__ import annotations

import json

import pytest
import yaml

from ramensim.sweep import store
from ramensim.sweep.report import make_report
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import real_run

pytest.importorskip("ramensim.lifecycle", reason="ramensim.lifecycle.run_scenario is not in the tree yet")

TINY = {
    "duration": 3.0,
    "agents": {"count": 2},
    "recording": {"mode": "off"},
    "evaluation": {"voxel_m": 0.08, "n_samples": 5000, "export_mesh": False},
    "map": {"log2_hashmap_size": 12, "n_rays": 256}, "consensus": {"primal_steps": 3},
    "output": {"save_meshes": False},
}


@pytest.mark.slow
def test_tiny_real_sweep_runs_and_reports(tmp_path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(TINY))
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(
        {"name": "tiny", "base": "base.yaml", "axes": {"method": ["ramen", "dinno"], "seed": [0]}}, sort_keys=False))
    plan = plan_sweep(tmp_path / "s.yaml")
    out = tmp_path / "out"
    res = run_sweep(plan, out, workers=2, run_fn=real_run, progress=False)
    assert not res.failed, res.failed
    for p in plan.points:
        folder = out / "runs" / p.name
        assert store.is_complete(folder, p.fingerprint)
        assert (folder / "scenario.yaml").is_file()
        metrics = json.loads((folder / "metrics.json").read_text())
        assert isinstance(metrics, dict) and metrics
    rep = make_report(out)
    assert {"artifacts_cm", "holes_cm", "completion_ratio_pct"} <= set(rep.metrics), rep.metrics
    assert [r["method"] for r in rep.rows] == ["ramen", "dinno"]
    assert all(r["completion_ratio_pct_n"] == 2 for r in rep.rows)  # 2 agents x 1 seed
    assert (out / "plots" / "bars_method.png").is_file()
