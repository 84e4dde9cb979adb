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
import numbers
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ramensim.evaluation.plots import plot_metric_bars, plot_metric_lines, plot_timelines, save_figure
from ramensim.sweep import store
from ramensim.sweep.aggregate import (PRIMARY_METRICS, aggregate, group_axes, load_runs, run_table,
                                      summary_tables, table_metrics)
from ramensim.sweep.html import write_html
from ramensim.sweep.trials import add_to_rows, csv_columns, markdown, summarize
from ramensim.sweep.timecourse import condition_sort_key, condition_title, condition_words, write_timecourse
# the paper style and the shared vocabulary, re-exported: callers import them from here
from ramensim.sweep.paper_report import STYLES, _PaperData, _paper_report, sweep_description  # noqa: F401
from ramensim.sweep.report_common import (HTML_MODES, MAX_GROUPS, MAX_TIMELINES, PANEL_ORDER,  # noqa: F401
                                          _CONSENSUS_FIGURES, Report, _numeric, _safe, captions)

log = logging.getLogger(__name__)

REPORT_OPTIONS = "report.json"
"""The options a folder's report was last drawn with (:func:`make_report`'s arguments, the
references relative to the folder), so that it can be redrawn the same way
(:func:`ramensim.sweep.archive.redraw_report`)."""


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
    store.atomic_write_json(root / REPORT_OPTIONS, {
        "metrics": list(metrics) if metrics else None, "formats": list(formats), "digits": digits,
        "references": [Path(os.path.relpath(Path(r).resolve(), root.resolve())).as_posix() for r in references],
        "html": html, "style": style, "width": width})
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
