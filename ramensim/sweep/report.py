"""Draw a sweep's tables and figures from its folder alone (``ramensim report SWEEP_DIR``).

Writes ``summary.csv`` (mean/std/n per metric), ``summary.md`` (mean ± std cells), ``runs.csv``
(one line per run) and ``plots/``:
- ``vs_<axis>.png|svg`` for every numeric axis with several values (paper Fig. 5 for
  ``channel.success_rate``, Fig. 7 for ``agents.count``), one line per combination of the other
  non-seed axes;
- ``bars_<axis>.png|svg`` for every categorical axis with several values (``method``: paper
  Table I), bars grouped by the other non-seed axes;
- ``consensus_timeline.png|svg`` and ``consensus_weighted_timeline.png|svg``: the consensus
  error (unweighted, eq. CE-1, and weighted by eq. 19, CE-2) over simulated time, one line per
  condition (mean ± std over seeds), for sweeps whose runs communicate;
- ``completion_over_time.png|svg``, ``runs_timeline.csv`` and ``time_to_consensus.csv|md``:
  completion over simulated time per condition and the time to consensus
  (``ramensim.sweep.timecourse``).

``summary.md`` opens with how many of the planned runs are done and names the missing ones,
so a report on a partly finished sweep says what it lacks; after its mean ± std table come each
point's 95 % interval of the team mean over trials, the paired comparisons of the completion
ratio along each swept key and the runs not counted or marked (``ramensim.sweep.trials``; the
interval columns are appended to ``summary.csv`` too). ``report.html`` holds all of it in
one self-contained page (``ramensim.sweep.html``), the figures of the metrics against a swept
number first; every figure's caption is built here from the sweep's own axes, trials and
references (:func:`captions`), so it never names an axis or a reference the sweep lacks.
"""
from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ramensim.evaluation.plots import (key_words, metric_label, plot_metric_bars, plot_metric_lines, plot_timelines,
                                       save_figure)
from ramensim.sweep import store
from ramensim.sweep.aggregate import (PRIMARY_METRICS, aggregate, group_axes, load_runs, run_table,
                                      summary_tables, table_metrics)
from ramensim.sweep.html import write_html
from ramensim.sweep.spec import is_replicate_axis
from ramensim.sweep.trials import TrialSummary, add_to_rows, csv_columns, markdown, summarize
from ramensim.sweep.timecourse import (CURVE_METRICS, condition_sort_key, condition_title, condition_words,
                                       trial_words, write_timecourse)

log = logging.getLogger(__name__)

MAX_GROUPS = 12
"""Most lines/bar groups in one figure; beyond that a figure is skipped with a log message."""
MAX_TIMELINES = 16
"""Most lines in the consensus-error-over-time figure (Fig. 5 with 7 rates x 2 methods fits)."""
HTML_MODES = ("embedded", "linked")
"""How report.html carries its figures (:func:`make_report`'s ``html``)."""
PANEL_ORDER = ("completion_ratio_pct", "artifacts_cm", "holes_cm", "completion_unseen_pct", "completion_far_pct",
               "completion_own_pct", "own_coverage_pct")
"""Order of the panels of a figure of metrics: the completion ratio (Fig. 5's and Fig. 7's) first."""


@dataclass
class Report:
    """What :func:`make_report` wrote."""

    rows: list[dict[str, Any]]
    metrics: list[str]
    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    missing_timeline: list[str] = field(default_factory=list)
    """Completed runs without a timeline (no completion over time for them)."""
    progress: str = ""
    """How many planned runs are done, and which are missing."""
    captions: dict[str, str] = field(default_factory=dict)
    """Figure stem -> its caption (built from the sweep's axes, trials and references)."""
    trials: TrialSummary | None = None
    """Each point's 95 % interval over trials, the paired comparisons, the runs not counted."""


def _numeric(values: Sequence[Any]) -> bool:
    return all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in values)


def _safe(key: str) -> str:
    return key.replace("/", "-")


_CONSENSUS_FIGURES = (("consensus_error", "consensus_timeline"), ("consensus_error_weighted", "consensus_weighted_timeline"))
"""The consensus error's timelines drawn (probe key, figure stem): unweighted (CE-1) and weighted (CE-2)."""


def _words(metric: str) -> str:
    """A metric's label for a sentence: no arrow, lower case (``completion ratio (%)``)."""
    text = metric_label(metric).replace(" ↑", "").replace(" ↓", "")
    return text[:1].lower() + text[1:] if not text[1:2].isupper() else text


def _and(items: Sequence[str]) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1] if items else ""


def _over(axes: Mapping[str, Sequence[Any]]) -> str:
    """``over agents and the 6 trials (run seed × scene layout)``, naming only the seed axes the
    sweep has; ``over agents`` when it has none."""
    seeds = [k for k in axes if is_replicate_axis(k)]
    if not seeds:
        return "over agents (one run per condition)"
    n = int(np.prod([len(axes[k]) for k in seeds]))
    return f"over agents and the {n} trial{'s' if n != 1 else ''} ({trial_words(seeds)})"


def captions(axes: Mapping[str, Sequence[Any]], keys: Sequence[str], drawn: Mapping[str, Sequence[str]],
             trials: int = 0, references: Sequence[str] = ()) -> dict[str, str]:
    """Each figure's caption (by file stem) in words, from the sweep's own axes: the swept keys
    of each figure, the seed axes a trial is made of, and the references drawn (``references``:
    the methods of ``--references`` runs beside the conditions). ``drawn``: stem -> the metrics of
    a metrics figure (``vs_KEY``, ``bars_KEY``, ``bars``)."""
    out: dict[str, str] = {}
    cond = [k for k in keys if len(axes.get(k, [])) > 1]
    for stem, metrics in drawn.items():
        what = _and([_words(m) for m in metrics])
        what = what[:1].upper() + what[1:]
        key = stem.split("_", 1)[1] if "_" in stem else ""
        others = [k for k in cond if k != key]
        by = condition_title(others).lower() if others else ""
        if stem.startswith("vs_"):
            unit = " (%)" if metric_label(key).endswith("(%)") else ""
            out[stem] = (f"{what} against the {key_words(key)}{unit}, " + (f"one line per {by}; " if by else "")
                         + f"mean ± std {_over(axes)}; bands: ± 1 std.")
        elif stem.startswith("bars_"):
            out[stem] = (f"{what} per {key_words(key)}" + (f", one bar per {by} in each group" if by else "")
                         + f"; bar: mean, error bar: ± 1 std {_over(axes)}.")
        else:
            out[stem] = f"{what}; bar: mean, error bar: ± 1 std {_over(axes)}."
    per = f"one line per condition ({condition_title(cond).lower()})" if cond else "one line"
    seeds = [k for k in axes if is_replicate_axis(k)]
    over = (f"mean ± std over {trials} trial{'s' if trials != 1 else ''} ({trial_words(seeds)})" if seeds
            else "one run per condition")
    refs = (f"; thin grey lines: {_and(list(references))} of the same trials from the reference sweep "
            f"(dashed: the ceiling, dotted: the floor)" if references else "")
    out["completion_over_time"] = (f"{_words(CURVE_METRICS[0])[:1].upper()}{_words(CURVE_METRICS[0])[1:]} and "
                                   f"{_words(CURVE_METRICS[1])} against simulated time (s), {per}, {over}{refs}.")
    clip = "; log scale, a band's lower edge clipped at the axis' bottom where mean − std falls below it"
    out["consensus_timeline"] = (f"Consensus error (RMS spread of the maps' parameters, eq. CE-1) against simulated "
                                 f"time (s), {per}, {over}{clip}.")
    out["consensus_weighted_timeline"] = (f"Consensus error weighted by eq. 19 (CE-2, the disagreement RAMEN's "
                                          f"penalty sees) against simulated time (s), {per}, {over}{clip}.")
    return out


def _timeline_figures(root: Path, records: Sequence[Any], metrics: Mapping[str, Any], keys: Sequence[str],
                      axes: Mapping[str, list[Any]], title: str, formats: Sequence[str]) -> list[Path]:
    """The consensus error (each key of :data:`_CONSENSUS_FIGURES`) over simulated time, one
    line per condition (the swept keys other than the seed), mean ± std over seeds at each
    probe time; written only for sweeps whose runs communicate (the metrics'
    ``consensus_timeline``). ``metrics``: each completed run's metrics.json, by name."""
    varying = [k for k in keys if len(axes.get(k, [])) > 1]
    curves: dict[str, dict[str, dict[float, list[float]]]] = {key: {} for key, _ in _CONSENSUS_FIGURES}
    for rec in records:
        run = metrics.get(rec.name)
        timeline = run.get("consensus_timeline") if isinstance(run, Mapping) else None
        if not isinstance(timeline, list) or not timeline:
            continue
        label = condition_words(rec.axes, varying) if varying else title
        for probe in timeline:
            if not isinstance(probe, Mapping):
                continue
            for key, by_label in curves.items():
                if isinstance(probe.get(key), numbers.Real):
                    by_label.setdefault(label, {}).setdefault(float(probe["t"]), []).append(float(probe[key]))
    out: list[Path] = []
    for key, stem in _CONSENSUS_FIGURES:
        by_label = curves[key]
        if not by_label or len(by_label) > MAX_TIMELINES:
            continue
        order = {condition_words(r.axes, varying): condition_sort_key(r.axes, varying, axes) for r in records}
        pts = {label: [(t, float(np.mean(v)), float(np.std(v))) for t, v in by_label[label].items()]
               for label in sorted(by_label, key=lambda lb: order.get(lb, ()))}
        out += save_figure(plot_timelines(pts, key, title=title,
                                          legend_title=condition_title(varying) if varying else None),
                           root / "plots" / stem, formats)
    return out


def _varies_along(records: Sequence[Any], metric: str, key: str) -> bool:
    """Whether ``metric`` changes with ``key`` on some trial: among the completed runs that share
    every other setting (method, seed, layout, ...), some two with different values of ``key``
    report different values. A metric set by the trial alone, such as own coverage against the
    success rate (the camera paths do not depend on the channel), draws a flat line that says
    nothing about the axis; judged per trial, not on means, so that a partly run sweep, where
    the values of ``key`` have different trials done, does not make it look as if it moved."""
    trials: dict[str, set[tuple[float, ...]]] = {}
    for r in records:
        vals = r.values.get(metric) if r.status in store.COMPLETE else None
        if vals:
            other = repr(sorted((k, repr(v)) for k, v in r.axes.items() if k != key))
            trials.setdefault(other, set()).add(tuple(round(float(v), 9) for v in vals))
    return any(len(v) > 1 for v in trials.values())


def _progress_line(plan: Mapping[str, Any], records: Sequence[Any]) -> str:
    """"N of M planned runs done" and the names of the points not done (at most 12)."""
    planned = [p["name"] for p in plan.get("points", []) if isinstance(p, Mapping) and "name" in p]
    done = {r.name for r in records if r.status in store.COMPLETE}
    failed = [r.name for r in records if r.status not in store.COMPLETE]
    todo = [n for n in planned if n not in done and n not in failed]
    line = f"{len(done)} of {len(planned) or len(records)} planned runs done"
    if failed:
        line += f"; {len(failed)} failed: {', '.join(failed[:12])}{' ...' if len(failed) > 12 else ''}"
    if todo:
        line += f"; {len(todo)} not run yet: {', '.join(todo[:12])}{' ...' if len(todo) > 12 else ''}"
    return line + "."


def make_report(sweep_dir: str | Path, metrics: Sequence[str] | None = None,
                formats: Sequence[str] = ("png", "svg"), digits: int = 2,
                references: Sequence[str | Path] = (), html: str = "embedded", style: str = "default",
                width: str = "column") -> Report:
    """Aggregate the committed runs of ``sweep_dir`` and (re)write its tables and plots;
    ``references``: sweep folders whose local and centralised runs are drawn beside the
    completion over time and give the centralised run of a trial for the time to consensus;
    ``html``: ``"embedded"`` (report.html self-contained) or ``"linked"`` (its figures read from
    ``plots/``).

    ``style="paper"``: the figures for a paper, each ``width`` wide (``column``: 3.5 in, ``page``:
    7 in; :data:`ramensim.evaluation.plots.PAPER_WIDTHS_IN`) as PDF, SVG and a 300-dpi PNG (for
    report.html), 8-pt fonts, no title (the sweep's description, :func:`sweep_description`, opens
    every caption; ``plots/captions.md`` holds them), one colour per method in every figure
    (:func:`ramensim.evaluation.plots.method_colour`), a success-rate axis on a log scale when
    its values span more than a decade, the mean over trials of the runs' team means with 95 %
    Student t bands (the intervals of ``summary.md``; one trial: no band), and a hollow marker
    (a hatched bar) with a footnote letter wherever robots diverged or failed, the caption naming
    how many and which; the tables print a value that rests on one number alone, not ``± 0``."""
    if html not in HTML_MODES:
        raise ValueError(f"html={html!r}: expected one of {', '.join(HTML_MODES)}")
    from ramensim.evaluation.plots import PAPER_WIDTHS_IN

    if style not in STYLES:
        raise ValueError(f"style={style!r}: expected one of {', '.join(STYLES)}")
    if style == "paper" and width not in PAPER_WIDTHS_IN:
        raise ValueError(f"width={width!r}: expected one of {', '.join(PAPER_WIDTHS_IN)}")
    paper = style == "paper"
    root = Path(sweep_dir)
    plan, records = load_runs(root)
    axes = {k: list(v) for k, v in (plan.get("axes") or {}).items()}
    keys = group_axes(axes)
    rows, names = aggregate(records, axes, metrics)
    metrics_by_run = {r.name: store.read_json(root / store.RUNS / r.name / store.METRICS)
                      for r in records if r.status in store.COMPLETE}  # read once: hosts, figures
    over_trials = summarize(records, axes, rows, names, metrics_by_run)
    add_to_rows(over_trials, rows)
    csv_text, md_text = summary_tables(rows, keys, names, digits=digits, extra_csv=csv_columns(over_trials),
                                       single_alone=paper)
    trials_md = markdown(over_trials, keys, digits)
    title = plan.get("name") or root.name
    progress = _progress_line(plan, records)
    description = sweep_description(plan, root) if paper else ""
    header = (f"# Sweep {title}\n\n" + (f"{description}\n\n" if paper else "") + f"{progress}\n\nMean ± std over "
              f"agents and seeds per point; {len(records)} runs read."
              + (" A cell without ± rests on one value (n = 1)." if paper else "") + "\n\n")
    rep = Report(rows=rows, metrics=names, progress=progress, trials=over_trials)
    for name, text in (("summary.csv", csv_text),
                       ("summary.md", header + md_text + (f"\n{trials_md}" if trials_md else "")),
                       ("runs.csv", run_table(records, keys, names))):
        store.atomic_write_text(root / name, text)
        rep.tables.append(root / name)
    plot_metrics = [m for m in (metrics or PRIMARY_METRICS) if m in names] or names[:3]
    if not metrics:  # the completion ratio first (Fig. 5, Fig. 7), then the rest as found
        plot_metrics.sort(key=lambda m: PANEL_ORDER.index(m) if m in PANEL_ORDER else len(PANEL_ORDER))
    drawn_metrics: dict[str, list[str]] = {}
    if not rows or not plot_metrics:
        log.warning("sweep %s: no completed run with metrics yet; tables written, no figures", title)
        return rep
    if paper:
        return _paper_report(rep, root, plan, records, axes, keys, rows, names, metrics, metrics_by_run,
                             over_trials, formats, references, html, width, title, progress, description, digits)
    plots = root / "plots"
    for key in keys:
        values = axes[key]
        if len(values) < 2:
            continue
        others = [k for k in keys if k != key and len(axes[k]) > 1]
        n_groups = len({tuple(str(r.get(k)) for k in others) for r in rows})
        if n_groups > MAX_GROUPS:
            log.warning("sweep %s: %d combinations of %s are too many lines for one figure; skipped the "
                        "%s figure (run 'ramensim report' on a smaller sweep)", title, n_groups, others, key)
            continue
        if _numeric(values):
            drawn = plot_metrics if metrics else [m for m in plot_metrics if _varies_along(records, m, key)]
            if drawn and len(drawn) < len(plot_metrics):
                log.info("sweep %s: %s left out of the %s figure: the same at every value of it",
                         title, ", ".join(m for m in plot_metrics if m not in drawn), key)
            fig = plot_metric_lines(rows, key, drawn or plot_metrics, series_keys=others, title=title)
            rep.figures += save_figure(fig, plots / f"vs_{_safe(key)}", formats)
            drawn_metrics[f"vs_{_safe(key)}"] = list(drawn or plot_metrics)
        else:
            fig = plot_metric_bars(rows, plot_metrics, category_key=key, hue_keys=others, title=title)
            rep.figures += save_figure(fig, plots / f"bars_{_safe(key)}", formats)
            drawn_metrics[f"bars_{_safe(key)}"] = list(plot_metrics)
    rep.figures += _timeline_figures(root, records, metrics_by_run, keys, axes, title, formats)
    tc = write_timecourse(root, records, keys, title, formats, [Path(r) for r in references], metrics_by_run)
    rep.tables += [f for f in tc.files if f.suffix in (".csv", ".md")]
    rep.figures += [f for f in tc.files if f.suffix not in (".csv", ".md")]
    rep.missing_timeline = tc.missing_timeline
    if not any(f.stem.startswith(("vs_", "bars_")) for f in rep.figures):  # only seeds vary: one bar per metric
        by = keys[0] if keys else None
        fig = plot_metric_bars(rows, plot_metrics, category_key=by or "sweep", title=title) if by else \
            plot_metric_bars([{**r, "sweep": title} for r in rows], plot_metrics, "sweep", title=title)
        rep.figures += save_figure(fig, plots / "bars", formats)
        drawn_metrics["bars"] = list(plot_metrics)
    rep.captions = captions(axes, keys, drawn_metrics, tc.trials, tc.drawn_references)
    rep.tables.append(write_html(root, title, progress, rows, keys, table_metrics(names), records, tc.ttc_rows,
                                 embed=html == "embedded", captions=rep.captions, axes=axes,
                                 fixed=plan.get("set") or {}, trials=over_trials, digits=digits))
    log.info("sweep %s: wrote %d tables and %d figure files under %s", title, len(rep.tables),
             len(rep.figures), root)
    return rep


# --- the paper style ------------------------------------------------------------------------

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
