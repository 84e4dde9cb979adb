"""A sweep's report as one self-contained HTML page (``report.html``), viewable offline.

Written by ``ramensim report`` beside ``summary.md``: the sweep's name, progress (runs done of
planned, the missing ones) and what it sweeps, in words; the figures of the metrics against each
swept number first and full width (Fig. 5: against the success rate); the summary table (mean ±
std per condition, values and headers in words, fractions in percent, conditions in the order of
their values, the columns of :data:`TABLE_METRICS` so that it fits a 1400-px window), the time
to consensus, every other figure of ``plots/`` with its caption and links to its SVG / PDF
versions (``embed=True``, the default: as a PNG data URI, so no file
beside the page is needed; ``embed=False``: linked as ``plots/NAME.png``, a page of a few kB for
folders kept under version control, where the embedded copy would double the plots), the
scenario of each condition (the resolved ``scenario.yaml`` of its first finished run) and a
link to every run folder (relative, so they work when the sweep folder is opened where it lies).
"""
from __future__ import annotations

import base64
import html
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

from ramensim.evaluation.plots import format_value, is_fraction_key, key_words, metric_label, value_order
from ramensim.evaluation.tables import format_mean_std
from ramensim.sweep import store
from ramensim.sweep.spec import is_replicate_axis

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;max-width:1240px;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{font-size:1.25em;margin-top:2em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0;max-width:100%}
th,td{border:1px solid #ccc;padding:.25em .45em;text-align:right}td{white-space:nowrap}
th{background:#f3f3f3;font-weight:600}td:first-child,th:first-child{text-align:left}
td.wrap{white-space:normal;text-align:left}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}figure.lead img{width:100%}
figcaption{font-size:.9em;color:#444}figcaption a{margin-left:.4em}
pre{background:#f7f7f7;padding:.5em;font-size:.8em;overflow:auto;max-height:24em;white-space:pre-wrap;overflow-wrap:anywhere}
.note{color:#555;font-size:.9em}li{overflow-wrap:anywhere}
"""

PAPER_PX_PER_IN = 160
"""Pixels per inch of a paper-style figure on report.html (about 1.7x its printed size on a
96-px-per-inch screen, so 7-pt text reads as well as on paper)."""

TABLE_METRICS = ("completion_ratio_pct", "artifacts_cm", "holes_cm", "completion_unseen_pct", "completion_far_pct",
                 "consensus_error", "communication.delivered_fraction")
"""The metric columns of the page's results table, where the runs have them (the paper's three,
what communication brought, the consensus error, the share of messages delivered); the rest of
``summary.csv`` stays there, so the table fits a 1400-px window."""

_TTC_HEADERS = {"trials": "trials", "reached": "reached", "t_consensus_mean_s": "mean time to consensus (s)",
                "t_consensus_max_s": "latest (s)", "final_gap_to_centralised_pts": "final gap to centralised (points)",
                "per_trial_s": "per trial (s)"}


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return "–" if not math.isfinite(v) else f"{v:.4g}"
    return html.escape(str(v))


def _table(rows: Sequence[Mapping[str, Any]], cols: Sequence[str], headers: Mapping[str, str] | None = None,
           wrap: Sequence[str] = ()) -> str:
    head = "".join(f"<th>{html.escape((headers or {}).get(c, c))}</th>" for c in cols)
    body = "".join("<tr>" + "".join(f"<td{' class=wrap' if c in wrap else ''}>{_cell(r.get(c))}</td>" for c in cols)
                   + "</tr>" for r in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _mean_std(row: Mapping[str, Any], metric: str, single_alone: bool = False) -> str:
    """A results cell, ``mean ± std``; with ``single_alone`` a cell of one value (``M_n`` 1) shows
    the value alone (the paper style: no ``± 0`` for one run)."""
    m, s = row.get(f"{metric}_mean"), row.get(f"{metric}_std")
    if not isinstance(m, (int, float)) or not math.isfinite(m):
        return "–"
    s = s if isinstance(s, (int, float)) else None
    if single_alone and row.get(f"{metric}_n") == 1:
        s = None
    if is_fraction_key(metric):  # shown in percent, as its header says
        return format_mean_std(100.0 * m, None if s is None else 100.0 * s, 1)
    return format_mean_std(m, s)


def _figure(png: Path, embed: bool, caption: str, lead: bool = False, width_px: int | None = None) -> str:
    if embed:
        src = "data:image/png;base64," + base64.b64encode(png.read_bytes()).decode("ascii")
    else:
        src = html.escape(f"{png.parent.name}/{png.name}")  # relative to report.html, beside plots/
    vector = "".join(f"<a href='{html.escape(png.parent.name + '/' + png.stem + '.' + ext)}'>{ext.upper()}</a>"
                     for ext in ("svg", "pdf") if png.with_suffix("." + ext).is_file())
    size = f' style="width:min(100%,{width_px}px)"' if width_px else ""
    return (f'<figure{" class=lead" if lead else ""}><img alt="{html.escape(png.stem)}" src="{src}"{size}>'
            f"<figcaption>{html.escape(caption)}{vector}</figcaption></figure>")


def _describe(axes: Mapping[str, Sequence[Any]], fixed: Mapping[str, Any]) -> str:
    """One paragraph: what the sweep varies (each swept key in words with its values, in order),
    what a trial is, and what it fixes."""
    swept = [f"{key_words(k)} ({', '.join(format_value(k, v) for v in value_order(k, list(vs)))})"
             for k, vs in axes.items() if not is_replicate_axis(k)]
    seeds = [f"{key_words(k)} ({len(vs)})" for k, vs in axes.items() if is_replicate_axis(k)]
    parts = []
    if swept:
        parts.append("Swept: " + "; ".join(swept) + ".")
    if seeds:
        parts.append("Trials: " + " × ".join(seeds) + ".")
    if fixed:
        parts.append("Fixed for every run: " + ", ".join(f"{k} = {v}" for k, v in fixed.items()) + ".")
    return " ".join(parts)


def _trials_html(ts: Any, keys: Sequence[str], digits: int) -> str:
    """The interval table, the paired comparisons and the runs not counted or marked
    (``ramensim.sweep.trials``), values and keys in words."""
    from ramensim.sweep.trials import comparison_intro, comparison_table, intro, point_table

    if not ts.points:
        return ""
    cells, cols, headers = point_table(ts, keys, digits, value=format_value)
    parts = [f"<h2>95 % interval over trials</h2><p class='note'>{html.escape(intro(ts))}</p>",
             _table(cells, cols, {**{k: metric_label(k) for k in keys}, **headers})]
    if ts.comparisons:
        parts.append(f"<h2>Paired comparisons over trials</h2><p class='note'>{html.escape(comparison_intro(ts))}</p>")
        for comp in ts.comparisons:
            rows, ccols, cheads = comparison_table(ts, comp, digits, value=format_value, header=metric_label)
            words = key_words(comp.axis)
            parts.append(f"<h3>{html.escape(words[:1].upper() + words[1:])} against "
                         f"{html.escape(format_value(comp.axis, comp.reference))}</h3>" + _table(rows, ccols, cheads))
    if ts.notes:
        parts.append("<h2>Runs not counted or marked</h2><ul>"
                     + "".join(f"<li>{html.escape(name)}: {html.escape(why)}</li>" for name, why in ts.notes)
                     + "</ul>")
    return "".join(parts)


def write_html(root: Path, title: str, progress: str, rows: Sequence[Mapping[str, Any]], keys: Sequence[str],
               metrics: Sequence[str], records: Sequence[Any], ttc_rows: Sequence[Mapping[str, Any]],
               embed: bool = True, captions: Mapping[str, str] | None = None,
               axes: Mapping[str, Sequence[Any]] | None = None, fixed: Mapping[str, Any] | None = None,
               trials: Any = None, digits: int = 2, paper_width_in: float | None = None,
               description: str = "", robots_lost: Sequence[str] | None = None) -> Path:
    """Write ``root/report.html`` (see the module docstring) and return its path. ``captions``:
    figure stem -> caption (:func:`ramensim.sweep.report.captions`); ``axes`` and ``fixed``:
    the plan's axes and ``set``, said in words under the title; ``trials``: the
    :class:`ramensim.sweep.trials.TrialSummary` shown after the results table (each point's 95 %
    interval over trials, the paired comparisons, the runs not counted or marked), its numbers
    with ``digits`` decimals. The figures of metrics against a swept number (``vs_*``) come
    first, full width; the results table shows :data:`TABLE_METRICS` (every metric is in
    ``summary.csv``).

    ``paper_width_in`` (the paper style): each figure shown at :data:`PAPER_PX_PER_IN` px per inch
    of its width (a 3.5-in figure 560 px wide, never wider than the page), ``description`` under
    the title, and a results cell of one value without ``± 0``; ``robots_lost``: per row, how
    many of its robots diverged or failed (``7 of 18``), a column of the results table when any."""
    captions = captions or {}
    width_px = round(paper_width_in * PAPER_PX_PER_IN) if paper_width_in else None
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{_STYLE}</style></head><body><h1>Sweep {html.escape(title)}</h1>"
             f"<p>{html.escape(progress)}</p>"]
    if description:
        parts.append(f"<p>{html.escape(description)}</p>")
    if axes:
        parts.append(f"<p class='note'>{html.escape(_describe(axes, fixed or {}))}</p>")
    order = ("completion_over_time", "bars", "consensus_timeline", "consensus_weighted_timeline")
    pngs = sorted((root / "plots").glob("*.png"),
                  key=lambda p: (not p.stem.startswith("vs_"), not p.stem.startswith("bars_"),
                                 order.index(p.stem) if p.stem in order else len(order), p.stem))
    # the metrics against each swept number first; a sweep of names only (Table I): its bars
    lead = [p for p in pngs if p.stem.startswith("vs_")] or [p for p in pngs if p.stem.startswith("bars_")]
    for p in lead:
        key = p.stem.split("_", 1)[1]
        heading = f"Against the {key_words(key)}" if p.stem.startswith("vs_") else f"Per {key_words(key)}"
        parts.append(f"<h2>{html.escape(heading)}</h2>"
                     + _figure(p, embed, captions.get(p.stem, metric_label(key)), lead=True, width_px=width_px))
    shown = [m for m in TABLE_METRICS if m in metrics] or list(metrics)[:6]
    cells = [{**{k: format_value(k, r.get(k)) for k in keys}, "runs": r.get("runs"), "failed": r.get("failed"),
              **{m: _mean_std(r, m, single_alone=width_px is not None) for m in shown}} for r in rows]
    rest = len(metrics) - len(shown)
    parts.append("<h2>Results per condition</h2><p class='note'>Mean ± population std over agents and trials"
                 + ("; a cell without ± rests on one value (n = 1)" if width_px else "")
                 + (f"; {rest} more metrics (and every mean, std and count) in <a href='summary.csv'>summary.csv</a>, "
                    f"each run in <a href='runs.csv'>runs.csv</a>" if rest > 0 else "") + ".</p>")
    headers = {**{k: metric_label(k) for k in keys}, "runs": "runs", "failed": "failed",
               **{m: metric_label(m) for m in shown}}
    lost_col = []
    if robots_lost and any(robots_lost):
        for c, text in zip(cells, robots_lost):
            c["robots_lost"] = text
        lost_col, headers["robots_lost"] = ["robots_lost"], "robots diverged or failed"
    table = _table(cells, [*keys, "runs", "failed", *lost_col, *shown], headers)
    # the paper style: a table wider than a narrow window scrolls by itself, not the page
    parts.append(f"<div style='overflow-x:auto'>{table}</div>" if width_px else table)
    if trials is not None:
        parts.append(_trials_html(trials, keys, digits))
    if ttc_rows:
        parts.append("<h2>Time to consensus</h2><p class='note'>First evaluation after which a run's completion "
                     "stays within 5 points of the centralised run of its trial (s); never: outside at the end.</p>")
        cond = ", ".join(key_words(k) for k in [k for k in keys if k != "method"] + [k for k in keys if k == "method"])
        ttc = [{**r, "condition": r.get("label", r.get("condition"))} for r in ttc_rows]
        cols = ["condition", *[c for c in _TTC_HEADERS if c in ttc_rows[0]]]
        parts.append(_table(ttc, cols, {"condition": (cond[:1].upper() + cond[1:]) or "condition", **_TTC_HEADERS},
                            wrap=("per_trial_s",)))
    others = [p for p in pngs if p not in lead]
    if others:
        parts.append("<h2>Figures</h2>" + "".join(_figure(p, embed, captions.get(p.stem, metric_label(p.stem)),
                                                         width_px=width_px) for p in others))
    parts.append("<h2>Scenario of each condition</h2>")
    shown_cond: set[tuple] = set()
    for rec in records:
        cond_values = tuple(str(rec.axes.get(k)) for k in keys)
        yaml_path = root / store.RUNS / rec.name / "scenario.yaml"
        if cond_values in shown_cond or rec.status not in store.COMPLETE or not yaml_path.is_file():
            continue
        shown_cond.add(cond_values)
        label = ", ".join(f"{key_words(k)} {format_value(k, rec.axes.get(k))}" for k in keys) or title
        parts.append(f"<details><summary>{html.escape(label)} (from {html.escape(rec.name)})</summary>"
                     f"<pre>{html.escape(yaml_path.read_text(encoding='utf-8', errors='replace'))}</pre></details>")
    parts.append("<h2>Runs</h2><ul>")
    for rec in records:
        link = f"{store.RUNS}/{rec.name}/"
        err = f" — {html.escape(rec.error)}" if getattr(rec, "error", None) else ""
        parts.append(f"<li><a href='{html.escape(link)}'>{html.escape(rec.name)}</a>: "
                     f"{html.escape(rec.status)}{err}</li>")
    parts.append("</ul></body></html>")
    path = root / "report.html"
    store.atomic_write_text(path, "".join(parts))
    return path
