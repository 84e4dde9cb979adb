"""Every sweep file shipped under scenarios/sweeps/ expands into valid scenarios (the check
'ramensim sweep --dry-run' makes), and the paper-horizon files run the protocol docs/RESULTS.md
describes: 600 simulated s, 3 run seeds x 2 house layouts."""
from __future__ import annotations

from pathlib import Path

import pytest

from ramensim.sweep.spec import plan_sweep

SWEEPS = Path(__file__).resolve().parents[2] / "scenarios" / "sweeps"
FILES = sorted(SWEEPS.rglob("*.yaml"))


@pytest.mark.parametrize("path", FILES, ids=[str(p.relative_to(SWEEPS)) for p in FILES])
def test_shipped_sweep_file_plans(path: Path) -> None:
    plan = plan_sweep(path)
    assert plan.points


@pytest.mark.parametrize("path", sorted((SWEEPS / "paper").glob("*.yaml")), ids=lambda p: p.name)
def test_paper_horizon_files_hold_the_protocol(path: Path) -> None:
    plan = plan_sweep(path)
    for p in plan.points:
        assert p.data["duration"] == 600
    trials = {(p.axes["seed"], p.axes["world.scene.seed"]) for p in plan.points}
    assert trials == {(s, lay) for s in (0, 1, 2) for lay in (0, 1)}
