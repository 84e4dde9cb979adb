"""``ramensim structure [ROOT]``: the shape of a ramensim source tree, drawn from its own imports:
its packages (rooms) and modules, the arrows between packages, the import circles between
modules, and the largest files. Run it on two checkouts (e.g. ``git worktree add /tmp/old REV``)
to show a change's before and after; nothing is imported or run, the files are read as text.

Layers are the repository's top folders, installed inside the ``ramensim`` namespace
(``core/`` is ``ramensim.core``, ``agents/`` is ``ramensim.agents``, ...; pyproject.toml's
package-dir); ``ramensim/`` holds the composition root. Imports under ``if TYPE_CHECKING:`` count
as arrows too (they are still a dependency of the text)."""
from __future__ import annotations

import argparse
import ast
import logging
import sys
from collections import defaultdict
from pathlib import Path

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

LAYERS = ("core", "world", "agents", "channels", "evaluation", "ramensim")
"""The repository's top folders that hold the package, bottom-up (docs/DESIGN.md)."""


def modules(root: Path) -> dict[str, Path]:
    """Every module of the tree at ``root`` by its installed dotted name (``ramensim.agents.team``)."""
    found: dict[str, Path] = {}
    for layer in LAYERS:
        base = root / layer
        for path in sorted(base.rglob("*.py")):
            rel = path.relative_to(base).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            prefix = ["ramensim"] if layer == "ramensim" else ["ramensim", layer]
            found[".".join(prefix + parts)] = path
    return found


def _imported(path: Path, name: str, known: dict[str, Path]) -> set[str]:
    """The modules of ``known`` that module ``name`` (file ``path``) imports, absolute or relative."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            targets = [f"{base}.{a.name}" for a in node.names] + [base]
        for t in targets:
            while t and t not in known:  # a name imported from a module: that module
                t = t.rpartition(".")[0]
            if t and t != name:
                out.add(t)
    return out


def _package(name: str, path: Path) -> str:
    return name if path.name == "__init__.py" else name.rsplit(".", 1)[0]


def _within(package: str, module: str) -> bool:
    """Whether ``package`` is ``module`` or lies inside it (dotted names, whole parts only)."""
    return package == module or package.startswith(module + ".")


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def describe(root: Path, largest: int = 8) -> str:
    """The tree at ``root`` in a few lines of Markdown (see the module's docstring)."""
    mods = modules(root)
    # a module's own package and the packages above it (their __init__) are not arrows of design
    graph = {m: {t for t in _imported(p, m, mods) if not _within(_package(m, p), t)} for m, p in mods.items()}
    lines = {m: len(p.read_text(encoding="utf-8").splitlines()) for m, p in mods.items()}
    rooms = defaultdict(list)
    for m, p in mods.items():
        rooms[_package(m, p)].append(m)
    arrows = {(_package(m, mods[m]), _package(t, mods[t])) for m, ts in graph.items() for t in ts}
    arrows = {(a, b) for a, b in arrows if a != b}
    circles = _circles(graph)
    text = [f"# The tree at {root}", "",
            f"{len(rooms)} packages (rooms), {len(mods)} modules, {sum(lines.values()):,} lines; "
            f"{len(arrows)} arrows between packages; {len(circles)} import circle(s) between modules", "",
            "| package | modules | lines | largest module (lines) |", "|---|---|---|---|"]
    for room in sorted(rooms):
        top = max(rooms[room], key=lambda m: lines[m])
        text.append(f"| {room} | {len(rooms[room])} | {sum(lines[m] for m in rooms[room]):,} | "
                    f"{top.rsplit('.', 1)[-1]} ({lines[top]}) |")
    text += ["", "Largest files: " + ", ".join(f"{mods[m].relative_to(root)} ({lines[m]})"
                                              for m in sorted(lines, key=lambda m: -lines[m])[:largest])]
    for c in circles:
        text.append(f"Circle: {' <-> '.join(c)}")
    return "\n".join(text) + "\n"


def add_parser(sub) -> None:
    p = sub.add_parser("structure", help="the shape of a source tree: packages, arrows, import circles, sizes",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("root", nargs="?", default=None, type=Path,
                   help="a ramensim source tree (default: the one this ramensim runs from)")
    p.add_argument("--largest", type=int, default=8, help="how many of the largest files to name")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    root = args.root or Path(__file__).resolve().parents[2]
    if not (root / "ramensim" / "__init__.py").exists():
        raise InputError(f"ramensim structure: {root} is not a ramensim source tree (no ramensim/__init__.py "
                         f"there); give the folder of a checkout, e.g. one made with 'git worktree add'.")
    sys.stdout.write(describe(root, args.largest))
    return 0
