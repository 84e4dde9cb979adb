"""The Ray executor on a local Ray instance (skipped when the optional 'ray' extra is missing)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml

from ramensim.sweep import store
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict

ray = pytest.importorskip("ray", reason="the optional 'ray' extra is not installed (pip install 'ramensim[ray]')")

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


@pytest.mark.slow
def test_ray_executor_runs_records_failures_and_resumes(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(REPO), str(HERE), os.environ.get("PYTHONPATH", "")]))
    monkeypatch.setenv("OMP_WAIT_POLICY", "PASSIVE")  # as the CLI sets it: the workers get it too
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump({"base": "base.yaml", "axes": {"fail": [False, True], "seed": [0, 1]}},
                                   sort_keys=False))
    plan = plan_sweep(path, validate_fn=validate_dict)
    out = tmp_path / "out"
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        res = run_sweep(plan, out, executor="ray", run_fn=fake_run, validate_fn=validate_dict, progress=False)
        assert sorted(res.ok) == ["fail=false__seed=0", "fail=false__seed=1"]
        assert sorted(res.failed) == ["fail=true__seed=0", "fail=true__seed=1"]
        assert store.is_complete(out / "runs" / "fail=false__seed=1")
        where = json.loads((out / "runs" / "fail=false__seed=1" / "where.json").read_text())
        assert where["omp_wait_policy"] == "PASSIVE"
        again = run_sweep(plan, out, executor="ray", run_fn=fake_run, validate_fn=validate_dict,
                          progress=False, retry_failed=False)
        assert again.skipped == 4 and not again.ok
        assert ray.is_initialized()  # a Ray session the caller started is left running
    finally:
        ray.shutdown()
