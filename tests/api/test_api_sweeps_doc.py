"""Every sweep file shown in docs/SWEEPS.md loads and expands into valid scenarios (the
same check `ramensim sweep --dry-run` makes), relative to scenarios/sweeps/ as shown."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from ramensim.sweep.spec import plan_sweep

ROOT = Path(__file__).resolve().parents[2]
BLOCKS = re.findall(r"```yaml\n(.*?)```", (ROOT / "docs" / "SWEEPS.md").read_text(), flags=re.S)


def test_doc_has_examples() -> None:
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("i", range(len(BLOCKS)))
def test_doc_sweep_files_are_valid(i: int, tmp_path: Path) -> None:
    sweeps = tmp_path / "sweeps"
    sweeps.mkdir()
    for f in (ROOT / "scenarios").glob("*.yaml"):
        (tmp_path / f.name).symlink_to(f)
    path = sweeps / f"doc{i}.yaml"
    path.write_text(BLOCKS[i])
    plan = plan_sweep(path)
    n = 1
    for values in plan.axes.values():
        n *= len(values)
    assert len(plan.points) == n >= 1
