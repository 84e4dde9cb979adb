"""The paper style of a sweep's report (``ramensim report SWEEP_DIR --style paper``; called by
:func:`ramensim.sweep.report.make_report`): figures a column or a page wide as PDF, SVG and PNG,
8-pt fonts, one colour per method, the mean over trials of the runs' team means with 95 % Student
t bands, hollow markers and footnotes where robots diverged or failed, and captions that open
with the sweep's description (:func:`sweep_description`)."""
from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ramensim.evaluation.plots import key_words
from ramensim.sweep import store
from ramensim.sweep.aggregate import group_axes, table_metrics
from ramensim.sweep.html import write_html
from ramensim.sweep.spec import is_replicate_axis
from ramensim.sweep.trials import TrialSummary
from ramensim.sweep.timecourse import CURVE_METRICS, condition_title, trial_words, write_timecourse
from ramensim.sweep.report_common import (MAX_GROUPS, MAX_TIMELINES, Report, _CONSENSUS_FIGURES, _and, _numeric,
                                          _safe, _words)

log = logging.getLogger(__name__)

STYLES = ("default", "paper")
"""Report styles (:func:`make_report`'s ``style``): the screen report, or figures for a paper."""
PAPER_METRICS = ("completion_ratio_pct", "artifacts_cm", "holes_cm")
"""The panels of the paper style's metric figures unless ``--metrics`` names others: the paper's
three (%, cm, cm)."""
_LINESTYLES = ("-", "--", ":", "-.")
_MARKERS = ("o", "s", "^", "D", "v", "P")
MAX_NOTED_ROBOTS = 6
"""Most robots a footnote names one by one (the rest are counted)."""


def sweep_description(plan: Mapping[str, Any], root: Path | None = None) -> str:
    """What the sweep is, in its author's words: the plan's ``description`` when it has one, else
    the leading comment block of the sweep file named by the plan's ``source`` (when that file is
    still there), else the sweep's name (else the folder's). One paragraph, whitespace joined."""
    text = plan.get("description")
    if isinstance(text, str) and text.strip():
        return " ".join(text.split())
    source = plan.get("source")
    if isinstance(source, str) and source:
        try:
            lines = Path(source).read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError):
            lines = []
        block: list[str] = []
        for line in lines:
            stripped = line.strip()
            if stripped.startswith("#"):
                block.append(stripped.lstrip("#").strip())
            elif stripped or block:
                break
        words = " ".join(" ".join(block).split())
        if words:
            return words
    return str(plan.get("name") or (root.name if root is not None else "sweep"))


@dataclass
class Trouble:
    """A robot of a run that diverged or failed (or a whole run that failed: ``agent`` None)."""
    run: str
    trial: str
    """The run's trial in words (``run seed 0, scene layout 1``)."""
    agent: str | None
    kind: str
    """``diverged`` or ``failed``."""
    reason: str = ""


def _trial_text(axes: Mapping[str, Any]) -> str:
    return ", ".join(f"{key_words(k)} {v}" for k, v in axes.items() if is_replicate_axis(k)) or "the one run"


def robot_troubles(root: Path, records: Sequence[Any], metrics_by_run: Mapping[str, Any]) -> dict[str, list[Trouble]]:
    """Per run name, its robots that diverged (non-finite map or loss: their metrics are NaN and
    left out of the team mean) or failed (their round raised; metrics.json ``per_agent``'s
    ``diverged`` and ``failed_reason``), and a run that failed as a whole (not counted at all)."""
    out: dict[str, list[Trouble]] = {}
    for rec in records:
        metrics = metrics_by_run.get(rec.name)
        if metrics is None and rec.status not in store.COMPLETE:
            metrics = store.read_json(root / store.RUNS / rec.name / store.METRICS)
        trial = _trial_text(rec.axes)
        found: list[Trouble] = []
        per_agent = metrics.get("per_agent") if isinstance(metrics, Mapping) else None
        if isinstance(per_agent, Mapping):
            for agent, entry in per_agent.items():
                if not isinstance(entry, Mapping):
                    continue
                if entry.get("failed_reason"):
                    found.append(Trouble(rec.name, trial, str(agent), "failed", str(entry["failed_reason"])))
                elif entry.get("diverged"):
                    why = entry.get("diverged_reason") or ""
                    rnd = entry.get("diverged_round")
                    found.append(Trouble(rec.name, trial, str(agent), "diverged",
                                         f"{why} in round {rnd}" if why and rnd is not None else str(why)))
        if rec.status not in store.COMPLETE and not found:
            found.append(Trouble(rec.name, trial, None, "failed", str(rec.error or rec.status)))
        if found:
            out[rec.name] = found
    return out


def _n_robots(metrics: Any) -> int:
    per_agent = metrics.get("per_agent") if isinstance(metrics, Mapping) else None
    return len(per_agent) if isinstance(per_agent, Mapping) else 0


def trouble_note(troubles: Sequence[Trouble], robots: int) -> str:
    """A footnote's words for one point: how many of its ``robots`` diverged or failed and which,
    per trial (``2 of 18 robots diverged (run seed 0, scene layout 1: agent_2; ...)``), and the runs
    that failed as a whole (not counted)."""
    parts = []
    for kind in ("diverged", "failed"):
        these = [t for t in troubles if t.kind == kind and t.agent is not None]
        if not these:
            continue
        by_trial: dict[str, list[str]] = {}
        for t in these:
            by_trial.setdefault(t.trial, []).append(str(t.agent))
        items = [f"{trial}: {', '.join(agents)}" for trial, agents in by_trial.items()]
        more = f"; {len(items) - MAX_NOTED_ROBOTS} more trials" if len(items) > MAX_NOTED_ROBOTS else ""
        count = f"{len(these)} of {robots}" if robots else str(len(these))
        parts.append(f"{count} robot{'s' if len(these) != 1 or robots != 1 else ''} {kind} "
                     f"({'; '.join(items[:MAX_NOTED_ROBOTS])}{more})")
    runs = [t for t in troubles if t.agent is None]
    if runs:
        parts.append(f"{len(runs)} run{'s' if len(runs) != 1 else ''} failed, not counted "
                     f"({'; '.join(t.trial for t in runs[:MAX_NOTED_ROBOTS])})")
    return "; ".join(parts)


def _letters() -> Any:
    import itertools
    import string

    for n in itertools.count(1):
        for combo in itertools.product(string.ascii_lowercase, repeat=n):
            yield "".join(combo)


@dataclass
class _Point:
    """The runs of one condition (every non-seed axis fixed)."""
    axes: dict[str, Any]
    runs: list[Any] = field(default_factory=list)
    troubles: list[Trouble] = field(default_factory=list)
    robots: int = 0


class _PaperData:
    """What the paper style's figures are drawn from: each finished run's team mean of every
    metric (:func:`ramensim.sweep.trials.team_mean`), grouped by condition, with the robots
    that diverged or failed; estimates are means over trials with the 95 % Student t interval
    of ``summary.md``'s interval table (:func:`ramensim.evaluation.intervals.t_interval`)."""

    def __init__(self, root: Path, records: Sequence[Any], axes: Mapping[str, Sequence[Any]],
                 metrics_by_run: Mapping[str, Any]) -> None:
        from ramensim.sweep.trials import team_mean

        self.axes = axes
        self.keys = group_axes(axes)
        self.troubles = robot_troubles(root, records, metrics_by_run)
        self.team = {r.name: {m: team_mean(r.values, m) for m in r.values} for r in records
                     if r.status in store.COMPLETE}
        self.points: dict[str, _Point] = {}
        from ramensim.sweep.spec import _canonical

        self._canonical = _canonical
        for r in records:
            p = self.points.setdefault(self.point_id(r.axes), _Point({k: r.axes.get(k) for k in self.keys}))
            if r.status in store.COMPLETE:
                p.runs.append(r)
            p.troubles += self.troubles.get(r.name, [])
            p.robots += _n_robots(metrics_by_run.get(r.name)) or len(r.values.get("completion_ratio_pct", []))
        methods = {str(m.get("method")) for m in metrics_by_run.values() if isinstance(m, Mapping) and m.get("method")}
        self.method = next(iter(methods)) if len(methods) == 1 else None
        """The one method of a sweep without a method axis (its colour), else None."""

    def point_id(self, ax: Mapping[str, Any]) -> str:
        return self._canonical({k: ax.get(k) for k in self.keys})

    def estimate(self, point: _Point, metric: str) -> tuple[float, float, float, int]:
        """(mean over trials, 95 % lo, hi, trials) of the team mean of ``metric`` at ``point``;
        lo and hi NaN with fewer than two trials."""
        from ramensim.evaluation.intervals import t_interval

        iv = t_interval([self.team[r.name].get(metric, math.nan) for r in point.runs])
        return iv.estimate, iv.lo, iv.hi, iv.n



def _series_styles(combos: Sequence[Mapping[str, Any]], keys: Sequence[str], method: str | None) -> list[tuple[str, str, str]]:
    """(colour, line style, marker) of each combination of ``keys``: the colour of its method
    (the ``method`` key, else the sweep's one method, else grey), lightened by its rank among the
    combinations of the same method; line style and marker by that rank too."""
    from ramensim.evaluation.plots import method_colour, shade

    def m_of(c: Mapping[str, Any]) -> str | None:
        return str(c["method"]) if "method" in keys else method

    out = []
    for c in combos:
        same = [d for d in combos if m_of(d) == m_of(c)]
        rank = next(i for i, d in enumerate(same) if d is c)
        base = method_colour(m_of(c)) if m_of(c) else "#555555"
        out.append((shade(base, rank, len(same)), _LINESTYLES[rank % len(_LINESTYLES)], _MARKERS[rank % len(_MARKERS)]))
    return out


def _ordered_combos(data: _PaperData, keys: Sequence[str]) -> list[dict[str, Any]]:
    """The combinations of ``keys``' values the sweep's points hold, in the tables' order."""
    import itertools

    from ramensim.evaluation.plots import value_order

    have = {data._canonical({k: p.axes.get(k) for k in keys}) for p in data.points.values()}
    out = []
    for vals in itertools.product(*(value_order(k, list(data.axes[k])) for k in keys)):
        combo = dict(zip(keys, vals))
        if data._canonical(combo) in have:
            out.append(combo)
    return out


def _where(combo: Mapping[str, Any], keys: Sequence[str]) -> str:
    """A point in a footnote: the method's name first, then each other key in words with its
    value (``dsgt, compute-time jitter 0.5``)."""
    from ramensim.evaluation.plots import format_value

    parts = [str(combo.get(k)) for k in keys if k == "method"]
    parts += [f"{key_words(k)} {format_value(k, combo.get(k))}" for k in keys if k != "method"]
    return ", ".join(parts) or "the sweep"


def _words_of(combo: Mapping[str, Any], keys: Sequence[str]) -> str:
    from ramensim.evaluation.plots import format_value

    return ", ".join(format_value(k, combo.get(k)) for k in keys) or "all"


class _Notes:
    """Footnote letters of one figure: a letter per point where robots diverged or failed."""

    def __init__(self) -> None:
        self.items: list[tuple[str, str]] = []
        self.lost = False
        """Whether some marked point has no value left (drawn as an x at the panel's bottom)."""
        self._gen = _letters()

    def add(self, where: str, point: _Point) -> str | None:
        if not point.troubles:
            return None
        letter = next(self._gen)
        self.items.append((letter, f"{where}: {trouble_note(point.troubles, point.robots)}"))
        return letter

    def text(self, what: str = "Hollow marker, letter") -> str:
        """The caption's footnote sentence (empty when no robot diverged or failed); ``what``:
        how the figure marks such a point."""
        if not self.items:
            return ""
        return (f" {what}: robots diverged (their values left out of the team mean) or failed there: "
                + "; ".join(f"({a}) {t}" for a, t in self.items) + ".")


def _over_trials(axes: Mapping[str, Sequence[Any]], of: str = "team") -> str:
    """What a paper-style figure's value and band are: the mean over the sweep's trials of each
    run's team mean (``of="team"``) or of its one value (``"run"``: the consensus error), and
    the 95 % Student t interval over the trials; one trial: no band."""
    seeds = [k for k in axes if is_replicate_axis(k)]
    n = int(np.prod([len(axes[k]) for k in seeds])) if seeds else 1
    value = "each run's team mean (over its robots)" if of == "team" else "each run's value"
    if n < 2:
        return f"{value} of the one trial (n = 1, so no band)"
    return f"mean over the {n} trials ({trial_words(seeds)}) of {value}; bands: 95 % Student t intervals over the trials"


def _paper_figures(root: Path, data: _PaperData, rows: Sequence[Mapping[str, Any]], plot_metrics: Sequence[str],
                   metrics_by_run: Mapping[str, Any], records: Sequence[Any], width: str, formats: Sequence[str],
                   description: str, tc: Any) -> tuple[list[Path], dict[str, str]]:
    """Every figure of the paper style (see :func:`make_report`) and its caption, by stem."""
    from ramensim.evaluation.plots import (PaperSeries, format_value, is_fraction_key, method_colour,
                                           paper_bars, paper_lines, save_paper_figure, value_order)

    plots = root / "plots"
    files: list[Path] = []
    caps: dict[str, str] = {}
    keys = data.keys
    cond = [k for k in keys if len(data.axes.get(k, [])) > 1]
    over = _over_trials(data.axes)
    for key in cond:
        others = [k for k in cond if k != key]
        combos = _ordered_combos(data, others)
        if len(combos) > MAX_GROUPS:
            log.warning("sweep %s: %d combinations of %s are too many lines for one figure; skipped the %s figure",
                        root.name, len(combos), others, key)
            continue
        styles = _series_styles(combos, others, data.method)
        values = value_order(key, list(data.axes[key]))
        numeric = _numeric(values)
        notes = _Notes()
        series = []
        for j, (combo, (colour, ls, marker)) in enumerate(zip(combos, styles)):
            s = PaperSeries(_words_of(combo, others), colour, ls, marker)
            for i, v in enumerate(values):
                point = data.points.get(data.point_id({**combo, key: v}))
                if point is None:
                    continue
                x = (100.0 * float(v) if is_fraction_key(key) else float(v)) if numeric else float(i)
                letter = notes.add(_where({**combo, key: v}, [*others, key]), point)
                if letter:
                    s.marks[x] = letter
                for m in plot_metrics:
                    est, lo, hi, _ = data.estimate(point, m)
                    s.points.setdefault(m, []).append((x, est, lo, hi))
                    notes.lost |= bool(letter) and not math.isfinite(est)
            series.append(s)
        what = _and([_words(m) for m in plot_metrics])
        what = what[:1].upper() + what[1:]
        by = f", one line per {condition_title(others).lower()}" if others else ""
        legend = condition_title(others) if others else None
        if numeric:
            stem = f"vs_{_safe(key)}"
            xs = [100.0 * float(v) if is_fraction_key(key) else float(v) for v in values]
            fig = paper_lines(series, key, plot_metrics, width, legend_title=legend, x_values=xs)
            unit = " (%, log scale)" if is_fraction_key(key) and fig.axes[0].get_xscale() != "linear" else \
                (" (%)" if is_fraction_key(key) else "")
            caps[stem] = (f"{description} — {what} against the {key_words(key)}{unit}{by}; {over}."
                          + notes.text("Hollow marker, letter" + (" (an x at the panel's bottom: no value left)"
                                                                  if notes.lost else "")))
        else:
            stem = f"bars_{_safe(key)}"
            cats = [format_value(key, v) for v in values]
            colours = {format_value(key, v): method_colour(v) for v in values} if key == "method" else None
            fig = paper_bars(cats, series, key, plot_metrics, width, legend_title=legend, colours=colours)
            caps[stem] = (f"{description} — {what} per {key_words(key)}"
                          + (f", one bar per {condition_title(others).lower()} in each group" if others else "")
                          + f"; bar: {over.replace('bands:', 'error bars:')}.{notes.text('Hatched bar, letter')}")
        files += save_paper_figure(fig, plots / stem, formats)
    if not cond:  # only seeds vary: one bar per metric
        notes = _Notes()
        point = next(iter(data.points.values()), None)
        s = PaperSeries("all", method_colour(data.method) if data.method else "#555555")
        if point is not None:
            if notes.add("the sweep", point):
                s.marks[0.0] = "a"
            for m in plot_metrics:
                est, lo, hi, _ = data.estimate(point, m)
                s.points[m] = [(0.0, est, lo, hi)]
        label = data.method or str(root.name)
        fig = paper_bars([label], [s], "method" if data.method else "sweep", plot_metrics, width)
        what = _and([_words(m) for m in plot_metrics])
        caps["bars"] = (f"{description} — {what[:1].upper() + what[1:]}; bar: {over.replace('bands:', 'error bars:')}."
                        f"{notes.text('Hatched bar, letter')}")
        files += save_paper_figure(fig, plots / "bars", formats)
    files += _paper_timeline_figures(root, data, records, metrics_by_run, width, formats, description, tc, caps)
    return files, caps


def _condition_series(data: _PaperData, label_runs: Mapping[str, list[Any]], varying: Sequence[str],
                      notes: _Notes) -> dict[str, PaperSeries]:
    """A :class:`PaperSeries` per condition label (no points yet), styled by method and rank."""
    from ramensim.evaluation.plots import PaperSeries

    combos = _ordered_combos(data, varying)
    styles = _series_styles(combos, varying, data.method)
    from ramensim.sweep.timecourse import condition_words

    out: dict[str, PaperSeries] = {}
    for combo, (colour, ls, _) in zip(combos, styles):
        label = condition_words(combo, varying) if varying else "all"
        if label not in label_runs:
            continue
        s = PaperSeries(label, colour, ls)
        point = _Point(dict(combo))
        for p in data.points.values():
            if all(data._canonical(p.axes.get(k)) == data._canonical(v) for k, v in combo.items()):
                point.troubles += p.troubles
                point.robots += p.robots
        letter = notes.add(label, point)
        if letter:
            s.marks[math.inf] = letter
        out[label] = s
    return out


def _paper_timeline_figures(root: Path, data: _PaperData, records: Sequence[Any], metrics_by_run: Mapping[str, Any],
                            width: str, formats: Sequence[str], description: str, tc: Any,
                            caps: dict[str, str]) -> list[Path]:
    """Completion over time (with the references) and the consensus error over time, 95 % bands
    over trials at each evaluation time."""
    from ramensim.evaluation.intervals import t_interval
    from ramensim.evaluation.plots import PaperSeries, method_colour, paper_timelines, save_paper_figure
    from ramensim.sweep.timecourse import condition_words, is_ceiling, matching_references

    files: list[Path] = []
    varying = [k for k in data.keys if len(data.axes.get(k, [])) > 1]

    def bands(by_t: Mapping[float, list[float]]) -> list[tuple[float, float, float, float]]:
        out = []
        for t in sorted(by_t):
            iv = t_interval(by_t[t])
            out.append((t, iv.estimate, iv.lo, iv.hi))
        return out

    over = _over_trials(data.axes)
    # completion over time
    if tc is not None and tc.curves:
        notes = _Notes()
        runs_of: dict[str, list[Any]] = {}
        for c in tc.curves:
            runs_of.setdefault(condition_words(c.axes, varying) if varying else "all", []).append(c)
        base = _condition_series(data, runs_of, varying, notes)
        panels: dict[str, list[PaperSeries]] = {}
        for m in CURVE_METRICS:
            series = []
            for label, s in base.items():
                by_t: dict[float, list[float]] = {}
                for c in runs_of[label]:
                    for t, v in zip(c.times, c.values[m]):
                        by_t.setdefault(t, []).append(v)
                series.append(PaperSeries(s.label, s.colour, s.linestyle, s.marker, {m: bands(by_t)}, s.marks))
            refs: dict[str, list[Any]] = {}
            for c in matching_references(tc.references, tc.curves):
                refs.setdefault(str(c.axes.get("method")), []).append(c)
            for method, cs in refs.items():
                by_t = {}
                for c in cs:
                    for t, v in zip(c.times, c.values[m]):
                        by_t.setdefault(t, []).append(v)
                series.append(PaperSeries(f"{method} (reference)", method_colour(method),
                                          "--" if is_ceiling(method) else ":", "", {m: bands(by_t)}))
            panels[m] = series
        fig = paper_timelines(panels, width, legend_title=condition_title(varying) if varying else None)
        files += save_paper_figure(fig, root / "plots" / "completion_over_time", formats)
        refs_text = (f"; thin lines: {_and(list(dict.fromkeys(str(c.axes.get('method')) for c in matching_references(tc.references, tc.curves))))} "
                     f"of the same trials from the reference sweep (dashed: the ceiling, dotted: the floor)"
                     if tc.drawn_references else "")
        what = f"{_words(CURVE_METRICS[0])} and {_words(CURVE_METRICS[1])}"
        caps["completion_over_time"] = (f"{description} — {what[:1].upper() + what[1:]} against simulated time (s)"
                                        + (f", one line per condition ({condition_title(varying).lower()})" if varying else "")
                                        + f"; {over}{refs_text}.{notes.text('Hollow end marker, letter in the legend')}")
    # the consensus error over time
    for key, stem in _CONSENSUS_FIGURES:
        runs_of = {}
        by_label: dict[str, dict[float, list[float]]] = {}
        for rec in records:
            run = metrics_by_run.get(rec.name)
            timeline = run.get("consensus_timeline") if isinstance(run, Mapping) else None
            if not isinstance(timeline, list) or not timeline:
                continue
            label = condition_words(rec.axes, varying) if varying else "all"
            for probe in timeline:
                if isinstance(probe, Mapping) and isinstance(probe.get(key), numbers.Real) \
                        and isinstance(probe.get("t"), numbers.Real):
                    by_label.setdefault(label, {}).setdefault(float(probe["t"]), []).append(float(probe[key]))
                    runs_of.setdefault(label, [])
        if not by_label or len(by_label) > MAX_TIMELINES:
            continue
        notes = _Notes()
        base = _condition_series(data, runs_of, varying, notes)
        series = [PaperSeries(s.label, s.colour, s.linestyle, s.marker, {key: bands(by_label[s.label])}, s.marks)
                  for s in base.values()]
        fig = paper_timelines({key: series}, width, log_y=True,
                              legend_title=condition_title(varying) if varying else None)
        files += save_paper_figure(fig, root / "plots" / stem, formats)
        what = ("Consensus error (RMS spread of the maps' parameters, eq. CE-1)" if key == "consensus_error" else
                "Consensus error weighted by eq. 19 (CE-2, the disagreement RAMEN's penalty sees)")
        caps[stem] = (f"{description} — {what} against simulated time (s)"
                      + (f", one line per condition ({condition_title(varying).lower()})" if varying else "")
                      + f"; {_over_trials(data.axes, 'run')}; log scale, a band's lower edge clipped at the axis' "
                        f"bottom.{notes.text('Hollow end marker, letter in the legend')}")
    return files


def _paper_report(rep: Report, root: Path, plan: Mapping[str, Any], records: Sequence[Any],
                  axes: Mapping[str, list[Any]], keys: Sequence[str], rows: Sequence[Mapping[str, Any]],
                  names: Sequence[str], metrics: Sequence[str] | None, metrics_by_run: Mapping[str, Any],
                  over_trials: TrialSummary, formats: Sequence[str], references: Sequence[str | Path], html: str,
                  width: str, title: str, progress: str, description: str, digits: int) -> Report:
    """The figures, captions and page of :func:`make_report`'s paper style (its tables are written)."""
    fmts = list(dict.fromkeys([*formats, "pdf", "svg", "png"]))
    plot_metrics = list(metrics) if metrics else [m for m in PAPER_METRICS if m in names] or list(names[:3])
    tc = write_timecourse(root, records, keys, title, (), [Path(r) for r in references], metrics_by_run)
    rep.tables += [f for f in tc.files if f.suffix in (".csv", ".md")]
    rep.missing_timeline = tc.missing_timeline
    data = _PaperData(root, records, axes, metrics_by_run)
    robots_lost: dict[str, str] = {}
    figures, rep.captions = _paper_figures(root, data, rows, plot_metrics, metrics_by_run, records, width, fmts,
                                           description, tc)
    rep.figures += figures
    from ramensim.evaluation.plots import PAPER_WIDTHS_IN

    lines = [f"# Figure captions: {title}\n", f"Each figure {PAPER_WIDTHS_IN[width]:g} in wide ({width} width), "
             f"as PDF, SVG and PNG under plots/.\n"]
    lines += [f"## {stem}\n\n{text}\n" for stem, text in rep.captions.items()]
    store.atomic_write_text(root / "plots" / "captions.md", "\n".join(lines))
    rep.tables.append(root / "plots" / "captions.md")
    for row in rows:  # the page's results table: how many robots diverged or failed at each point
        point = data.points.get(data.point_id(row))
        lost = [t for t in (point.troubles if point is not None else []) if t.agent is not None]
        runs_lost = [t for t in (point.troubles if point is not None else []) if t.agent is None]
        text = (f"{len(lost)} of {point.robots}" if lost and point is not None else "") + \
            (f"{', ' if lost else ''}{len(runs_lost)} run{'s' if len(runs_lost) != 1 else ''} failed" if runs_lost else "")
        robots_lost[data.point_id(row)] = text
    lead = f"{description} — "  # report.html says the description once, under its title
    page_captions = {k: v[len(lead):] if v.startswith(lead) else v for k, v in rep.captions.items()}
    rep.tables.append(write_html(root, title, progress, rows, keys, table_metrics(names), records, tc.ttc_rows,
                                 embed=html == "embedded", captions=page_captions, axes=axes,
                                 fixed=plan.get("set") or {}, trials=over_trials, digits=digits,
                                 paper_width_in=PAPER_WIDTHS_IN[width], description=description,
                                 robots_lost=[robots_lost.get(data.point_id(r), "") for r in rows]))
    log.info("sweep %s: wrote %d tables and %d figure files (paper style, %s width) under %s", title,
             len(rep.tables), len(rep.figures), width, root)
    return rep
