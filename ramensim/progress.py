"""Progress of a run and of a sweep, for the person waiting on it.

:class:`RunProgress` is an event-bus subscriber (``run_scenario(..., subscribers=[p])``): it
follows the simulated time of the events, the latest completion ratio of each map (periodic
evaluation, ``evaluation.every_s``) and the fate of every message. On a terminal it draws a
rich progress bar (simulated seconds of the total, wall time, ETA, completion %, delivered %);
elsewhere (a log file, CI) it writes one log record every ``log_every_s`` wall seconds.

:class:`SweepProgress` watches a sweep folder from a thread of the driver: the points
published under ``runs/`` (overall bar) and, for every point still running in a
``runs/.partial-*`` folder, the simulated time of its latest flushed ``metrics.json``
(``output.flush_every_s``). It reads files only, so it works the same for local workers and Ray.

The ETA is linear in simulated time: wall_elapsed * (total - t) / t (s).
"""
from __future__ import annotations

import json
import logging
import math
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Literal

from ramensim.core.events import Event, MessageDelivered, MessageDropped, MessageSent, MetricsEvaluated
from ramensim.terminal import fit, fit_point

log = logging.getLogger(__name__)

Mode = Literal["bar", "log", "off"]


def choose_mode(quiet: bool = False, stream: Any = None) -> Mode:
    """``off`` with ``-q``; ``bar`` when ``stream`` (default stderr) is a terminal; else ``log``."""
    if quiet:
        return "off"
    stream = sys.stderr if stream is None else stream
    try:
        return "bar" if stream.isatty() else "log"
    except (AttributeError, ValueError):
        return "log"


def eta_s(elapsed_s: float, done: float, total: float) -> float:
    """Linear estimate of the wall seconds left: elapsed * (total - done) / done (nan before any progress)."""
    if done <= 0 or total <= 0:
        return math.nan
    return max(0.0, elapsed_s * (total - done) / done)


def sweep_eta_s(rates: list[float], remaining_sim_s: float, parallel: int) -> float:
    """Wall seconds left in a sweep, measured from its runs (not from the point count, which a
    resumed sweep's already-finished points would distort): the mean wall seconds per
    simulated second of the runs measured so far (finished ones, and the flushed progress of
    running ones), times the simulated seconds left, shared by the runs going in parallel;
    nan before any run has reported."""
    if not rates:
        return math.nan
    return max(0.0, float(sum(rates) / len(rates)) * max(0.0, remaining_sim_s) / max(1, parallel))


def fmt_s(s: float) -> str:
    """Seconds as m:ss (h:mm:ss from an hour on); "?" when not finite."""
    if not math.isfinite(s):
        return "?"
    s = int(round(s))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


class RunProgress:
    """Progress of one run, fed by the simulation's event bus (all times simulated seconds
    unless named wall)."""

    def __init__(self, total_s: float, title: str = "run", mode: Mode = "log", log_every_s: float = 30.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.total_s = float(total_s)
        self.title = title
        self.mode = mode
        self.log_every_s = log_every_s
        self._clock = clock
        self.t = 0.0
        """Simulated time of the latest event (s)."""
        self.sent = self.delivered = self.dropped = 0
        self.completion: dict[int, float] = {}
        """Latest completion ratio (%) of each map from the periodic evaluation."""
        self.final_completion: float | None = None
        """The run's own result (mean over maps of the final evaluation, %), once :meth:`finish` has it."""
        self._wall0 = clock()
        self._last_draw = -math.inf
        self._last_log = self._wall0
        self._progress = None
        self._task = None
        self._final_wall: float | None = None
        self._completion_t = 0.0

    # --- what the run has done so far ----------------------------------------------------
    @property
    def wall_s(self) -> float:
        """Wall seconds since :meth:`start`; once :meth:`finish` has been told the run's own wall
        time, that figure (so the bar ends on the number metrics.json and run.log report)."""
        return self._final_wall if self._final_wall is not None else self._clock() - self._wall0

    def finish(self, wall_s: float, completion_pct: float | None = None) -> None:
        """The run has ended with ``wall_s`` wall seconds (its ``RunResult.wall_time_s``) and,
        when given, ``completion_pct``, its result (``RunResult.mean("completion_ratio_pct")``):
        the bar's last frame shows that figure, not the mean of the last periodic evaluation
        (which the final evaluation, run after it, usually changes)."""
        self._final_wall = float(wall_s)
        if completion_pct is not None and math.isfinite(completion_pct):
            self.final_completion = float(completion_pct)

    @property
    def eta_s(self) -> float:
        return eta_s(self.wall_s, self.t, self.total_s)

    @property
    def delivered_fraction(self) -> float:
        """Delivered / (delivered + dropped): the messages whose fate is known (nan before any)."""
        done = self.delivered + self.dropped
        return self.delivered / done if done else math.nan

    @property
    def completion_pct(self) -> float:
        """The run's result once :meth:`finish` has it; before, the mean over maps of their latest
        periodic completion ratio (%), nan before the first evaluation."""
        if self.final_completion is not None:
            return self.final_completion
        vals = [v for v in self.completion.values() if math.isfinite(v)]
        return sum(vals) / len(vals) if vals else math.nan

    @property
    def completion_text(self) -> str:
        """The completion figure as shown: ``63.9 % at t=60 s`` while the run goes (the last periodic
        evaluation), ``59.7 % (final)`` once :meth:`finish` has the run's result, ``-`` before any."""
        pct = self.completion_pct
        if not math.isfinite(pct):
            return "-"
        if self.final_completion is not None:
            return f"{pct:.1f} % (final)"
        return f"{pct:.1f} % at t={self._completion_t:g} s"

    def line(self) -> str:
        """One line: simulated time, wall, ETA, completion, delivered."""
        pct = 100.0 * self.t / self.total_s if self.total_s > 0 else 100.0
        parts = [f"{self.title}: t={self.t:.1f}/{self.total_s:g} s simulated ({pct:.0f} %)",
                 f"wall {fmt_s(self.wall_s)}", f"ETA {fmt_s(self.eta_s)}"]
        if math.isfinite(self.completion_pct):
            parts.append(f"completion {self.completion_text}")
        if self.sent:
            frac = self.delivered_fraction
            parts.append(f"delivered {'?' if frac != frac else f'{100 * frac:.0f}'} % of {self.sent} sent")
        return ", ".join(parts)

    # --- bus subscriber ---------------------------------------------------------------------
    def __call__(self, event: Event) -> None:
        if event.t > self.t:
            self.t = event.t
        if isinstance(event, MessageSent):
            self.sent += 1
        elif isinstance(event, MessageDelivered):
            self.delivered += 1
        elif isinstance(event, MessageDropped):
            self.dropped += 1
        elif isinstance(event, MetricsEvaluated) and event.agent >= 0:
            v = event.metrics.get("completion_ratio_pct")
            if v is not None:
                self.completion[event.agent] = float(v)
                self._completion_t = event.t
        self.refresh()

    def refresh(self, force: bool = False) -> None:
        """Redraw the bar (at most 10 times a wall second) or log a line (every ``log_every_s``)."""
        if self.mode == "off":
            return
        now = self._clock()
        if self.mode == "bar":
            if self._progress is not None and (force or now - self._last_draw >= 0.1):
                self._last_draw = now
                frac = self.delivered_fraction
                self._progress.update(self._task, completed=min(self.t, self.total_s), eta=fmt_s(self.eta_s),
                                      completion="-" if not math.isfinite(self.completion_pct)
                                      else f"{self.completion_pct:.1f} %",
                                      delivered="-" if frac != frac else f"{100 * frac:.0f} %")
        elif force or now - self._last_log >= self.log_every_s:
            self._last_log = now
            log.info("%s", self.line())

    # --- lifetime ---------------------------------------------------------------------------
    def start(self) -> "RunProgress":
        self._wall0 = self._last_log = self._clock()
        if self.mode == "bar":
            self._progress = _run_bar(lambda: self.wall_s)
            self._task = self._progress.add_task(self.title, total=self.total_s, completion="-", delivered="-",
                                                 eta="?")
            self._progress.start()
        return self

    def close(self, ran: bool = True) -> None:
        """Stop the bar (its final state drawn once); ``ran=False`` (the run was refused or
        raised before its end: a held lock, bad input) draws nothing more. In log mode nothing
        is logged here: the run's own ``finished:`` line (simulated and wall time, messages,
        metrics) is the last one, not a second progress line beside it."""
        if self.mode == "bar" and self._progress is not None:
            if ran:
                self.refresh(force=True)
            self._progress.stop()
            self._progress = None

    def __enter__(self) -> "RunProgress":
        return self.start()

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(ran=exc_type is None)


class SweepProgress:
    """Overall and per-run progress of a sweep, read from its folder by a watcher thread.

    ``durations`` maps point name -> simulated duration (s). Overall: points published under
    ``runs/NAME`` with a ``status.json`` (done, of ``len(durations)``). Per run: the newest
    ``runs/.partial-NAME-*/metrics.json`` flush gives its simulated time."""

    def __init__(self, out_dir: str | Path, durations: dict[str, float], title: str = "sweep",
                 mode: Mode = "log", period_s: float = 1.0, log_every_s: float = 30.0) -> None:
        self.runs = Path(out_dir) / "runs"
        self.durations = dict(durations)
        self.title = title
        self.mode = mode
        self.period_s = period_s
        self.log_every_s = log_every_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._progress = None
        self._overall = None
        self._tasks: dict[str, Any] = {}
        self._name_width = 48
        self._wall0 = time.monotonic()
        self._last_log = self._wall0
        self._done_at_start: set[str] = set()
        self._rates: dict[str, float] = {}
        """Point -> wall seconds per simulated second, of the runs finished by this sweep."""
        self._running_rates: dict[str, float] = {}

    @staticmethod
    def _read_times(folder: Path) -> tuple[float, float]:
        """(simulated s, wall s) of a run folder's metrics.json; zeros when unreadable."""
        try:
            m = json.loads((folder / "metrics.json").read_text(encoding="utf-8"))
            return float(m.get("sim_time_s") or 0.0), float(m.get("wall_time_s") or 0.0)
        except (OSError, ValueError, TypeError, AttributeError):
            return 0.0, 0.0

    def finished(self) -> set[str]:
        """The points published under ``runs/NAME`` with a ``status.json``."""
        return {n for n in self.durations if (self.runs / n / "status.json").is_file()}

    def eta(self, running: dict[str, float], finished: set[str] | None = None) -> float:
        """Wall seconds left (:func:`sweep_eta_s`), from the runs this sweep finished and the
        flushed progress of those running; nan until one has reported."""
        finished = self.finished() if finished is None else finished
        for n in finished - self._done_at_start - set(self._rates):
            sim, wall = self._read_times(self.runs / n)
            if wall > 0 and sim > 0:
                self._rates[n] = wall / sim
        left = sum(d for n, d in self.durations.items() if n not in finished)
        left -= sum(running.values())
        rates = list(self._rates.values()) or list(self._running_rates.values())
        return sweep_eta_s(rates, left, len(running) or 1)

    def snapshot(self) -> tuple[int, dict[str, float]]:
        """(points done, {running point: simulated seconds reached})."""
        return len(self.finished()), self.running()

    def running(self) -> dict[str, float]:
        """{running point: simulated seconds reached}, from its newest flushed metrics.json
        (whose wall time per simulated second also feeds the ETA until a run finishes)."""
        running: dict[str, float] = {}
        if self.runs.is_dir():
            for d in self.runs.glob(".partial-*"):
                name = d.name[len(".partial-"):].rsplit("-", 1)[0]
                if name not in self.durations:
                    continue
                sim, wall = self._read_times(d)
                running[name] = max(running.get(name, 0.0), sim)
                if wall > 0 and sim > 0:
                    self._running_rates[name] = wall / sim
        return running

    def _draw(self) -> None:
        finished, running = self.finished(), self.running()
        done, total = len(finished), len(self.durations)
        eta = self.eta(running, finished)
        if self.mode == "bar" and self._progress is not None:
            self._progress.update(self._overall, completed=done, eta=f"ETA {fmt_s(eta)}", done=f"{done}/{total}")
            for name in list(self._tasks):
                if name not in running:
                    self._progress.remove_task(self._tasks.pop(name))
            for name, t in running.items():
                if name not in self._tasks:
                    self._tasks[name] = self._progress.add_task(f"  {fit_point(name, self._name_width - 2)}",
                                                                total=self.durations[name] or 1.0,
                                                                eta="", done="")
                self._progress.update(self._tasks[name], completed=t, done=f"{t:.0f}/{self.durations[name]:g} s")
        elif self.mode == "log":
            now = time.monotonic()
            if now - self._last_log >= self.log_every_s:
                self._last_log = now
                runs = ", ".join(f"{n} t={t:.0f}/{self.durations[n]:g} s" for n, t in sorted(running.items()))
                log.info("%s: %d/%d points done, wall %s, ETA %s%s", self.title, done, total,
                         fmt_s(now - self._wall0), fmt_s(eta), f"; running {runs}" if runs else "")

    def _loop(self) -> None:
        while not self._stop.wait(self.period_s):
            try:
                self._draw()
            except Exception:  # noqa: BLE001 - a display must never stop a sweep
                log.debug("sweep progress display failed", exc_info=True)

    def start(self) -> "SweepProgress":
        if self.mode == "off":
            return self
        self._wall0 = self._last_log = time.monotonic()
        self._done_at_start = self.finished()
        if self.mode == "bar":
            self._progress, self._name_width = _sweep_bar()
            self._overall = self._progress.add_task(fit(self.title, self._name_width), total=len(self.durations),
                                                    eta="ETA ?",
                                                    done=f"{len(self._done_at_start)}/{len(self.durations)}")
            self._progress.start()
        self._thread = threading.Thread(target=self._loop, daemon=True, name="sweep-progress")
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        if self._progress is not None:
            try:
                self._draw()
            finally:
                self._progress.stop()
                self._progress = None

    def __enter__(self) -> "SweepProgress":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


def _run_bar(wall_s: Callable[[], float]) -> Any:
    """A run's live bar on the shared stderr console, in one line of the terminal's width:
    title, bar, simulated seconds, wall time (``wall_s()``, ticking through the final
    evaluation and ending on the run's own figure), ETA, completion and delivered share;
    below :data:`ramensim.terminal.NARROW` columns the title is left out (the log line above
    names the run) and the labels shortened, so an 80-column terminal shows every figure whole."""
    from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn
    from rich.table import Column
    from rich.text import Text

    from ramensim.terminal import narrow, stderr_console

    class WallColumn(ProgressColumn):
        def render(self, task: Any) -> Text:
            return Text(fmt_s(wall_s()), style="progress.elapsed")

    console = stderr_console()
    whole = {"table_column": Column(no_wrap=True)}  # figures are never cut to "0:00…"
    short = narrow(console)
    cols: list[Any] = [] if short else [TextColumn("[bold]{task.description}", table_column=Column(
        no_wrap=True, overflow="ellipsis", max_width=32))]
    cols += [BarColumn(bar_width=None if short else 30),
             TextColumn("{task.completed:.1f}/{task.total:g} s" + ("" if short else " sim"), **whole),
             WallColumn(table_column=Column(no_wrap=True)),
             TextColumn("ETA {task.fields[eta]}", **whole),
             TextColumn(("compl. {task.fields[completion]} deliv. {task.fields[delivered]}" if short else
                         "completion {task.fields[completion]}  delivered {task.fields[delivered]}"), **whole)]
    return Progress(*cols, console=console, transient=False)


def _sweep_bar() -> tuple[Any, int]:
    """A sweep's live bars on the shared stderr console and the width of their name column:
    one bar for the points done (with the sweep's ETA), one per running point, its name
    shortened to fit (:func:`ramensim.terminal.fit_point`)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Column

    from ramensim.terminal import narrow, stderr_console

    console = stderr_console()
    width = 26 if narrow(console) else 48
    bar = Progress(TextColumn("[bold]{task.description}", table_column=Column(
                       no_wrap=True, overflow="ellipsis", min_width=width, max_width=width)),
                   BarColumn(bar_width=None), TextColumn("{task.fields[done]}", table_column=Column(no_wrap=True)),
                   TimeElapsedColumn(table_column=Column(no_wrap=True)),
                   TextColumn("{task.fields[eta]}", table_column=Column(no_wrap=True)),
                   console=console)
    return bar, width


def point_durations(plan: Any) -> dict[str, float]:
    """Simulated duration (s) of every point of a sweep plan (its ``duration`` key, else the
    scenario default)."""
    from ramensim.schema import Scenario

    default = float(Scenario.model_fields["duration"].default)
    return {p.name: float(p.data.get("duration", default)) for p in plan.points}
