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


@pytest.mark.timeout(600)  # a hang guard only
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


@pytest.mark.timeout(600)  # a hang guard only
def test_a_ray_worker_killed_mid_point_fails_that_point_alone_and_a_resume_runs_it(tmp_path, monkeypatch):
    """A local Ray instance started by the test; the worker process running one point is killed
    (SIGKILL) while it runs: that point is recorded failed with the worker's death as reason, the
    others finish, and running the sweep again runs the killed point to completion."""
    import signal
    import threading
    import time

    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(REPO), str(HERE), os.environ.get("PYTHONPATH", "")]))
    pid_file, hold = tmp_path / "victim.pid", tmp_path / "hold"
    hold.write_text("")
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump({
        "base": "base.yaml", "axes": {"seed": [0, 1, 2]},
        "variants": {"v": {"pid_file": str(pid_file), "hold_while": str(hold)}}}, sort_keys=False))
    plan = plan_sweep(path, validate_fn=validate_dict)
    # only seed 0 holds and tells its pid: the others run through
    for p in plan.points:
        if p.axes["seed"] != 0:
            p.data.pop("pid_file"), p.data.pop("hold_while")
    out = tmp_path / "out"
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        box = {}
        sweep = threading.Thread(target=lambda: box.setdefault("res", run_sweep(
            plan, out, executor="ray", run_fn=fake_run, validate_fn=validate_dict, progress=False)))
        sweep.start()
        for _ in range(1200):  # bounded by steps: the point starts within a minute on a loaded machine
            if pid_file.is_file() and pid_file.read_text():
                break
            time.sleep(0.05)
        os.kill(int(pid_file.read_text()), signal.SIGKILL)
        sweep.join(300)
        assert not sweep.is_alive()
        res = box["res"]
        killed = [n for n in res.failed if "seed=0" in n]
        assert killed and "ray task failed" in res.failed[killed[0]]
        assert sorted(n for n in res.ok) == [n for n in sorted(p.name for p in plan.points) if "seed=0" not in n]
        hold.unlink()  # the point may now run through
        again = run_sweep(plan, out, executor="ray", run_fn=fake_run, validate_fn=validate_dict, progress=False)
        assert again.ok == killed and again.skipped == 2
        assert store.is_complete(out / "runs" / killed[0])
    finally:
        ray.shutdown()
