"""The package layout: agents/, channels/ and evaluation/ install inside the ramensim
namespace (no top-level 'agents' package in a user's environment), every package folder is
listed in pyproject.toml, and imports form the documented DAG (SimPy internals:
tests/channels/test_channels_kernel.py):
``ramensim (composition root) -> agents, channels, evaluation -> ramensim.core``."""
from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MAPPED = {"ramensim": "ramensim", "agents": "ramensim.agents", "channels": "ramensim.channels",
          "evaluation": "ramensim.evaluation"}


def _package_folders() -> set[str]:
    names = set()
    for top, dotted in MAPPED.items():
        for init in (REPO / top).rglob("__init__.py"):
            rel = init.parent.relative_to(REPO / top)
            names.add(".".join([dotted, *rel.parts]))
    return names


def test_pyproject_lists_every_package_folder():
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert set(cfg["packages"]) == _package_folders()
    assert {k: v for k, v in cfg["package-dir"].items()} == {v: k for k, v in MAPPED.items()}


@pytest.mark.parametrize("name, ok", [("agents", False), ("channels", False), ("evaluation", False),
                                      ("ramensim.agents.consensus", True), ("ramensim.channels", True),
                                      ("ramensim.evaluation.metrics", True), ("ramensim.core", True)])
def test_installed_namespace(tmp_path, name, ok):
    """Run outside the repository, so only the installed package can answer."""
    proc = subprocess.run([sys.executable, "-c", f"import {name}"], cwd=tmp_path, capture_output=True, text=True,
                          env={"PATH": "/usr/bin:/bin"})
    assert (proc.returncode == 0) is ok, proc.stderr


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return {m for m in out if m.split(".")[0] == "ramensim"}


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in ("agents", "channels", "evaluation", "core") else "root"


# which project layers each layer may import (besides itself)
ALLOWED = {"core": set(), "channels": {"core"}, "evaluation": {"core"}, "agents": {"core"},
           "root": {"core", "agents", "channels", "evaluation"}}


def test_imports_form_the_documented_dag():
    bad = []
    for top, dotted in MAPPED.items():
        for path in (REPO / top).rglob("*.py"):
            rel = path.relative_to(REPO / top).with_suffix("")
            layer = _layer(".".join([dotted, *rel.parts]))
            for mod in _imports(path):
                target = _layer(mod)
                if target != layer and target not in ALLOWED[layer]:
                    bad.append(f"{path.relative_to(REPO)} ({layer}) imports {mod} ({target})")
    assert not bad, "\n".join(bad)
