"""Cheap, importable stand-ins for the validation and run functions of a sweep (pickled by
reference into spawned worker processes, so they must live in a module, not in a test)."""
from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

METHOD_BASE = {"ramen": 90.0, "dinno": 70.0, "dsgd": 60.0, "dsgt": 50.0}


def validate_dict(data: dict[str, Any], source: str) -> dict[str, Any]:
    """Accept any scenario dict (the sweep logic under test does not need the real schema)."""
    return dict(data)


def agent_metrics(scenario: dict[str, Any]) -> list[dict[str, float]]:
    """Known per-agent metrics: completion = base(method) x rate + seed + agent index."""
    n = int(scenario.get("agents", {}).get("count", 3))
    rate = float(scenario.get("channel", {}).get("success_rate", 1.0))
    seed = int(scenario.get("seed", 0))
    base = METHOD_BASE.get(scenario.get("method", "ramen"), 10.0)
    return [{"artifacts_cm": 1.0 + i + seed, "holes_cm": 2.0 * (i + 1),
             "completion_ratio_pct": base * rate + seed + i} for i in range(n)]


def fake_run(scenario: dict[str, Any], out_dir: Path) -> dict[str, Any]:
    """Log the call, sleep ``sleep_s``, fail if ``fail`` is set, else return known metrics
    (writing metrics.json like the real run does when ``write_metrics`` is set)."""
    log_file = scenario.get("log_file")
    if log_file:
        fd = os.open(log_file, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, (json.dumps(scenario.get("tag")) + "\n").encode())
        finally:
            os.close(fd)
    (Path(out_dir) / "scenario.json").write_text(json.dumps(scenario), encoding="utf-8")
    # where it ran: the Ray cluster test checks the point ran on the worker node (its cwd)
    (Path(out_dir) / "where.json").write_text(json.dumps({"cwd": os.getcwd(), "pid": os.getpid(),
                                                             "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY")}), encoding="utf-8")
    pid_file = scenario.get("pid_file")  # the Ray test kills this very process mid-point
    if pid_file:
        Path(pid_file).write_text(str(os.getpid()), encoding="utf-8")
    time.sleep(float(scenario.get("sleep_s", 0.0)))
    hold = scenario.get("hold_while")  # keep running while this file exists (at most 120 s)
    deadline = time.monotonic() + 120.0
    while hold and Path(hold).exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    if scenario.get("fail"):
        raise RuntimeError(f"injected failure for seed {scenario.get('seed')}")
    seed = int(scenario.get("seed", 0))
    metrics = {"agents": agent_metrics(scenario), "consensus_error": 0.5 * seed,
               "consensus_timeline": [{"t": 1.0, "consensus_error": 1.0 + seed}, {"t": 2.0, "consensus_error": 0.5 * seed}]}
    if scenario.get("diverge"):
        metrics["diverged_agents"] = [0]
    if scenario.get("interrupted"):
        metrics.update(status="interrupted", error="interrupted by the user")
    if scenario.get("write_metrics"):
        (Path(out_dir) / "metrics.json").write_text(json.dumps(metrics), encoding="utf-8")
    return metrics


def hard_crash(scenario: dict[str, Any], out_dir: Path) -> dict[str, Any]:
    """Kill the worker process itself (as the OOM killer would) when ``crash`` is set."""
    if scenario.get("crash"):
        os._exit(137)
    return fake_run(scenario, out_dir)


def real_run(scenario: Any, out_dir: Path, base_dir: Path | None = None) -> dict[str, Any]:
    """The real :func:`ramensim.lifecycle.run_scenario`; while the shipped decoder weights are not in
    the tree, with seeded random decoders instead (the sweep machinery is what is under test)."""
    import tempfile

    import torch

    from ramensim.agents.map import pretrain
    from ramensim.agents.map.decoders import init_decoders
    from ramensim.lifecycle import run_scenario

    if not pretrain.DEFAULT_DECODERS.is_file():
        path = Path(tempfile.mkdtemp(prefix="decoders-")) / "decoders.pt"
        pretrain.save_decoders(init_decoders(scenario.map, torch.Generator().manual_seed(0)), path)
        pretrain.DEFAULT_DECODERS = path
    return run_scenario(scenario, out_dir, base_dir=base_dir)


def blob_run(scenario: dict[str, Any], out_dir: Path) -> dict[str, Any]:
    """:func:`fake_run` that also writes ``blob_bytes`` bytes (a mesh's worth) into its folder
    first, as a real run's outputs take space (a full disk fails here with ENOSPC)."""
    with open(Path(out_dir) / "blob.bin", "wb") as fh:
        fh.write(b"\0" * int(scenario.get("blob_bytes", 0)))
        fh.flush()
        os.fsync(fh.fileno())
    return fake_run(scenario, out_dir)
