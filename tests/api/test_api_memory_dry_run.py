"""``ramensim run FILE --dry-run``: what one robot and the run cost in memory, item by item,
against the machine; nothing is run and no folder is made."""
from __future__ import annotations

from pathlib import Path

from ramensim.cli import main
from ramensim.config import load_scenario
from ramensim.memory import describe, robot_breakdown, scenario_estimate

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "house_3agents.yaml"


def test_breakdown_items_add_up_to_the_estimate_per_robot() -> None:
    sc = load_scenario(SCENARIO, ["agents.count=12", "topology.kind=ring"])
    items = dict(robot_breakdown(sc))
    n = sc.map.n_params
    assert items["map parameters (theta)"] == 4 * n
    assert items["per-neighbour state (8 vectors x 2 neighbours)"] == 4 * n * 8 * 2
    without_rays = sum(b for what, b in items.items() if not what.startswith("ray database"))
    # the run's estimate (less the fixed share) is 12 such robots and the rounds' lent buffers
    from ramensim.agents.consensus import get_method
    from ramensim.memory import lent_vectors

    lent = 4 * n * lent_vectors(get_method("ramen"), 12)
    assert scenario_estimate(sc) - (1 << 30) == 12 * without_rays + lent
    assert "rounds' work buffers" in describe(sc)
    assert "does NOT fit" in describe(sc, available=1 << 30) and "fits" in describe(sc, available=1 << 40)


def test_dry_run_prints_the_costs_and_runs_nothing(tmp_path: Path, capsys) -> None:
    out = tmp_path / "never"
    assert main(["run", str(SCENARIO), "--set", "agents.count=100", "--set", "topology.kind=ring",
                 "--set", "world.trajectory.split=none", "--out", str(out), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "memory of one robot" in text and "ray database" in text and "for 100 robots on the 'ring'" in text
    assert not out.exists()
