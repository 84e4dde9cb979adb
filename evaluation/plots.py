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
from dataclasses import dataclass, field
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


# --- the paper style (``ramensim report --style paper``) ---------------------------------------

PAPER_WIDTHS_IN = {"column": 3.5, "page": 7.0}
"""Figure widths of the paper style (inches): one journal column, the full page."""

METHOD_COLOURS = {"ramen": "#0072B2", "dinno": "#D55E00", "dsgd": "#009E73", "dsgt": "#CC79A7",
                  "local": "#7F7F7F", "centralised": "#000000"}
"""One colour per built-in method in every paper-style figure (Okabe-Ito, readable in grey and by
colour-blind readers): RAMEN blue, DiNNO vermillion, DSGD green, DSGT pink, local grey,
centralised black. Other methods get :func:`method_colour`'s hash-based colour."""

PAPER_FONT_PT = 8.0
"""Base font size of the paper style (points): labels 8 pt, ticks and legends 7 pt, legible in a
3.5-in column printed at 100 %."""


def method_colour(method: Any) -> str:
    """The colour of ``method`` (hex ``#rrggbb``) in every paper-style figure: the fixed
    :data:`METHOD_COLOURS` for the built-in methods, else a colour derived from the SHA-256 of
    the name (the same in every figure and every report), a hue kept away from the fixed ones'
    and mid lightness so that it reads on white."""
    import colorsys
    import hashlib

    name = str(method)
    if name in METHOD_COLOURS:
        return METHOD_COLOURS[name]
    h = hashlib.sha256(name.encode("utf-8")).digest()
    hue = (h[0] * 256 + h[1]) / 65536.0
    light = 0.35 + 0.15 * h[2] / 255.0
    r, g, b = colorsys.hls_to_rgb(hue, light, 0.75)
    return "#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in (r, g, b)))


def shade(colour: str, rank: int, count: int) -> str:
    """``colour`` lightened by its ``rank`` among ``count`` conditions drawn in one hue (rank 0:
    the colour itself; the last: mixed with 55 % white), so that the lines of one method at
    several success rates keep the method's hue."""
    from matplotlib.colors import to_rgb

    f = 0.55 * rank / (count - 1) if count > 1 else 0.0
    r, g, b = (c + (1.0 - c) * f for c in to_rgb(colour))
    return "#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in (r, g, b)))


def paper_rc() -> dict[str, Any]:
    """The matplotlib settings of the paper style: :data:`PAPER_FONT_PT` fonts, thin lines, fonts
    embedded in PDFs as TrueType (type 42, as journals ask) and SVG text as paths (renders the
    same everywhere)."""
    small = PAPER_FONT_PT - 1.0
    return {"font.size": PAPER_FONT_PT, "axes.labelsize": PAPER_FONT_PT, "axes.titlesize": PAPER_FONT_PT,
            "xtick.labelsize": small, "ytick.labelsize": small, "legend.fontsize": small,
            "legend.title_fontsize": small, "lines.linewidth": 1.2, "lines.markersize": 3.5,
            "axes.linewidth": 0.6, "xtick.major.width": 0.6, "ytick.major.width": 0.6,
            "xtick.minor.width": 0.4, "ytick.minor.width": 0.4, "grid.linewidth": 0.4,
            "legend.frameon": False, "legend.handlelength": 1.8, "legend.columnspacing": 1.0,
            "pdf.fonttype": 42, "svg.fonttype": "path", "svg.hashsalt": "ramensim",
            "figure.constrained_layout.h_pad": 0.02, "figure.constrained_layout.w_pad": 0.02}


def paper_width(width: str | float) -> float:
    """A paper-style width in inches: ``column`` (3.5), ``page`` (7) or a number of inches."""
    if isinstance(width, str):
        return PAPER_WIDTHS_IN[width]
    return float(width)


def percent_ticks(ax: Any, values_pct: Sequence[float], axis: str = "x", fmt: Any = None) -> str:
    """Put a success-rate axis (values in %) on the scale that separates them: log when the
    positive values span more than a decade (1 % and 5 % apart, not both on top of 0), symlog
    (linear below the smallest positive value) when one is 0, else linear; major ticks at the
    swept values, labelled ``5 %``, thinned where two labels would overlap at the axis' drawn
    width (the ends and the small values kept first). ``fmt``: a value's label (default ``5 %``;
    any swept number's axis can use this, e.g. rho from 1e-5 to 1e-3). Returns the scale used."""
    vals = sorted({float(v) for v in values_pct if math.isfinite(float(v))})
    pos = [v for v in vals if v > 0]
    scale = "linear"
    if len(pos) >= 2 and pos[-1] / pos[0] > 10.0:
        scale = "symlog" if vals[0] <= 0 else "log"
    set_scale = ax.set_xscale if axis == "x" else ax.set_yscale
    if scale == "symlog":
        set_scale("symlog", linthresh=pos[0], linscale=0.5)
    elif scale == "log":
        set_scale("log")
    the_axis = ax.xaxis if axis == "x" else ax.yaxis
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator

    the_axis.set_major_locator(FixedLocator(vals))
    the_axis.set_minor_locator(NullLocator())
    the_axis.set_minor_formatter(NullFormatter())
    labels = _thin_labels(ax, vals, scale, axis, fmt)
    (ax.set_xticklabels if axis == "x" else ax.set_yticklabels)(labels)
    return scale


def _thin_labels(ax: Any, vals: Sequence[float], scale: str, axis: str, fmt: Any = None) -> list[str]:
    """Tick labels of :func:`percent_ticks`: ``fmt(value)`` (default ``5 %``) at each value, blank
    where it would overlap a label kept before it (kept in order: the smallest, the largest, then
    from small to large)."""
    texts = [fmt(v) if fmt else f"{v:.4g} %" for v in vals]
    if len(vals) < 3:
        return texts
    fig = ax.get_figure()
    pos = ax.get_position()
    length_in = (pos.width * fig.get_figwidth()) if axis == "x" else (pos.height * fig.get_figheight())
    length_pt = max(length_in * 72.0, 1.0)
    size = float(matplotlib.rcParams["xtick.labelsize"] if isinstance(matplotlib.rcParams["xtick.labelsize"],
                                                                      (int, float)) else PAPER_FONT_PT - 1)

    def coord(v: float) -> float:
        if scale == "log":
            return math.log10(v)
        if scale == "symlog":
            lin = min(x for x in vals if x > 0)
            return (v / lin * 0.5 / math.log(10)) if abs(v) <= lin else (0.5 / math.log(10) + math.log10(v / lin))
        return v

    cs = [coord(v) for v in vals]
    span = (max(cs) - min(cs)) or 1.0
    at = [(c - min(cs)) / span * length_pt for c in cs]
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath

    font = FontProperties(size=size)
    measure = TextToPath()
    # half a label's drawn width (pt) and half a gap of 4 pt beside it
    half = [0.5 * measure.get_text_width_height_descent(t, font, ismath=False)[0] + 2.0 for t in texts]
    keep: list[int] = []
    for i in [0, len(vals) - 1, *range(1, len(vals) - 1)]:
        if all(abs(at[i] - at[j]) >= half[i] + half[j] for j in keep):
            keep.append(i)
    return [t if i in keep else "" for i, t in enumerate(texts)]


@dataclass
class PaperSeries:
    """One line of a paper-style figure: its legend label, colour, line style and marker, and per
    metric its points ``(x, estimate, lo, hi)`` (units of the metric; lo/hi NaN: no band) with the
    footnote letter of each x where robots diverged or failed (drawn hollow, the letter beside)."""
    label: str
    colour: str
    linestyle: str = "-"
    marker: str = "o"
    points: dict[str, list[tuple[float, float, float, float]]] = field(default_factory=dict)
    marks: dict[float, str] = field(default_factory=dict)


def paper_lines(series: Sequence[PaperSeries], x_key: str, metrics: Sequence[str], width: str | float = "column",
                legend_title: str | None = None, x_values: Sequence[float] = ()) -> Figure:
    """Metrics against a swept number at a journal width (:func:`paper_width`): one panel per
    metric (one column of panels at column width, up to three a row at page width, x shared),
    each series a line with its 95 % band (where it has one), a point where robots diverged or
    failed hollow with its footnote letter; success rates on :func:`percent_ticks`' axis, from
    100 % down. ``x_values``: the swept values (the ticks), in the units drawn."""
    w = paper_width(width)
    n = max(1, len(metrics))
    cols = 1 if w < 5 else min(n, 3)
    nrows = (n + cols - 1) // cols
    panel_h = 1.45 if cols == 1 else 1.9
    legend_rows = math.ceil(len(series) / max(1, _legend_cols(series, w))) if len(series) > 1 else 0
    with matplotlib.rc_context(paper_rc()):
        fig = Figure(figsize=(w, panel_h * nrows + 0.45 + 0.16 * legend_rows), layout="constrained")
        axs = list(fig.subplots(nrows, cols, squeeze=False, sharex=True).ravel())
        for ax in axs[n:]:
            ax.set_visible(False)
        percent = is_fraction_key(x_key)
        for ax, metric in zip(axs, metrics):
            for s in series:
                pts = [p for p in s.points.get(metric, []) if math.isfinite(p[0]) and math.isfinite(p[1])]
                if not pts:
                    ax.plot([], [], color=s.colour, linestyle=s.linestyle, marker=s.marker, label=s.label)
                    continue
                xs, ms, los, his = zip(*sorted(pts))
                ax.plot(xs, ms, color=s.colour, linestyle=s.linestyle, marker=s.marker, label=s.label,
                        markerfacecolor=s.colour, markeredgecolor=s.colour)
                band = [(x, lo, hi) for x, lo, hi in zip(xs, los, his) if math.isfinite(lo) and math.isfinite(hi)]
                if len(band) >= 2:
                    bx, blo, bhi = zip(*band)
                    ax.fill_between(bx, blo, bhi, color=s.colour, alpha=0.18, linewidth=0)
                for x, m in zip(xs, ms):
                    letter = s.marks.get(x)
                    if letter:
                        ax.plot([x], [m], linestyle="none", marker=s.marker, markersize=6.0, markerfacecolor="white",
                                markeredgecolor=s.colour, markeredgewidth=1.1, zorder=5)
                        ax.annotate(letter, (x, m), xytext=(3, 3), textcoords="offset points",
                                    fontsize=PAPER_FONT_PT - 1.0, color="0.1", fontstyle="italic", zorder=6)
            _lost_marks(ax, series, metric)
            if any(s.marks for s in series):
                ax.margins(y=0.14)  # room for a marked point's letter inside the frame
            ax.set_ylabel(_short_label(metric, panel_h * 72.0 - 6.0))
            ax.grid(True, alpha=0.3)
            ax.yaxis.set_major_locator(MaxNLocator(nbins=4))
        shown = list(axs[:n])
        for ax in shown[max(0, n - cols):]:  # the lowest panel of each column: its x label and ticks
            ax.set_xlabel(metric_label(x_key))
            ax.xaxis.set_tick_params(labelbottom=True)
        xs_all = sorted({float(v) for v in x_values}) or sorted({p[0] for s in series for ps in s.points.values()
                                                                   for p in ps})
        fmt = (lambda v: f"{v:.4g} %") if percent else (lambda v: format_value(x_key, int(v) if float(v).is_integer()
                                                                              and abs(v) < 1e6 else v))
        for ax in shown:
            if percent or len(xs_all) <= 10:
                percent_ticks(ax, xs_all, fmt=fmt)
            if percent:
                ax.invert_xaxis()  # from 100 % (synchronous) down, as the paper reads
        if len(series) > 1:
            handles, labels = axs[0].get_legend_handles_labels()
            fig.legend(handles, labels, loc="outside upper center", ncols=_legend_cols(series, w),
                       title=legend_title)
        if percent or len(xs_all) <= 10:  # a second pass: the axes' final widths are known once laid out
            fig.get_layout_engine().execute(fig)
            for ax in shown:
                ax.set_xticklabels(_thin_labels(ax, xs_all, ax.get_xscale(), "x", fmt))
    return fig


def _lost_marks(ax: Any, series: Sequence[PaperSeries], metric: str) -> None:
    """A point marked as troubled whose value is missing (every robot of every trial diverged or
    failed there): an ``x`` at the bottom of the panel at its x, in the series' colour, with its
    letter, so that a point left out is never silently absent."""
    from matplotlib.transforms import blended_transform_factory

    where = blended_transform_factory(ax.transData, ax.transAxes)
    stacked: dict[float, int] = {}
    for s in series:
        have = {p[0] for p in s.points.get(metric, []) if math.isfinite(p[1])}
        for x, letter in s.marks.items():
            if x in have or not math.isfinite(x):
                continue
            k = stacked[x] = stacked.get(x, -1) + 1  # several series lost at one x: one above the other
            y = 0.06 + 0.12 * k
            ax.plot([x], [y], transform=where, linestyle="none", marker="x", markersize=5.5,
                    markeredgecolor=s.colour, markeredgewidth=1.3, zorder=5, clip_on=False)
            ax.annotate(letter, (x, y), xycoords=where, xytext=(4, -2), textcoords="offset points",
                        fontsize=PAPER_FONT_PT - 1.0, color="0.1", fontstyle="italic", zorder=6)


def _legend_cols(series: Sequence[Any], width_in: float) -> int:
    """Columns of a legend above a figure ``width_in`` wide: as many entries as fit a row."""
    longest = max((len(getattr(s, "label", s)) for s in series), default=1)
    per = (longest * 0.55 * (PAPER_FONT_PT - 1) + 30) / 72.0  # inches per entry: text, handle, gap
    return max(1, min(len(series), int(width_in // per)))


def _short_label(metric: str, max_pt: float = 95.0) -> str:
    """A panel's y label in the paper style: the metric's label wrapped at word boundaries into
    lines no longer than ``max_pt`` points at :data:`PAPER_FONT_PT` (the panel's height), so
    that a label never runs past its panel into the next."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath

    font, measure = FontProperties(size=PAPER_FONT_PT), TextToPath()
    lines: list[str] = []
    words: list[str] = []
    for word in metric_label(metric).split(" "):
        if words and (word in ("↑", "↓") or word.startswith("(") and len(word) <= 5):
            words[-1] += "\u00a0" + word  # a unit and the better-direction arrow stay with their word
        else:
            words.append(word)
    for word in words:
        trial = f"{lines[-1]} {word}" if lines else word
        if lines and measure.get_text_width_height_descent(trial, font, ismath=False)[0] <= max_pt:
            lines[-1] = trial
        else:
            lines.append(word)
    return "\n".join(lines)


def paper_bars(categories: Sequence[str], groups: Sequence[PaperSeries], category_key: str,
               metrics: Sequence[str], width: str | float = "column", legend_title: str | None = None,
               colours: Mapping[str, str] | None = None) -> Figure:
    """Bars per category (x: index into ``categories``) at a journal width, one panel per metric;
    each group a bar in every category at its estimate with a 95 % error bar where it has one; a
    bar where robots diverged or failed hatched, its footnote letter above. ``colours``: a colour
    per category (the method's when the categories are methods), else the group's."""
    w = paper_width(width)
    n = max(1, len(metrics))
    cols = 1 if w < 5 else min(n, 3)
    nrows = (n + cols - 1) // cols
    panel_h = 1.35 if cols == 1 else 1.8
    rot = 30 if len(categories) > 3 and w < 5 or len(categories) > 6 else 0
    with matplotlib.rc_context(paper_rc()):
        fig = Figure(figsize=(w, panel_h * nrows + 0.35 + (0.25 if rot else 0)
                              + (0.16 * math.ceil(len(groups) / _legend_cols(groups, w)) if len(groups) > 1 else 0)),
                     layout="constrained")
        axs = list(fig.subplots(nrows, cols, squeeze=False, sharex=True).ravel())
        for ax in axs[n:]:
            ax.set_visible(False)
        bw = 0.8 / max(1, len(groups))
        for ax, metric in zip(axs, metrics):
            for j, g in enumerate(groups):
                for x, m, lo, hi in g.points.get(metric, []):
                    if not math.isfinite(m):
                        continue
                    cat = categories[int(x)]
                    colour = (colours or {}).get(cat, g.colour)
                    if colours and len(groups) > 1:
                        colour = shade(colour, j, len(groups))
                    letter = g.marks.get(x)
                    xx = x - 0.4 + bw * (j + 0.5)
                    err = [[m - lo], [hi - m]] if math.isfinite(lo) and math.isfinite(hi) else None
                    ax.bar([xx], [m], width=bw * 0.92, color="white" if letter else colour, edgecolor=colour,
                           hatch="////" if letter else None, linewidth=0.8, label=g.label if x == 0 else None)
                    if err is not None:
                        ax.errorbar([xx], [m], yerr=err, color="0.15", capsize=2, linewidth=0.8, capthick=0.8)
                    if letter:
                        ax.annotate(letter, (xx, hi if err is not None else m), xytext=(0, 2), textcoords="offset points",
                                    ha="center", fontsize=PAPER_FONT_PT - 1.0, fontstyle="italic", color="0.1")
            ax.set_ylabel(_short_label(metric, panel_h * 72.0 - 6.0))
            ax.grid(True, axis="y", alpha=0.3)
            ax.yaxis.set_major_locator(MaxNLocator(nbins=4))
            ax.margins(y=0.12)
        for ax in axs[:n]:
            ax.set_xticks(range(len(categories)), list(categories), rotation=rot, ha="right" if rot else "center")
        for ax in axs[max(0, n - cols):n]:
            ax.set_xlabel(metric_label(category_key))
            ax.xaxis.set_tick_params(labelbottom=True)
        if len(groups) > 1:
            handles, labels = axs[0].get_legend_handles_labels()
            fig.legend(handles, labels, loc="outside upper center", ncols=_legend_cols(groups, w), title=legend_title)
    return fig


def paper_timelines(panels: Mapping[str, Sequence[PaperSeries]], width: str | float = "column",
                    log_y: bool = False, legend_title: str | None = None) -> Figure:
    """Quantities over simulated time (s) at a journal width: one panel per metric (stacked at
    column width, side by side at page width), each series ``(t, estimate, lo, hi)`` with its 95 %
    band where it has one; a series whose label ends in "(reference)" drawn thin. Log y (the
    consensus error): a band's lower edge clipped at half the smallest estimate shown."""
    w = paper_width(width)
    n = max(1, len(panels))
    cols = 1 if w < 5 else n
    nrows = (n + cols - 1) // cols
    labels = list(dict.fromkeys(s.label for ss in panels.values() for s in ss))
    ncols = _legend_cols(labels, w)
    panel_h = 1.5 if cols == 1 else 2.0
    with matplotlib.rc_context(paper_rc()):
        fig = Figure(figsize=(w, panel_h * nrows + 0.4 + 0.15 * math.ceil(len(labels) / ncols)), layout="constrained")
        axs = list(fig.subplots(nrows, cols, squeeze=False, sharex=True).ravel())
        for ax, (metric, series) in zip(axs, panels.items()):
            ests = [p[1] for s in series for p in s.points.get(metric, []) if math.isfinite(p[1]) and p[1] > 0]
            floor = 0.5 * min(ests) if log_y and ests else math.nan
            for s in series:
                pts = sorted(p for p in s.points.get(metric, []) if math.isfinite(p[0]) and math.isfinite(p[1]))
                if not pts:
                    continue
                ts, ms, los, his = zip(*pts)
                ref = s.label.endswith("(reference)")
                letter = next(iter(s.marks.values()), None)
                ax.plot(ts, ms, color=s.colour, linestyle=s.linestyle, linewidth=0.9 if ref else 1.2,
                        label=f"{s.label} ({letter})" if letter else s.label)
                band = [(t, lo, hi) for t, lo, hi in zip(ts, los, his) if math.isfinite(lo) and math.isfinite(hi)]
                if len(band) >= 2 and not ref:
                    bt, blo, bhi = zip(*band)
                    if math.isfinite(floor):
                        blo = [max(v, floor) for v in blo]
                    ax.fill_between(bt, blo, bhi, color=s.colour, alpha=0.15 if len(series) <= 4 else 0.07,
                                    linewidth=0)
                if letter:  # the line ends in a hollow marker; its letter is in the legend
                    ax.plot([ts[-1]], [ms[-1]], linestyle="none", marker="o", markersize=5, markerfacecolor="white",
                            markeredgecolor=s.colour, markeredgewidth=1.0, zorder=5)
            ax.set_ylabel(_short_label(metric, panel_h * 72.0 - 6.0))
            ax.grid(True, alpha=0.3, which="major")
            if log_y:
                ax.set_yscale("log")
                if math.isfinite(floor):
                    ax.set_ylim(bottom=floor)
            else:
                ax.yaxis.set_major_locator(MaxNLocator(nbins=4))
        for ax in axs[n:]:
            ax.set_visible(False)
        for ax in axs[max(0, n - cols):n]:
            ax.set_xlabel("Simulated time (s)")
            ax.xaxis.set_tick_params(labelbottom=True)
        handles, names = axs[0].get_legend_handles_labels()
        if len(handles) > 1:
            fig.legend(handles, names, loc="outside upper center", ncols=ncols, title=legend_title)
    return fig


def save_paper_figure(fig: Figure, stem: str | Path, formats: Sequence[str] = ("pdf", "svg", "png")) -> list[Path]:
    """:func:`save_figure` with the paper style's settings (fonts embedded as TrueType in the PDF)
    and a 300-dpi PNG; the figure keeps the size it was drawn at (inches), no tight bounding box,
    so a PDF's MediaBox and an SVG's width are exactly the asked width."""
    import logging

    quiet = logging.getLogger("fontTools")  # its font subsetting logs every table of the PDF's font at INFO
    level = quiet.level
    quiet.setLevel(max(level, logging.WARNING))
    try:
        with matplotlib.rc_context(paper_rc()):
            return save_figure(fig, stem, formats, dpi=300)
    finally:
        quiet.setLevel(level)
