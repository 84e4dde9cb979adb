"""Progress of runs and sweeps (ramensim.progress): the numbers it shows, the log lines it
writes when not on a terminal, and the sweep folder watcher."""
from __future__ import annotations

import io
import json
import logging
import math
from pathlib import Path

from ramensim.core.events import MessageDelivered, MessageDropped, MessageSent, MetricsEvaluated
from ramensim.progress import RunProgress, SweepProgress, choose_mode, eta_s


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_choose_mode() -> None:
    assert choose_mode(quiet=True) == "off"
    assert choose_mode(stream=io.StringIO()) == "log"

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True
    assert choose_mode(stream=Tty()) == "bar"


def test_eta_is_linear_in_simulated_time() -> None:
    assert eta_s(30.0, 10.0, 60.0) == 150.0
    assert math.isnan(eta_s(5.0, 0.0, 60.0))


def test_run_progress_counts_and_logs(caplog) -> None:
    clock = Clock()
    p = RunProgress(60.0, "office", mode="log", log_every_s=30.0, clock=clock).start()
    with caplog.at_level(logging.INFO, logger="ramensim.progress"):
        p(MessageSent(1.0, 0, 0, 1, 100, 1.0))
        p(MessageSent(1.0, 1, 1, 0, 100, 1.0))
        p(MessageSent(1.5, 2, 0, 1, 100, 1.5))
        p(MessageDelivered(2.0, 0, 0, 1, 100, 1.0, 1.0, 1.0))
        p(MessageDropped(2.0, 1, 1, 0, 100, 1.0, "loss"))
        p(MetricsEvaluated(10.0, 0, {"completion_ratio_pct": 40.0}))
        p(MetricsEvaluated(10.0, 1, {"completion_ratio_pct": 60.0}))
        p(MetricsEvaluated(10.0, -1, {"team_coverage_pct": 90.0}))
        assert not caplog.records  # less than log_every_s of wall time so far
        clock.now += 40.0
        p(MessageSent(15.0, 3, 0, 1, 100, 15.0))
    assert p.t == 15.0 and p.sent == 4 and p.delivered == 1 and p.dropped == 1
    assert p.delivered_fraction == 0.5 and p.completion_pct == 50.0
    assert p.eta_s == 40.0 * 45.0 / 15.0
    (rec,) = caplog.records
    msg = rec.getMessage()
    assert "t=15.0/60 s" in msg and "(25 %)" in msg and "ETA 2:00" in msg
    assert "completion 50.0 %" in msg and "delivered 50 % of 4 sent" in msg


def test_off_mode_is_silent(caplog) -> None:
    p = RunProgress(10.0, mode="off", log_every_s=0.0).start()
    with caplog.at_level(logging.INFO, logger="ramensim.progress"):
        p(MessageSent(5.0, 0, 0, 1, 1, 5.0))
        p.close()
    assert not caplog.records and p.t == 5.0


def test_sweep_progress_reads_the_folder(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    (runs / "a").mkdir(parents=True)
    (runs / "a" / "status.json").write_text("{}")
    part = runs / ".partial-b-1234abcd"
    part.mkdir()
    (part / "metrics.json").write_text(json.dumps({"sim_time_s": 20.0}))
    (runs / ".partial-c-99999999").mkdir()  # just started: no flush yet
    sp = SweepProgress(tmp_path, {"a": 60.0, "b": 60.0, "c": 30.0, "d": 60.0}, mode="off")
    done, running = sp.snapshot()
    assert done == 1 and running == {"b": 20.0, "c": 0.0}


def test_sweep_eta_comes_from_measured_runs_not_the_point_count(tmp_path: Path) -> None:
    """A resumed sweep whose first points were done before it started: the ETA uses the wall
    time per simulated second of the runs it measured (issue 29, item 9)."""
    from ramensim.progress import sweep_eta_s

    runs = tmp_path / "runs"
    for name in ("old1", "old2"):  # finished in an earlier session, very fast: ignored
        (runs / name).mkdir(parents=True)
        (runs / name / "status.json").write_text("{}")
        (runs / name / "metrics.json").write_text(json.dumps({"wall_time_s": 1.0, "sim_time_s": 60.0}))
    sp = SweepProgress(tmp_path, {"old1": 60.0, "old2": 60.0, "new": 60.0, "next": 60.0, "last": 60.0}, mode="off")
    sp._done_at_start = {"old1", "old2"}
    part = runs / ".partial-next-1234abcd"
    part.mkdir()
    (part / "metrics.json").write_text(json.dumps({"wall_time_s": 30.0, "sim_time_s": 15.0}))
    _, running = sp.snapshot()
    assert sp.eta(running) == sweep_eta_s([2.0], 60.0 + 60.0 + 60.0 - 15.0, 1)  # 2 s/s from the running run
    (runs / "new").mkdir()
    (runs / "new" / "status.json").write_text("{}")
    (runs / "new" / "metrics.json").write_text(json.dumps({"wall_time_s": 180.0, "sim_time_s": 60.0}))
    assert sp.eta(running) == 3.0 * (60.0 + 60.0 - 15.0)  # 3 s/s from the run this sweep finished
    assert math.isnan(sweep_eta_s([], 100.0, 2)) and sweep_eta_s([1.0], 100.0, 2) == 50.0


def test_closing_logs_no_second_last_line(caplog) -> None:
    """Neither a run refused before its event loop (a held lock, bad input) nor a finished one
    logs a closing progress line: the run's own 'finished:' line is the last (issue 29, item 8:
    the last progress line was printed twice)."""
    import pytest

    with caplog.at_level(logging.INFO, logger="ramensim.progress"):
        with pytest.raises(RuntimeError):
            with RunProgress(10.0, "refused", "log"):
                raise RuntimeError("the run folder is locked")
        with RunProgress(10.0, "ran", "log") as p:
            p(MessageSent(10.0, 0, 0, 1, 100, 10.0))
    assert not caplog.records


def test_the_last_figure_is_the_runs_result_not_the_last_periodic_mean(caplog) -> None:
    """While the run goes, the completion shown is the last periodic evaluation's mean and says
    when it was taken; once the run has its result (the final evaluation, run after the last
    periodic one), that result is what the bar and the line show (issue 57: the bar ended on
    63.9 % while the run's result was 59.65 %)."""
    p = RunProgress(60.0, "office", mode="log", log_every_s=0.0)
    p(MetricsEvaluated(30.0, 0, {"completion_ratio_pct": 63.0}))
    p(MetricsEvaluated(30.0, 1, {"completion_ratio_pct": 64.8}))
    assert p.completion_pct == 63.9 and "completion 63.9 % at t=30 s" in p.line()
    p.finish(12.0, 59.65)
    assert p.completion_pct == 59.65 and "completion 59.6 % (final)" in p.line()
    p.finish(12.0, float("nan"))  # a run without a final evaluation keeps what it had
    assert p.completion_pct == 59.65


def test_api_run_hands_the_result_to_the_progress(tmp_path, monkeypatch) -> None:
    """ramensim.run tells the bar the run's own completion (RunResult's mean over maps)."""
    import ramensim.lifecycle as lifecycle
    from ramensim import api
    from ramensim.core.results import AgentMetrics, MetricSummary, RunResult

    seen = {}
    real_finish = RunProgress.finish

    def finish(self, wall_s, completion_pct=None):
        seen["args"] = (wall_s, completion_pct)
        real_finish(self, wall_s, completion_pct)

    def fake_run_scenario(sc, run_dir, base_dir=None, subscribers=()):
        result = RunResult(status="ok", scenario=sc.name, method="local", seed=0, n_agents=2, success_rate=1.0,
                           sim_time_s=sc.duration, wall_time_s=3.0,
                           per_agent={"agent_0": AgentMetrics(rounds=1, completion_ratio_pct=50.0),
                                      "agent_1": AgentMetrics(rounds=1, completion_ratio_pct=70.0)},
                           summary={"completion_ratio_pct": MetricSummary(mean=60.0, std=10.0, n=2)},
                           consensus_error=0.0)
        result.write(Path(run_dir) / "metrics.json")
        return RunResult.read(Path(run_dir) / "metrics.json")

    monkeypatch.setattr(RunProgress, "finish", finish)
    monkeypatch.setattr(lifecycle, "run_scenario", fake_run_scenario)
    (tmp_path / "o").mkdir()
    api.run({"method": "local", "duration": 1}, out=tmp_path / "o")
    assert seen["args"] == (3.0, 60.0)
