"""``ramensim sweep --device cuda|cpu|auto``: every run's maps on that torch device without
making the runs other points. The run gets ``map.device`` (its scenario says where it ran), its
status the device, and the point keeps the plan's fingerprint, so a later sweep without the
option counts it as done (a GPU run completes the same protocol point as a CPU run);
``--device cuda`` on a machine without CUDA is a one-paragraph error before anything runs."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
import yaml

from ramensim.cli import main
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict


def _sweep_file(tmp_path: Path) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "map": {"device": "cpu"}}))
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump({"name": "exp", "base": "base.yaml", "axes": {"seed": [0, 1]}}, sort_keys=False))
    return path


def test_device_reaches_the_runs_and_keeps_the_points(tmp_path):
    plan = plan_sweep(_sweep_file(tmp_path), validate_fn=validate_dict)
    out = tmp_path / "out"
    first = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False,
                      device="auto")
    assert sorted(first.ok) == sorted(p.name for p in plan.points)
    for p in plan.points:
        ran = json.loads((out / "runs" / p.name / "scenario.json").read_text())
        status = json.loads((out / "runs" / p.name / "status.json").read_text())
        assert ran["map"]["device"] == "auto" and p.data["map"]["device"] == "cpu"
        assert status["device"] == "auto" and status["fingerprint"] == p.fingerprint
    again = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert again.skipped == len(plan.points) and not again.ok  # the same points, already done


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has CUDA")
def test_device_cuda_without_a_gpu_is_a_clear_error(tmp_path, capsys):
    code = main(["sweep", str(_sweep_file(tmp_path)), "--device", "cuda", "--out", str(tmp_path / "o"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "--device cuda" in err and "no CUDA device" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "runs").exists()
