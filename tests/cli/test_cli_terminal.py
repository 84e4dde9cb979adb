"""Terminal output (issue 29, items 8 and 9): the run summary and the live bar fit an
80-column terminal with every figure whole; logs share the bars' console (drawn above a bar,
not onto its line); piped output is plain and unwrapped; one wall-time figure everywhere."""
from __future__ import annotations

import io
import logging
from pathlib import Path

import pytest
from rich.console import Console

import ramensim.terminal as terminal
from ramensim.commands.run import _print_summary
from ramensim.core.results import AgentMetrics, RunResult
from ramensim.observe import one_line

LONG_PATH = Path("/tmp/a/rather/long/folder/name/for/the/runs/of/this/test") / ("x" * 60)


def _result() -> RunResult:
    agents = {f"agent_{k}": AgentMetrics(rounds=600, completion_ratio_pct=73.01 + k, artifacts_cm=2.34,
                                         holes_cm=9.29, own_coverage_pct=71.26, completion_unseen_pct=65.73)
              for k in range(3)}
    return RunResult(status="ok", scenario="house_3agents", method="ramen", seed=0, n_agents=3, success_rate=1.0,
                     sim_time_s=600.0, wall_time_s=1134.8, per_agent=agents, summary={}, consensus_error=0.0138,
                     team_coverage_pct=57.3,
                     communication={"sent": 12, "delivered": 11, "dropped": 1, "in_flight": 6})


@pytest.fixture
def console_of_width(monkeypatch):
    """Make the command's stdout console (or the shared stderr one) a terminal of a given width."""
    def make(width: int, which: str = "stdout") -> io.StringIO:
        buf = io.StringIO()
        con = Console(file=buf, width=width, force_terminal=True, soft_wrap=True, color_system=None)
        if which == "stdout":
            monkeypatch.setattr(terminal, "stdout_console", lambda: con)
        else:
            monkeypatch.setattr(terminal, "_stderr_console", con)
        return buf
    return make


def test_summary_fits_80_columns_with_whole_titles_and_figures(console_of_width):
    buf = console_of_width(80)
    _print_summary(_result(), LONG_PATH)
    text = buf.getvalue()
    table = [line for line in text.splitlines() if line.startswith(("┃", "│", "┏", "└"))]
    assert table and all(len(line) <= 80 for line in table)
    assert "…" not in text  # no title or figure cut to 'comple…'
    for figure in ("73.01", "74.01", "75.01", "2.34", "9.29", "71.26", "65.73", "600"):
        assert figure in text
    assert "compl. = completion ratio" in text  # the short titles are said in full
    assert str(LONG_PATH) in text  # the run folder's path is never split by us (soft wrap)


def test_summary_piped_is_plain_and_unwrapped(capsys):
    _print_summary(_result(), LONG_PATH)
    out = capsys.readouterr().out
    assert "\x1b[" not in out  # no colour codes in a pipe
    assert f"run folder: {LONG_PATH}\n" in out
    assert "completion %" in out and "own coverage¹ %" in out  # whole titles
    assert "600 s simulated in 1135 s of wall time" in out
    assert "messages: 18 sent: 11 delivered, 1 dropped, 6 still in flight at the end" in out


def test_run_bar_fits_80_columns(console_of_width):
    from ramensim.progress import RunProgress

    console_of_width(80, which="stderr")
    p = RunProgress(600.0, "house_3agents_with_a_long_name", mode="bar")
    p.start()
    try:
        p.t, p.sent, p.delivered, p.completion = 312.4, 10, 9, {0: 70.04}
        p.refresh(force=True)
        row = Console(file=io.StringIO(), width=80, color_system=None)
        with row.capture() as cap:
            row.print(p._progress.make_tasks_table(p._progress.tasks))
        line = cap.get().rstrip("\n")
    finally:
        p.close(ran=False)
    assert len(line) <= 80 and "…" not in line
    assert "312.4/600 s" in line and "ETA " in line and "compl. 70.0 %" in line and "deliv. 100 %" in line


def test_the_bar_ends_on_the_runs_own_wall_time():
    from ramensim.progress import RunProgress

    now = [0.0]
    p = RunProgress(10.0, mode="off", clock=lambda: now[0]).start()
    now[0] = 5.0
    assert p.wall_s == 5.0
    now[0] = 100.0
    p.finish(42.5)
    assert p.wall_s == 42.5  # the figure metrics.json and run.log report, not the bar's own clock


def test_logs_share_the_bars_console_on_a_terminal(monkeypatch):
    from rich.logging import RichHandler

    from ramensim.cli import _setup_logging

    root = logging.getLogger()
    saved = root.handlers[:], root.level
    try:
        monkeypatch.setattr(terminal, "is_terminal", lambda stream: True)
        _setup_logging(0, False)
        (handler,) = root.handlers
        assert isinstance(handler, RichHandler) and handler.console is terminal.stderr_console()
    finally:
        root.handlers[:] = saved[0]
        root.setLevel(saved[1])


def test_piped_logs_are_one_plain_line_each(capsys):
    from ramensim.cli import _setup_logging

    root = logging.getLogger()
    saved = root.handlers[:], root.level
    try:
        _setup_logging(0, False)
        logging.getLogger("ramensim.test").info("run folder %s", LONG_PATH)
    finally:
        root.handlers[:] = saved[0]
        root.setLevel(saved[1])
    (line,) = capsys.readouterr().err.splitlines()
    assert line.endswith(f"INFO run folder {LONG_PATH}")


def test_finished_line_carries_times_and_messages():
    line = one_line(_result())
    assert line.startswith("600.0 s simulated in 1134.8 s of wall time")
    assert "18 sent: 11 delivered, 1 dropped, 6 still in flight" in line and "91.7 %" in line


def test_point_names_fit_keeping_every_axis():
    from ramensim.terminal import fit_point

    name = "seed=0__world.scene.seed=1__method=centralised"
    assert fit_point(name, 60) == name
    assert fit_point(name, 34) == "seed=0 seed=1 method=centralised"
    assert fit_point(name, 24) == "0 / 1 / centralised"
    assert fit_point(name, 10) == "…ntralised" and len(fit_point("x" * 50, 10)) == 10


def test_footnotes_wrap_at_words_on_an_80_column_terminal(console_of_width):
    """The footnotes and the team-coverage and messages sentences are longer than 80 columns:
    on a terminal they wrap between words, never mid-word (issue 57); the run folder's path is
    still never split by us."""
    buf = console_of_width(80)
    _print_summary(_result(), LONG_PATH)
    lines = buf.getvalue().splitlines()
    prose = [line for line in lines if not line.startswith(("┃", "│", "┏", "└", "┡", "run folder:"))]
    assert all(len(line) <= 80 for line in prose), [line for line in prose if len(line) > 80]
    text = " ".join(" ".join(prose).split())
    for sentence in ("¹ of the surface the team saw, the share this map's own camera(s) saw; ² completion on the "
                     "part only teammates saw", "(the denominator of the metrics above is that seen part)",
                     "6 still in flight at the end"):
        assert sentence in text  # every word whole
    assert f"run folder: {LONG_PATH}" in buf.getvalue()
