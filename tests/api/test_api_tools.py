"""tools/ keeps only queues and thin entry scripts (issue 69 item 3): every Python script there is a
few lines that call a ``main`` of the package, nothing imports through ``sys.path``, and each one
still starts (``--help``), so every command older pages print keeps working."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPTS = sorted((REPO / "tools").glob("*.py"))


def test_tools_holds_only_thin_scripts_and_queues():
    assert SCRIPTS
    assert {p.suffix for p in (REPO / "tools").iterdir() if p.is_file()} <= {".py", ".sh"}
    for path in SCRIPTS:
        text = path.read_text(encoding="utf-8")
        tree = ast.parse(text)
        code = [n for n in tree.body if not (isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant))]
        assert len(code) <= 3, f"{path.name}: more than an import and a call of the package's main"
        imports = [n for n in code if isinstance(n, ast.ImportFrom)]
        assert len(imports) == 1 and imports[0].module.startswith("ramensim.") and \
            [a.name for a in imports[0].names] == ["main"], path.name
        assert "sys.path" not in text and "PYTHONPATH" not in text, path.name


def test_no_sys_path_imports_in_tools_or_tests():
    """Tests import the package; a test's own helper beside it is found by pytest, not by a path
    put on sys.path (the plugin loader's sys.path entry for a user's plugin file is a feature)."""
    offenders = []
    for top in ("tools", "tests"):
        for path in (REPO / top).rglob("*.py"):
            text = path.read_text(encoding="utf-8")
            if path.name != Path(__file__).name and ("sys.path.insert" in text or "sys.path.append" in text
                                                     or "syspath_prepend" in text):
                offenders.append(str(path.relative_to(REPO)))
    assert not offenders, offenders


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.name for p in SCRIPTS])
def test_every_script_starts(path):
    proc = subprocess.run([sys.executable, str(path), "--help"], capture_output=True, text=True, timeout=120,
                          cwd=REPO)
    assert proc.returncode == 0 and "usage:" in proc.stdout and "Traceback" not in proc.stderr, proc.stderr
