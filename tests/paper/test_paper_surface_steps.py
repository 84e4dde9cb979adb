"""``ramensim paper surface-steps`` (``ramensim.paper.surface_steps``): a completion dip at the
evaluation where the seen surface jumps is found on a synthetic archive; no runs is one clear error."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from ramensim.commands.paper import main


@pytest.fixture()
def tool():
    from ramensim.paper import surface_steps
    return surface_steps


def _run(folder: Path, cov: list[float], comp: list[float]) -> None:
    folder.mkdir(parents=True)
    tl = [{"t": 30.0 * (i + 1), "agent": a, "team_coverage_pct": v, "completion_ratio_pct": c + a}
          for i, (v, c) in enumerate(zip(cov, comp)) for a in (0, 1)]
    (folder / "metrics.json").write_text(json.dumps({"timeline": tl}))


def test_a_jump_of_the_seen_surface_lowers_completion(tmp_path, tool, capsys):
    _run(tmp_path / "runs" / "a", [10, 11, 25, 26, 27], [70, 71, 60, 66, 70])   # jump at 90 s
    _run(tmp_path / "runs" / "b", [12, 13, 14, 30, 31], [72, 73, 74, 62, 68])   # jump at 120 s
    steps = tool.run_steps(json.loads((tmp_path / "runs" / "a" / "metrics.json").read_text()))
    assert steps[1] == (90.0, 14.0, pytest.approx(-11.0))   # team completion: mean of the two robots
    res = tool.summarize(steps + tool.run_steps(json.loads((tmp_path / "runs" / "b" / "metrics.json").read_text())),
                         jump=5)
    assert res["at_jumps"]["n"] == 2 and res["at_jumps"]["mean"] == pytest.approx(-11.5)
    assert res["elsewhere"]["n"] == 6 and res["elsewhere"]["mean"] > 0
    assert res["correlation"] < -0.9
    assert main(["surface-steps", str(tmp_path), "--until", "90"]) == 0
    assert "steps where the seen surface grew >= 5 points: 1" in capsys.readouterr().out


def test_a_folder_without_runs_is_one_clear_error(tmp_path, tool, caplog):
    assert main(["surface-steps", str(tmp_path / "nope")]) == 2
    assert "holds no runs/<point>/metrics.json" in caplog.text and "nope" in caplog.text
