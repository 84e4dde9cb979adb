"""``ramensim structure``: the shape of a source tree drawn from its imports. On a tree made
here it counts modules, packages, arrows and a planted circle; on this checkout it finds no
import circle at all, type-checking imports included (a stricter reading than
tests/api/test_api_packaging.py's, which leaves those out)."""
from __future__ import annotations

from pathlib import Path

from ramensim.cli import main
from ramensim.commands.structure import describe

ROOT = Path(__file__).resolve().parents[2]


def _tree(tmp_path: Path) -> Path:
    files = {
        "ramensim/__init__.py": "",
        "core/__init__.py": "",
        "core/a.py": "import numpy\n",
        "agents/__init__.py": "",
        "agents/b.py": "from ramensim.core.a import x\nfrom typing import TYPE_CHECKING\n"
                       "if TYPE_CHECKING:\n    from ramensim.agents.c import y\n",
        "agents/c.py": "from . import b\nfrom ramensim.core import a\n",
    }
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    return tmp_path


def test_counts_and_a_planted_circle(tmp_path):
    text = describe(_tree(tmp_path))
    assert "3 packages (rooms), 6 modules" in text
    assert "1 arrows between packages; 1 import circle(s)" in text  # agents -> core, once
    assert "Circle: ramensim.agents.b <-> ramensim.agents.c" in text


def test_this_checkout_has_no_import_circle(capsys):
    assert main(["structure", str(ROOT)]) == 0
    out = capsys.readouterr().out
    assert "0 import circle(s)" in out and "Circle:" not in out


def test_a_folder_that_is_no_source_tree_is_one_paragraph(tmp_path, capsys):
    assert main(["structure", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is not a ramensim source tree" in err and "Traceback" not in err
