"""ramensim compare: the table of several runs (means over maps), the completion curve over
simulated time and its plot, and bad input (a folder without metrics.json: exit 2)."""
from __future__ import annotations

import json
from pathlib import Path

from ramensim.cli import main
from ramensim.commands.compare import compare_runs
from ramensim.core.results import AgentMetrics, RunResult


def _write_run(folder: Path, rate: float, comp: tuple[float, float], timeline: list[dict]) -> Path:
    folder.mkdir(parents=True)
    RunResult(status="ok", scenario="office", method="ramen", seed=0, n_agents=2, success_rate=rate,
              sim_time_s=10.0, wall_time_s=1.0,
              per_agent={"agent_0": AgentMetrics(rounds=5, completion_ratio_pct=comp[0], artifacts_cm=3.0,
                                                 holes_cm=4.0),
                         "agent_1": AgentMetrics(rounds=5, completion_ratio_pct=comp[1], artifacts_cm=5.0,
                                                 holes_cm=None)},
              summary={}, consensus_error=0.01, team_coverage_pct=80.0,
              communication={"sent": 10, "delivered_fraction": rate, "bytes_sent": 2_500_000},
              timeline=timeline).write(folder / "metrics.json")
    return folder


def test_compare_rows_and_curve(tmp_path: Path) -> None:
    a = _write_run(tmp_path / "a", 0.5, (40.0, 60.0),
                   [{"t": 5.0, "agent": 0, "completion_ratio_pct": 20.0},
                    {"t": 5.0, "agent": 1, "completion_ratio_pct": 30.0}])
    b = _write_run(tmp_path / "x" / "a", 0.2, (10.0, 10.0), [])
    rows = compare_runs([a, b / "metrics.json"])
    assert [r["run"] for r in rows] == ["a (1)", "a (2)"]  # same folder names are told apart
    assert rows[0]["completion_ratio_pct"] == 50.0 and rows[0]["completion_ratio_pct_std"] == 10.0
    assert rows[0]["artifacts_cm"] == 4.0
    assert rows[0]["holes_cm"] == 4.0  # the missing one is left out of the mean
    assert rows[1]["success_rate"] == 0.2 and rows[1]["bytes_sent"] == 2_500_000
    assert rows[0]["_curve"] == ([5.0, 10.0], [25.0, 50.0])  # periodic evaluation, then the final one
    assert rows[1]["_curve"] == ([10.0], [10.0])


def test_compare_cli_table_json_and_plot(tmp_path: Path, capsys) -> None:
    a = _write_run(tmp_path / "r50", 0.5, (40.0, 60.0), [])
    b = _write_run(tmp_path / "r20", 0.2, (10.0, 20.0), [])
    plot = tmp_path / "cmp.png"
    assert main(["compare", str(a), str(b), "--plot", str(plot), "--json", "-q"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["run"] for r in rows] == ["r50", "r20"] and rows[1]["completion_ratio_pct"] == 15.0
    assert plot.is_file() and plot.read_bytes()[:4] == b"\x89PNG"
    assert main(["compare", str(a), str(b), "--no-plot", "--labels", "half,fifth"]) == 0
    out = capsys.readouterr().out
    assert "half" in out and "fifth" in out and "50.00 ± 10.00" in out


def test_compare_bad_input(tmp_path: Path, capsys) -> None:
    a = _write_run(tmp_path / "a", 0.5, (1.0, 2.0), [])
    assert main(["compare", str(a), str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err
    assert "no metrics.json" in err and "Traceback" not in err
    assert main(["compare", str(a), "--labels", "x,y", "--no-plot"]) == 2


def test_compare_says_when_a_curve_has_few_points(tmp_path: Path, capsys) -> None:
    a = _write_run(tmp_path / "short", 0.5, (40.0, 60.0), [])
    b = _write_run(tmp_path / "mid", 0.5, (40.0, 60.0), [{"t": 5.0, "agent": 0, "completion_ratio_pct": 20.0}])
    c = _write_run(tmp_path / "long", 0.5, (40.0, 60.0), [{"t": 5.0, "agent": 0, "completion_ratio_pct": 20.0},
                                                           {"t": 9.0, "agent": 0, "completion_ratio_pct": 30.0}])
    assert main(["compare", str(a), str(b), str(c), "--plot", str(tmp_path / "c.png")]) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "run short has 1 evaluation" in err and "one point, the final value" in err
    assert "run mid has 2 evaluations" in err and "only 2 points" in err
    assert "run long" not in err and err.count("evaluation.every_s") == 1  # the hint once for both runs


def test_compare_at_a_periodic_evaluation(tmp_path: Path, capsys) -> None:
    """--at T: the maps' metrics of the evaluation at T and the consensus error of the last probe
    at or before it; the far-part column appears only when a run has it; a time without an
    evaluation is a one-paragraph error naming the run and the times it has."""
    timeline = [{"t": 5.0, "agent": 0, "completion_ratio_pct": 20.0, "completion_far_pct": 4.0,
                 "team_coverage_pct": 30.0},
                {"t": 5.0, "agent": 1, "completion_ratio_pct": 30.0, "completion_far_pct": 8.0,
                 "team_coverage_pct": 30.0},
                {"t": 8.0, "agent": 0, "completion_ratio_pct": 35.0}]
    a = _write_run(tmp_path / "path", 0.5, (40.0, 60.0), timeline)
    data = json.loads((a / "metrics.json").read_text())
    data["consensus_timeline"] = [{"t": 2.0, "consensus_error": 0.3}, {"t": 4.0, "consensus_error": 0.2},
                                  {"t": 6.0, "consensus_error": 0.1}]
    (a / "metrics.json").write_text(json.dumps(data))
    b = _write_run(tmp_path / "complete", 0.5, (40.0, 60.0), [{"t": 5.0, "agent": 0, "completion_ratio_pct": 50.0}])
    rows = compare_runs([a, b], at=5.0)
    assert rows[0]["completion_ratio_pct"] == 25.0 and rows[0]["completion_ratio_pct_std"] == 5.0
    assert rows[0]["completion_far_pct"] == 6.0 and rows[0]["team_coverage_pct"] == 30.0
    assert rows[0]["consensus_error"] == 0.2 and rows[0]["sim_time_s"] == 5.0
    assert rows[1]["completion_ratio_pct"] == 50.0 and rows[1]["completion_far_pct"] != rows[1]["completion_far_pct"]
    assert compare_runs([a])[0]["completion_ratio_pct"] == 50.0  # without --at: the end
    assert main(["compare", str(a), str(b), "--at", "5", "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "t = 5 s" in out and "far part" in out and "6.00 ± 2.00" in out
    assert main(["compare", str(b), "--no-plot"]) == 0
    assert "far part" not in capsys.readouterr().out
    assert main(["compare", str(a), str(b), "--at", "8", "--no-plot"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "run complete has no evaluation at t = 8 s" in err and "its periodic evaluations: 5" in err
    assert "the final one at its end, 10" in err and "Traceback" not in err


def test_compare_at_the_runs_end_takes_the_final_evaluation(tmp_path: Path, capsys) -> None:
    """--at T where T is the run's end (the periodic evaluations stop before it): the final
    evaluation's metrics, and the title says so; a run killed before it (a partial result, no
    final metrics) still refuses that time."""
    a = _write_run(tmp_path / "a", 0.5, (40.0, 60.0), [{"t": 5.0, "agent": 0, "completion_ratio_pct": 20.0},
                                                       {"t": 5.0, "agent": 1, "completion_ratio_pct": 30.0}])
    row = compare_runs([a], at=10.0)[0]
    assert row["completion_ratio_pct"] == 50.0 and row["at_evaluation"] == "final" and row["sim_time_s"] == 10.0
    assert compare_runs([a], at=5.0)[0]["at_evaluation"] == "periodic"
    assert main(["compare", str(a), "--at", "10", "--no-plot"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "at t = 10 s, final evaluation" in out and "50.00 ± 10.00" in out
    killed = _write_run(tmp_path / "killed", 0.5, (float("nan"), float("nan")), [])
    assert main(["compare", str(killed), "--at", "10", "--no-plot"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "has no evaluation at t = 10 s" in err and "final one" not in err
