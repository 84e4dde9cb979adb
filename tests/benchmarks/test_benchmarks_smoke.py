"""The benchmarks still run against the code they measure: every module imports, and the
paper-horizon profiler (``benchmarks/bench_long_run.py``), which wraps stages by their names,
profiles a tiny run with every stage found (a renamed module or method fails here, not in
the middle of an hour-long measurement). Timings are printed by the benchmarks, never checked."""
from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODULES = sorted(p.stem for p in (ROOT / "benchmarks").glob("*.py") if p.stem != "__init__")


def _benchmarks_package(monkeypatch) -> None:
    """The repository's benchmarks/ folder as the package ``benchmarks`` (it is not installed),
    loaded from its own file, so that its modules import as ``benchmarks.<name>``."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("benchmarks", ROOT / "benchmarks" / "__init__.py",
                                                  submodule_search_locations=[str(ROOT / "benchmarks")])
    package = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(package)
    monkeypatch.setitem(sys.modules, "benchmarks", package)


@pytest.mark.parametrize("name", MODULES)
def test_benchmark_module_imports(name, monkeypatch):
    _benchmarks_package(monkeypatch)
    importlib.import_module(f"benchmarks.{name}")


def test_long_run_profiler_finds_every_stage(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "benchmarks/bench_long_run.py", "scenarios/office_3agents.yaml",
           "--set", "duration=2", "--set", "recording.mode=off", "--set", "evaluation.every_s=1",
           "--set", "evaluation.voxel_m=0.1", "--set", "evaluation.n_samples=5000", "--window", "1"]
    out = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    text = out.stdout
    assert "status ok" in text, text
    calls = dict(re.findall(r"^  (\S+(?: \S+)*?)\s+[\d.]+ s\s+[\d.]+ %\s+\((\d+) calls\)", text, re.M))
    for stage in ("map gradient", "map step", "frames", "consensus", "rendering", "eval: mesh", "eval: cull",
                  "eval: metrics", "evaluation"):
        assert int(calls.get(stage, 0)) > 0, (stage, text)
    assert "periodic evaluations (simulated t: wall s): 1:" in text, text
