"""The package layout: core/, world/, agents/, channels/ and evaluation/ install inside the
ramensim namespace (no top-level 'agents' package in a user's environment), every package
folder is listed in pyproject.toml, imports go only down the documented layers
``ramensim (composition root) -> world, agents, channels, evaluation -> ramensim.core`` and no
module imports itself through others (SimPy internals: tests/channels/test_channels_kernel.py)."""
from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MAPPED = {"ramensim": "ramensim", "core": "ramensim.core", "world": "ramensim.world", "agents": "ramensim.agents",
          "channels": "ramensim.channels", "evaluation": "ramensim.evaluation"}
LAYERS = ("core", "world", "agents", "channels", "evaluation")
"""The layers below the composition root, each a top-level folder."""


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


@pytest.mark.parametrize("name, ok", [("agents", False), ("channels", False), ("evaluation", False), ("core", False),
                                      ("world", False), ("ramensim.agents.consensus", True),
                                      ("ramensim.channels", True), ("ramensim.evaluation.metrics", True),
                                      ("ramensim.core", True), ("ramensim.world.datasets", True)])
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
    return parts[1] if len(parts) > 1 and parts[1] in LAYERS else "root"


# which project layers each layer may import (besides itself)
ALLOWED = {"core": set(), "world": {"core"}, "channels": {"core"}, "evaluation": {"core"}, "agents": {"core"},
           "root": set(LAYERS)}


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


def _modules() -> dict[str, Path]:
    """Every module of the project by dotted name (a package by its __init__)."""
    out = {}
    for top, dotted in MAPPED.items():
        for path in (REPO / top).rglob("*.py"):
            rel = path.relative_to(REPO / top).with_suffix("").parts
            if rel and rel[-1] == "__init__":
                rel = rel[:-1]
            out[".".join([dotted, *rel])] = path
    return out


def _module_imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules ``path`` imports, at any depth of the file (imports inside functions
    too: a lazy import is still a dependency; not those only a type checker reads). ``from pkg import name`` counts ``pkg.name`` when
    that is a module, else ``pkg``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    typing_only = set()  # imports under 'if TYPE_CHECKING:' run only for type checkers
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            typing_only.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    out = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                out.add(sub if sub in modules else node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return {m for m in out if m in modules}


def test_no_module_imports_itself_through_others():
    import networkx as nx

    modules = _modules()
    g = nx.DiGraph()
    for name, path in modules.items():
        for target in _module_imports(path, modules):
            # a package's __init__ re-exporting its own modules, and a module importing its
            # own package, are not circles of design
            if target != name and not target.startswith(name + ".") and not name.startswith(target + "."):
                g.add_edge(name, target)
    cycles = [c for c in nx.simple_cycles(g) if len(c) > 1]
    assert not cycles, "import circles:\n" + "\n".join(" -> ".join(c + [c[0]]) for c in cycles[:20])


def test_design_module_map_names_every_module():
    """docs/DESIGN.md's module map (its first code block after 'Module map') lists every module
    by its file path, or the folder holding it (e.g. 'world/'), and lists nothing that is gone."""
    import re

    text = (REPO / "docs" / "DESIGN.md").read_text()
    block = text.split("### Module map", 1)[1].split("```", 2)[1]
    entries = {m.group(1) for m in re.finditer(r"^([\w/.*]+(?:\.py|/))", block, re.M)}
    files = {p.relative_to(REPO).as_posix() for top in MAPPED for p in (REPO / top).rglob("*.py")
             if p.name != "__init__.py" and p.name != "__main__.py"}
    missing = sorted(f for f in files if f not in entries and not any(e.endswith("/") and f.startswith(e)
                                                                       for e in entries))
    gone = sorted(e for e in entries if not (REPO / e).exists())
    assert not missing and not gone, f"not in the module map: {missing}; listed but gone: {gone}"


def test_method_names_are_declared_once():
    """No module of the composition root names a consensus method as a string: what differs by
    method comes from its registry entry (issue 26). The string 'local' of the sweep's local
    process-pool executor is not the method. The analyses of archived runs (ramensim/paper/,
    ramensim/sweep/breadth.py, its figure and its names, breadth_figure.py and breadth_names.py) name methods as the values their sweep files wrote, to select runs
    (an archive's ``method=dinno`` point): data, not behaviour that differs by method."""
    from ramensim.agents.consensus import method_names

    executor = {"ramensim/sweep/runner.py", "ramensim/commands/sweep.py", "ramensim/api.py"}
    archived = ("ramensim/paper/", "ramensim/sweep/breadth.py", "ramensim/sweep/breadth_figure.py",
                "ramensim/sweep/breadth_names.py")
    found = []
    for path in (REPO / "ramensim").rglob("*.py"):
        rel = path.relative_to(REPO).as_posix()
        if rel.startswith(archived):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value in method_names():
                if not (node.value == "local" and rel in executor):
                    found.append(f"{rel}:{node.lineno} {node.value!r}")
    assert not found, found
