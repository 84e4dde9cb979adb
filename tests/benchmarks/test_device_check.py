"""The GPU machine's one prepared script (benchmarks/device_check.py, issue 70) rehearsed on the
CPU with every stage shrunk, so that a typo or a renamed function fails here and not in the few
minutes of device time a task is lent. Timings are read, never checked."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
STAGES = ("machine", "tests", "run_batch", "run_inline", "run_cpu", "batch", "scale", "profile")


def _device_check():
    import importlib.util

    spec = importlib.util.spec_from_file_location("device_check", ROOT / "benchmarks" / "device_check.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_rehearsal_on_the_cpu_runs_every_stage(tmp_path):
    out, work = tmp_path / "out", tmp_path / "work"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "benchmarks/device_check.py", str(out), "--device", "cpu", "--tiny",
                           "--work", str(work), "--budget-s", "1200", "--commit", "rehearsal"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=1500)
    assert proc.returncode == 0, proc.stderr[-3000:]
    # what comes back from the GPU machine: at most 8 plain files in OUT
    assert sorted(p.name for p in out.iterdir()) == ["device_check.json", "device_check.md", "stages.log", "tests.log"]
    r = json.loads((out / "device_check.json").read_text())
    for stage in STAGES:
        assert "error" not in r[stage], (stage, r[stage], (out / "stages.log").read_text()[-3000:])
    assert r["commit"] == "rehearsal" and r["machine"]["cores"] >= 1
    assert "skipped" in r["tests"]["summary"] or "passed" in r["tests"]["summary"]
    assert r["run_batch"]["team_lockstep"] is True and r["run_inline"]["team_lockstep"] is False
    for stage in ("run_batch", "run_inline", "run_cpu"):
        run = r[stage]
        assert run["status"] == "ok" and run["sim_s"] == 1.0 and run["rtf"] > 0
        assert len(run["completion_pct"]) == 2 and all(v > 0 for v in run["completion_pct"].values())
        assert run["eval_stage_s"] and run["eval_stage_s"][-1]["final"]
    assert {(x["preset"], x["robots"]) for x in r["batch"]["rows"]} == {("cpu", 2), ("paper", 2)}
    assert all(x["max_rel_grad_diff"] < 1e-4 and x["batched_samples_per_s"] > 0 for x in r["batch"]["rows"])
    assert [x["robots"] for x in r["scale"]["rows"]] == [2, 3]
    md = (out / "device_check.md").read_text()
    for heading in ("## The 3-robot house run", "## One round of the team's maps", "## Robots on a ring",
                    "## Goals"):
        assert heading in md


def test_goals_read_the_figures_they_name():
    dc = _device_check()
    r = {"run_batch": {"rtf": 4.0, "gpu_busy_share": 0.5}, "run_inline": {"rtf": 6.0},
         "scale": {"rows": [{"robots": 3, "wall_per_robot_s": 0.2, "rtf": 5.0},
                            {"robots": 24, "wall_per_robot_s": 0.05, "rtf": 0.8},
                            {"robots": 100, "wall_per_robot_s": 0.02, "rtf": 0.5}]},
         "batch": {"rows": [{"preset": "paper", "robots": 3, "batched_samples_per_s": 2.0e7},
                            {"preset": "paper", "robots": 24, "batched_samples_per_s": 6.0e7},
                            {"preset": "cpu", "robots": 100, "batched_samples_per_s": 9.0e7}]}}
    text = "\n".join(dc.goals(r))
    assert "10x real time: 6.00x" in text
    assert "busy: 50%" in text
    assert "cost per robot-second of 3: 0.25x" in text
    assert "1x real time: 0.50x" in text
    assert "60.0 M (24 robots)" in text  # the paper preset's best, not the default map's
