"""The README's two commands, as written, in a fresh clone (issue 29: 'a fresh-clone test that
runs the README's commands as written'). Slow: it makes two virtual environments and installs
the package with its dependencies (network), then runs the default scenario end to end and
the test command on one test module (the whole suite would take its own 10-15 minutes).

    .venv/bin/python -m pytest -m slow tests/e2e/test_e2e_readme_fresh_clone.py
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow


def _readme_commands() -> tuple[str, str]:
    cmds = [line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith("python3 -m venv .venv && ")]
    run = next(c for c in cmds if "ramensim run" in c)
    test = next(c for c in cmds if "pytest" in c)
    return run, test


@pytest.fixture(scope="module")
def clone(tmp_path_factory) -> Path:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs git and a git checkout to clone")
    dest = tmp_path_factory.mktemp("fresh") / "ramensim"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(dest)], check=True, timeout=300)
    return dest


def _bash(cmd: str, cwd: Path, timeout: int) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "PYTHONPATH"))}
    env.setdefault("PIP_RETRIES", "1")
    return subprocess.run(["bash", "-c", cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def test_the_main_command_runs_the_default_scenario_end_to_end(clone):
    run_cmd, _ = _readme_commands()
    proc = _bash(run_cmd, clone, 3000)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (metrics,) = (clone / "runs").glob("*/metrics.json")
    m = json.loads(metrics.read_text())
    assert m["status"] == "ok" and m["sim_time_s"] == 60.0
    assert all(a["completion_ratio_pct"] > 0 for a in m["per_agent"].values())
    assert "run folder:" in proc.stdout


def test_the_test_command_runs(clone):
    _, test_cmd = _readme_commands()
    proc = _bash(test_cmd + " -q tests/api/test_api_install.py", clone, 3000)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert " passed" in proc.stdout
