"""``ramensim paper figures`` (``ramensim.paper.figures``): docs/RESULTS.md's completion-over-time
figures. The band is Student's t interval of the mean over trials (checked against the formula by
hand); runs are grouped by condition and method, trials pooled; a missing archive is one error
line, exit 2 (through the CLI, and logged by the script's ``main``)."""
from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from ramensim.commands.paper import main


@pytest.fixture()
def figures():
    from ramensim.paper import figures
    return figures


def _timeline(path: Path) -> None:
    """Two success rates x two methods x three trials (run seed x layout), evaluations at 30 and 60 s."""
    cols = ["name", "seed", "world.scene.seed", "channel.success_rate", "method", "wall_time_s",
            "final_completion_ratio_pct", "completion_ratio_pct@30", "completion_ratio_pct@60"]
    path.parent.mkdir(parents=True)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for rate, base in (("1.0", 70.0), ("0.2", 60.0)):
            for method, shift in (("ramen", 5.0), ("dinno", 0.0)):
                for k, (seed, layout) in enumerate(((0, 0), (0, 1), (1, 0))):
                    v30, v60 = base + shift + 2 * k, base + shift + 10 + k
                    w.writerow([f"p{rate}{method}{k}", seed, layout, rate, method, 1.0, v60, v30,
                                "" if (rate, method, k) == ("0.2", "dinno", 2) else v60])


def test_t_interval_is_the_t_formula(figures):
    mean, low, high = figures.t_interval([70.0, 72.0, 74.0])
    half = 4.302652729911275 * 2.0 / math.sqrt(3)  # t(0.975, 2) x sample std 2 / sqrt(3)
    assert mean == pytest.approx(72.0) and low == pytest.approx(72.0 - half) and high == pytest.approx(72.0 + half)
    assert math.isnan(figures.t_interval([70.0])[1]) and math.isnan(figures.t_interval([])[0])
    assert figures.t_interval([70.0, math.nan, 74.0])[0] == pytest.approx(72.0)  # a missing evaluation is skipped


def test_runs_grouped_by_condition_and_method(figures, tmp_path):
    path = tmp_path / "paper_x" / "runs_timeline.csv"
    _timeline(path)
    conditions, times, data = figures.read_timeline(path)
    assert conditions == ["channel.success_rate"] and times == [30.0, 60.0]
    assert set(data) == {(("channel.success_rate", "1.0"),), (("channel.success_rate", "0.2"),)}
    ramen = data[(("channel.success_rate", "1.0"),)]["ramen"]
    assert ramen == [[75.0, 85.0], [77.0, 86.0], [79.0, 87.0]]  # three trials pooled
    with_units = figures.read_timeline(path, with_units=True)[2][(("channel.success_rate", "1.0"),)]["ramen"]
    assert [r[:-1] for r in with_units] == ramen and all(isinstance(r[-1], str) for r in with_units)
    assert math.isnan(data[(("channel.success_rate", "0.2"),)]["dinno"][2][1])
    png = figures.draw("paper_x", path, tmp_path / "out")
    assert png.name == "paper_x_completion.png" and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_missing_or_foreign_archive_is_one_error(figures, tmp_path, capsys, caplog):
    bad = tmp_path / "res" / "paper_y" / "runs_timeline.csv"
    bad.parent.mkdir(parents=True)
    bad.write_text("a,b\n1,2\n")
    # the script's main logs the paragraph (before the CLI below takes over the log's handlers)
    assert main(["figures", "--results", str(tmp_path / "nothing"), "--out", str(tmp_path / "o")]) == 2
    assert "nothing" in caplog.text and "Traceback" not in caplog.text
    assert main(["figures", "--results", str(tmp_path / "res"), "--out", str(tmp_path / "o")]) == 2
    assert "runs_timeline.csv" in caplog.text
    assert "runs_timeline.csv" in capsys.readouterr().err  # the script's paragraph also reaches stderr
    from ramensim.cli import main as cli

    assert cli(["paper", "figures", "--results", str(tmp_path / "nothing"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "nothing" in err and "Traceback" not in err
    assert cli(["paper", "figures", "--results", str(tmp_path / "res"), "--out", str(tmp_path / "o")]) == 2
    assert "runs_timeline.csv" in capsys.readouterr().err
