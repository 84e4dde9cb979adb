"""Every method runs end to end with its maps on CUDA (``map.device: cuda``): the consensus
state, the copies received and the messages' encoding follow the map's device (a map on CUDA
sends host copies and keeps what it receives next to its own state). Each run is set beside
the same run on the CPU's pure-torch path: the same messages (the channel and the schedule do
not depend on the device) and the same metrics up to float rounding. Skipped where torch sees
no CUDA device (CI); run on a GPU machine with ``pytest tests/e2e/test_e2e_cuda.py``."""
from __future__ import annotations

import csv
import json

import pytest
import torch

from ramensim.config import load_scenario
from ramensim.lifecycle import run_scenario

from tiny_runs import SCENARIO, TINY

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="torch sees no CUDA device")


def _run(tmp_path, method: str, device: str, *extra: str):
    sc = load_scenario(SCENARIO, TINY + ["duration=3", "evaluation.every_s=null", f"method={method}",
                                         f"map.device={device}", "map.native=false", *extra])
    sc = sc[0] if isinstance(sc, tuple) else sc
    folder = tmp_path / f"{method}_{device}_{len(extra)}"
    run_scenario(sc, folder)
    metrics = json.loads((folder / "metrics.json").read_text())
    if not (folder / "messages.csv").exists():  # local, centralised: nothing sent
        return metrics, []
    with open(folder / "messages.csv", newline="") as f:
        msgs = [(r["src"], r["dst"], r["t_sent"], r["status"]) for r in csv.DictReader(f)]
    return metrics, msgs


@pytest.mark.parametrize("method, extra", [
    ("ramen", ()), ("dinno", ()), ("dsgd", ()), ("dsgt", ()), ("local", ()), ("centralised", ()),
    ("ramen", ("consensus.encoding=sparse",)),
])
def test_method_runs_on_cuda_as_on_the_cpu(tmp_path, method, extra):
    torch.backends.cuda.matmul.allow_tf32 = False
    gpu, gpu_msgs = _run(tmp_path, method, "cuda", *extra)
    cpu, cpu_msgs = _run(tmp_path, method, "cpu", *extra)
    assert gpu["status"] == "ok" and not any(e["diverged"] for e in gpu["per_agent"].values())
    assert gpu_msgs == cpu_msgs
    assert set(gpu["per_agent"]) == set(cpu["per_agent"])
    for name, a_cpu in cpu["per_agent"].items():
        a_gpu = gpu["per_agent"][name]
        assert a_gpu["rounds"] == a_cpu["rounds"] > 0
        assert a_gpu["completion_ratio_pct"] == pytest.approx(a_cpu["completion_ratio_pct"], abs=1.0)


def test_lockstep_batches_on_cuda_match_the_cpu(tmp_path, monkeypatch):
    """The team engine's lockstep batches (``RAMENSIM_TEAM_BATCH=1``: every pending round's
    gradients in one pass over stacked tables, the form built for a GPU) on CUDA against the
    same batches on the CPU's torch path: the same messages, the same metrics up to rounding."""
    from ramensim.agents.team import BATCH_ENV, WORKERS_ENV

    torch.backends.cuda.matmul.allow_tf32 = False
    monkeypatch.delenv(WORKERS_ENV, raising=False)
    monkeypatch.setenv(BATCH_ENV, "1")
    gpu, gpu_msgs = _run(tmp_path, "ramen", "cuda", "agents.compute.jitter=0.3")
    cpu, cpu_msgs = _run(tmp_path, "ramen", "cpu", "agents.compute.jitter=0.3")
    for m in (gpu, cpu):
        assert m["status"] == "ok" and m["build"]["team_lockstep"] and m["build"]["team_largest_batch"] >= 2
    assert gpu_msgs == cpu_msgs and gpu_msgs
    for name, a_cpu in cpu["per_agent"].items():
        a_gpu = gpu["per_agent"][name]
        assert a_gpu["rounds"] == a_cpu["rounds"] > 0
        assert a_gpu["completion_ratio_pct"] == pytest.approx(a_cpu["completion_ratio_pct"], abs=1.0)
