"""Figures of aggregated results (matplotlib, Agg, no pyplot state): metric vs a swept number
with mean ± std bands (paper Fig. 5: vs communication success rate; Fig. 7: vs number of
agents), and per-method bars with std error bars (paper Table I).

Input rows are dicts with the swept keys and ``M_mean`` / ``M_std`` per metric ``M``. Keys
and metrics are labelled in words (:func:`metric_label`, :func:`key_words`), values of
fractions such as the success rate as percentages (:func:`format_value`: 0.2 -> ``20 %``), and
conditions are drawn in the order of their values (:func:`value_order`).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import matplotlib
import numpy as np
from matplotlib.figure import Figure  # a bare Figure renders with Agg; no pyplot, no global backend
from matplotlib.ticker import MaxNLocator

_LABELS = {
    "artifacts_cm": "Artifacts (cm) ↓",
    "holes_cm": "Holes (cm) ↓",
    "completion_ratio_pct": "Completion ratio (%) ↑",
    "consensus_error": "Consensus error (RMS)",
    "consensus_error_peak": "Consensus error, peak (RMS)",
    "consensus_error_weighted": "Consensus error, eq. 19-weighted (RMS)",
    "consensus_error_weighted_peak": "Consensus error, eq. 19-weighted, peak (RMS)",
    "own_coverage_pct": "Own coverage (%)",
    "completion_own_pct": "Completion, own part (%) ↑",
    "completion_unseen_pct": "Completion, part only teammates saw (%) ↑",
    "holes_own_cm": "Holes, own part (cm) ↓",
    "holes_unseen_cm": "Holes, part only teammates saw (cm) ↓",
    "completion_far_pct": "Completion, far part (%) ↑",
    "holes_far_cm": "Holes, far part (cm) ↓",
    "channel.success_rate": "Communication success rate (%)",
    "success_rate": "Communication success rate (%)",
    "agents.count": "Number of agents",
    "method": "Method",
    "communication.delivered_fraction": "Messages delivered (%)",
    "communication.bytes_sent": "Bytes sent",
    "communication.bytes_delivered": "Bytes delivered",
    "communication.sent": "Messages sent",
    "communication.delivered": "Messages delivered",
    "bytes_sent": "Bytes sent",
    "bytes": "Bytes",
    "team_coverage_pct": "Team coverage (%)",
    "wall_time_s": "Wall time (s)",
    "sim_time_s": "Simulated time (s)",
    "runs": "Runs",
    "failed": "Failed",
}

_WORDS = {
    "seed": "run seed",
    "world.scene.seed": "scene layout",
    "world.scene.name": "scene",
    "world.trajectory.seed": "camera path seed",
    "channel.seed": "channel seed",
    "channel.success_rate": "communication success rate",
    "agents.count": "number of agents",
    "agents.compute.jitter": "compute-time jitter",
    "method": "method",
}
"""Swept keys in words, for captions and legend titles (others: their last part, ``_`` as a space)."""

FRACTION_KEYS = ("success_rate", "delivered_fraction")
"""Keys (by their last part) whose values are fractions in [0, 1], shown as percentages."""


def metric_label(key: str) -> str:
    """Axis/column label of a metric or swept key, with its unit where known."""
    if key in _LABELS:
        return _LABELS[key]
    words = key_words(key)
    return words[:1].upper() + words[1:]


def key_words(key: str) -> str:
    """A swept key in words, lower case, no unit: ``channel.success_rate`` -> ``communication
    success rate``, ``world.scene.seed`` -> ``scene layout``, ``consensus.ramen.rho`` -> ``rho``."""
    if key in _WORDS:
        return _WORDS[key]
    return key.rsplit(".", 1)[-1].replace("_", " ")


def is_fraction_key(key: str) -> bool:
    """Whether ``key``'s values are fractions in [0, 1] shown as percentages."""
    return key.rsplit(".", 1)[-1] in FRACTION_KEYS


def format_value(key: str, value: Any) -> str:
    """One value of ``key`` as a reader wants it: a fraction as a percentage (``0.05`` -> ``5 %``),
    other numbers as written (``1e-05``, ``4``), names as they are."""
    if is_fraction_key(key) and isinstance(value, (int, float)) and not isinstance(value, bool) \
            and 0.0 <= float(value) <= 1.0:
        return f"{100.0 * float(value):.4g} %"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def value_order(key: str, values: Sequence[Any]) -> list[Any]:
    """``values`` of ``key`` in the order a reader scans them: numbers sorted, fractions such as
    the success rate from 100 % down (the paper's Fig. 5 reads that way), others ascending;
    names (methods, scenes) in the order given."""
    nums = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
    if len(nums) != len(values):
        return list(values)
    return sorted(values, key=float, reverse=is_fraction_key(key))


def _is_percent_axis(key: str, xs: Sequence[float]) -> bool:
    return is_fraction_key(key) and all(0.0 <= x <= 1.0 for x in xs)


def _series_label(row: Mapping[str, Any], series_keys: Sequence[str]) -> str:
    """A line's or bar group's legend entry: its values of ``series_keys`` in words
    (``20 %, ramen``); the legend's title names the keys."""
    if not series_keys:
        return "all"
    return ", ".join(format_value(k, row.get(k)) for k in series_keys)


def _sorted_rows(rows: Sequence[Mapping[str, Any]], keys: Sequence[str]) -> list[Mapping[str, Any]]:
    """``rows`` ordered by :func:`value_order` of each key in turn (the first key slowest)."""
    out = list(rows)
    for key in reversed(list(keys)):
        seen: list[Any] = []
        for r in out:  # distinct values in order of appearance, by equality (a swept block is a dict)
            if r.get(key) not in seen:
                seen.append(r.get(key))
        order = value_order(key, seen)
        out.sort(key=lambda r: order.index(r.get(key)) if r.get(key) in order else len(order))
    return out


def _finite(v: Any) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return math.nan
    return f


def plot_metric_lines(rows: Sequence[Mapping[str, Any]], x_key: str, metrics: Sequence[str],
                      series_keys: Sequence[str] = ("method",), title: str | None = None) -> Figure:
    """One panel per metric (two panels a row, large: the figure a reader of Fig. 5 / Fig. 7
    looks for first): mean vs ``x_key`` with a ±std band, one line per combination of
    ``series_keys``. Success rates in [0, 1] are shown in percent."""
    n = max(1, len(metrics))
    cols = 1 if n == 1 else 2
    nrows = (n + cols - 1) // cols
    fig = Figure(figsize=(5.6 * cols + 1.6, 4.0 * nrows + 0.4), layout="constrained")
    grid = fig.subplots(nrows, cols, squeeze=False)
    axs = list(grid.ravel())
    for ax in axs[n:]:
        ax.set_visible(False)
    series: dict[str, list[Mapping[str, Any]]] = {}
    for row in _sorted_rows(rows, series_keys):
        series.setdefault(_series_label(row, series_keys), []).append(row)
    all_x = [_finite(r.get(x_key)) for r in rows]
    integer_x = all(isinstance(r.get(x_key), (int, np.integer)) and not isinstance(r.get(x_key), bool)
                    for r in rows)
    scale = 100.0 if _is_percent_axis(x_key, [x for x in all_x if math.isfinite(x)]) else 1.0
    for ax, metric in zip(axs, metrics):
        for label, srows in series.items():
            pts = sorted(((_finite(r.get(x_key)) * scale, _finite(r.get(f"{metric}_mean")),
                           _finite(r.get(f"{metric}_std"))) for r in srows), key=lambda t: t[0])
            pts = [p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1])]
            if not pts:
                continue
            xs = [p[0] for p in pts]
            ms = [p[1] for p in pts]
            ss = [p[2] if math.isfinite(p[2]) else 0.0 for p in pts]
            line = ax.plot(xs, ms, marker="o", label=label)[0]
            ax.fill_between(xs, [m - s for m, s in zip(ms, ss)], [m + s for m, s in zip(ms, ss)],
                            color=line.get_color(), alpha=0.2, linewidth=0)
        ax.set_xlabel(metric_label(x_key))
        ax.set_ylabel(metric_label(metric))
        ax.grid(True, alpha=0.3)
        if integer_x:
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        if scale == 100.0:
            ax.invert_xaxis()  # the paper reads from 100 % (synchronous) down to 20 %
    if len(series) > 1:
        handles, labels = axs[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside right upper", fontsize="small", title=_legend_title(series_keys))
    if title:
        fig.suptitle(title)
    return fig


def plot_metric_bars(rows: Sequence[Mapping[str, Any]], metrics: Sequence[str], category_key: str = "method",
                     hue_keys: Sequence[str] = (), title: str | None = None) -> Figure:
    """One panel per metric (at most three a row): a bar per ``category_key`` value (grouped by
    the combination of ``hue_keys``) at its mean, with a ±std error bar (paper Table I as a figure)."""
    n = max(1, len(metrics))
    cols = min(n, 3)
    nrows = (n + cols - 1) // cols
    fig = Figure(figsize=(4.6 * cols + (1.6 if hue_keys else 0.0), 3.6 * nrows + 0.4), layout="constrained")
    axs = list(fig.subplots(nrows, cols, squeeze=False).ravel())
    for ax in axs[n:]:
        ax.set_visible(False)
    cats: list[str] = []
    hues: list[str] = []
    rows = _sorted_rows(rows, [category_key, *hue_keys])
    for row in rows:
        c, h = format_value(category_key, row.get(category_key)), _series_label(row, hue_keys)
        if c not in cats:
            cats.append(c)
        if h not in hues:
            hues.append(h)
    width = 0.8 / max(1, len(hues))
    for ax, metric in zip(axs, metrics):
        for j, hue in enumerate(hues):
            xs, ms, ss = [], [], []
            for row in rows:
                if _series_label(row, hue_keys) != hue:
                    continue
                m = _finite(row.get(f"{metric}_mean"))
                s = _finite(row.get(f"{metric}_std"))
                xs.append(cats.index(format_value(category_key, row.get(category_key))) - 0.4 + width * (j + 0.5))
                ms.append(m if math.isfinite(m) else 0.0)
                ss.append(s if math.isfinite(s) else 0.0)
            ax.bar(xs, ms, width=width, yerr=ss, capsize=3, label=hue if hue_keys else None)
        ax.set_xticks(range(len(cats)), cats, rotation=30 if len(cats) > 4 else 0,
                      ha="right" if len(cats) > 4 else "center")
        ax.set_xlabel(metric_label(category_key))
        ax.set_ylabel(metric_label(metric))
        ax.grid(True, axis="y", alpha=0.3)
    if hue_keys and len(hues) > 1:
        handles, labels = axs[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside right upper", fontsize="small", title=_legend_title(hue_keys))
    if title:
        fig.suptitle(title)
    return fig


def _legend_title(keys: Sequence[str]) -> str:
    """What a legend's entries are: the swept keys in words, in the entries' order
    (``Communication success rate, method``; the entries read ``20 %, ramen``)."""
    text = ", ".join(key_words(k) for k in keys)
    return text[:1].upper() + text[1:]


def save_figure(fig: Figure, stem: str | Path, formats: Sequence[str] = ("png", "svg"), dpi: int = 150) -> list[Path]:
    """Write ``stem.png`` / ``stem.svg`` / ``stem.pdf`` (deterministic: no date metadata, fixed SVG id
    salt; a PDF without its creation date)."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    with matplotlib.rc_context({"svg.hashsalt": "ramensim"}):
        for fmt in formats:
            path = stem.parent / f"{stem.name}.{fmt}"
            meta = ({"Date": None} if fmt == "svg" else {"CreationDate": None} if fmt == "pdf"
                    else {"Software": None} if fmt == "png" else None)
            fig.savefig(path, format=fmt, dpi=dpi, metadata=meta)
            paths.append(path)
    return paths


def log_band_floor(curves: Mapping[str, Sequence[tuple[float, float, float]]]) -> float:
    """Lower edge of a log axis drawn with ±std bands: half the smallest positive mean shown.
    A band whose mean − std is at or below zero is clipped there, instead of reaching down to
    1e-12 and squashing every line into the top of the figure; nan when no mean is positive."""
    means = [m for pts in curves.values() for _, m, _ in pts if math.isfinite(m) and m > 0]
    return 0.5 * min(means) if means else math.nan


def plot_timelines(curves: Mapping[str, Sequence[tuple[float, float, float]]], y_key: str,
                   title: str | None = None, log_y: bool = True, legend_title: str | None = None) -> Figure:
    """One line per label: ``(t, mean, std)`` points of a quantity over simulated time (s),
    with a ±std band (e.g. the consensus error of each method / success rate, mean over
    seeds). Log scale by default: the consensus error spans decades; there the bands are
    clipped at :func:`log_band_floor`, the axis' lower edge."""
    fig = Figure(figsize=(7.2, 3.8), layout="constrained")
    ax = fig.subplots()
    colour, style = _line_styles(list(curves))
    floor = log_band_floor(curves) if log_y else math.nan
    for label, pts in curves.items():
        pts = sorted(p for p in pts if all(math.isfinite(v) for v in p))
        if not pts:
            continue
        ts, ms, ss = zip(*pts)
        line = ax.plot(ts, ms, label=label, color=colour[label], linestyle=style[label])[0]
        lo = [max(m - s, floor) if math.isfinite(floor) else m - s for m, s in zip(ms, ss)]
        ax.fill_between(ts, lo, [m + s for m, s in zip(ms, ss)], color=line.get_color(), alpha=0.2, linewidth=0)
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel(metric_label(y_key))
    if log_y:
        ax.set_yscale("log")
        if math.isfinite(floor):
            ax.set_ylim(bottom=floor)
    ax.grid(True, alpha=0.3, which="both")
    if curves:
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), title=legend_title)
    if title:
        fig.suptitle(title)
    return fig


def plot_timeline_panels(panels: Mapping[str, Mapping[str, Sequence[tuple[float, float, float]]]],
                         title: str | None = None, legend_title: str | None = None) -> Figure:
    """One panel per metric (e.g. completion and unseen-part completion, %), each with one line
    per label of ``(t, mean, std)`` points over simulated time (s) and a ±std band; labels ending
    in "(reference)" (local, centralised from another sweep) are drawn thin and grey-dashed.
    Linear y: completion ratios are percentages."""
    n = max(len(panels), 1)
    fig = Figure(figsize=(5.0 * n + 2.4, 4.0), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
    labels = list(dict.fromkeys(lb for lines in panels.values() for lb in lines))
    colour, style = _line_styles([lb for lb in labels if not lb.endswith("(reference)")])
    for ax, (metric, lines) in zip(axes, panels.items()):
        for label, pts in lines.items():
            pts = sorted(p for p in pts if all(math.isfinite(v) for v in p))
            if not pts:
                continue
            ts, ms, ss = zip(*pts)
            if label.endswith("(reference)"):
                kw = dict(color="0.35", linestyle="--" if label.startswith("centralised") else ":", linewidth=1.2)
            else:
                kw = dict(color=colour[label], linestyle=style[label], linewidth=1.6)
            line = ax.plot(ts, ms, label=label, **kw)[0]
            ax.fill_between(ts, [m - s for m, s in zip(ms, ss)], [m + s for m, s in zip(ms, ss)],
                            color=line.get_color(), alpha=0.15, linewidth=0)
        ax.set_xlabel("simulated time (s)")
        ax.set_ylabel(metric_label(metric))
        ax.grid(True, alpha=0.3)
    handles, names = axes[0].get_legend_handles_labels()
    if handles:
        axes[-1].legend(handles, names, fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0),
                        title=legend_title)
    if title:
        fig.suptitle(title)
    return fig


def _line_styles(labels: Sequence[str]) -> tuple[dict[str, Any], dict[str, str]]:
    """Colour and line style per label ``"a, b, ..., method"``: the colour tells the leading
    part (a condition such as the success rate, from a sequential colour map), the line style
    the last part (the method), so that many lines stay distinguishable (a 10-colour cycle
    repeats after ten)."""
    from matplotlib import colormaps

    heads = list(dict.fromkeys(lb.rsplit(", ", 1)[0] if ", " in lb else lb for lb in labels))
    tails = list(dict.fromkeys(lb.rsplit(", ", 1)[1] if ", " in lb else "" for lb in labels))
    cmap = colormaps["viridis" if len(heads) > 10 else "tab10"]
    styles = ["-", "--", ":", "-."]
    colour, style = {}, {}
    for lb in labels:
        head, tail = lb.rsplit(", ", 1) if ", " in lb else (lb, "")
        k = heads.index(head)
        colour[lb] = cmap(k / max(len(heads) - 1, 1) * 0.9) if len(heads) > 10 else cmap(k % 10)
        style[lb] = styles[tails.index(tail) % len(styles)]
    return colour, style
