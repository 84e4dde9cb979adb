"""The install promises of the README: torch is a floor in pyproject (installing ramensim never
replaces a user's CUDA build), the CPU wheel comes from constraints/cpu.txt, the README's two
set-up commands use it, and .ci/run runs the README's test command verbatim."""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_torch_is_a_floor_not_a_pin() -> None:
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    torch = [d for d in deps if re.match(r"torch\b", d)]
    assert len(torch) == 1 and ">=" in torch[0] and "==" not in torch[0], torch


def test_constraints_pin_the_cpu_wheel() -> None:
    lines = [l.strip() for l in (ROOT / "constraints" / "cpu.txt").read_text().splitlines()
             if l.strip() and not l.startswith("#")]
    assert "torch==2.13.0+cpu" in lines
    assert "--extra-index-url https://download.pytorch.org/whl/cpu" in lines


def test_readme_commands_use_the_constraints_and_ci_runs_the_test_command() -> None:
    readme = (ROOT / "README.md").read_text()
    cmds = [l for l in readme.splitlines() if l.startswith("python3 -m venv .venv && ")]
    assert len(cmds) == 2, cmds
    assert all("-c constraints/cpu.txt" in c for c in cmds)
    test_cmd = next(c for c in cmds if "pytest" in c)
    assert test_cmd in (ROOT / ".ci" / "run").read_text().splitlines()
