"""Completion over time for each archived paper-horizon experiment: per method the mean over
trials with its 95 % confidence band (the figures at the top of docs/RESULTS.md;
``ramensim paper figures``).

:func:`draw_all` reads every ``<experiment>/runs_timeline.csv`` under the results folder (one row
per run, written by ``ramensim report``: the sweep's axes, then the team completion, the mean over
the run's robots, at every periodic evaluation as ``completion_ratio_pct@<t>``) and writes
``<out>/<experiment>_completion.png``: one panel per condition (the sweep's axes other than
``method`` and the trials' run seed and layout, e.g. the success rate or the robot count), one
line per method.

The band at each evaluation time t is Student's t interval of the mean over the n trials with
a value there, taken over the independent units: the trials of one run seed (its house
layouts, which share its channel realisation and map initialisation) are averaged first (eq. U-1
of ``ramensim.evaluation.intervals``), then mean ± t(0.975, n - 1) · s / sqrt(n) over the n run
seeds, s the sample standard deviation (ddof 1) of their team completion (%). With one unit
there is no band. The interval is over units, not robots.
"""
from __future__ import annotations

import csv
import logging
import math
from collections import defaultdict
from pathlib import Path
from typing import Sequence

import numpy as np

from ramensim.core.errors import InputError
from ramensim.evaluation.intervals import nest

log = logging.getLogger(__name__)

PREFIX = "completion_ratio_pct@"
"""The runs_timeline.csv columns of the team completion (%) at an evaluation, ``<PREFIX><t s>``."""
TRIAL_AXES = ("seed", "world.scene.seed")
UNIT_AXIS = "seed"
"""The axis whose value is a trial's independent unit (the run seed)."""
"""Axes whose values are trials (repetitions), not conditions."""
LEVEL = 0.95
"""The confidence level of the band."""
COLOURS = {"ramen": "C0", "dinno": "C1", "centralised": "0.35", "local": "C4", "dsgd": "C2", "dsgt": "C3"}
"""One colour per method in every figure (others take the next free matplotlib colours)."""
COLUMNS = 4
"""Panels per row."""


def t_interval(values: Sequence[float], level: float = LEVEL) -> tuple[float, float, float]:
    """(mean, low, high) of ``values`` (%): Student's t interval of the mean at ``level``; low
    and high are NaN for fewer than two values."""
    from scipy import stats

    x = np.asarray([v for v in values if math.isfinite(v)], dtype=float)
    if x.size == 0:
        return math.nan, math.nan, math.nan
    mean = float(x.mean())
    if x.size < 2:
        return mean, math.nan, math.nan
    half = float(stats.t.ppf(0.5 + level / 2, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    return mean, mean - half, mean + half


def _float(text: str) -> float:
    """``text`` as a number, NaN where it is none (an empty cell)."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def read_timeline(path: Path, with_units: bool = False) -> tuple[list[str], list[float],
                                                                 dict[tuple[tuple[str, str], ...], dict[str, list[list]]]]:
    """The condition axes, the evaluation times (s) and, per condition and method, each trial's
    team completion at those times (%) from one ``runs_timeline.csv`` (``with_units``: each
    trial's list ends with its unit, the run seed as written); InputError naming the file when
    it is missing or has no method or completion columns."""
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected the runs_timeline.csv that 'ramensim report' writes "
                         f"into an archived sweep folder.")
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    header = list(rows[0]) if rows else []
    times_cols = [c for c in header if c.startswith(PREFIX)]
    if "method" not in header or not times_cols or "wall_time_s" not in header:
        raise InputError(f"{path}: expected the columns 'method', 'wall_time_s' and '{PREFIX}<t>' of "
                         f"'ramensim report''s runs_timeline.csv; found {', '.join(header[:8]) or 'no rows'}.")
    axes = header[header.index("name") + 1 if "name" in header else 0:header.index("wall_time_s")]
    conditions = [a for a in axes if a != "method" and a not in TRIAL_AXES]
    times = [_float(c[len(PREFIX):]) for c in times_cols]
    out: dict[tuple[tuple[str, str], ...], dict[str, list[list[float]]]] = defaultdict(lambda: defaultdict(list))
    for row in rows:
        key = tuple((a, row[a]) for a in conditions)
        values: list = [_float(row[c]) for c in times_cols]
        out[key][row["method"]].append(values + [row.get(UNIT_AXIS, "")] if with_units else values)
    return conditions, times, out


def _label(key: tuple[tuple[str, str], ...]) -> str:
    """A panel's title in words from its condition's axes and values."""
    parts = []
    for axis, value in key:
        v = _float(value)
        if axis == "channel.success_rate" and math.isfinite(v):
            parts.append(f"{100 * v:g} % success")
        elif axis == "agents.count":
            parts.append(f"{value} robots")
        elif axis == "agents.compute.jitter" and math.isfinite(v):
            parts.append("clocks in step" if v == 0 else f"clocks ±{100 * v:g} %")
        else:
            parts.append(f"{axis}={value}")
    return ", ".join(parts) or "all runs"


def _order(key: tuple[tuple[str, str], ...]) -> tuple[float, ...]:
    """Panels in reading order: success rates falling (as the paper's Fig. 5), other numbers rising."""
    return tuple(-_float(v) if a == "channel.success_rate" else _float(v) for a, v in key)


def draw(name: str, csv_path: Path, out: Path) -> Path:
    """Write ``out/<name>_completion.png`` from one experiment's runs_timeline.csv ``csv_path``
    (completion %, against simulated time s) and return its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    _, times, data = read_timeline(csv_path, with_units=True)
    keys = sorted(data, key=_order)
    rows, cols = math.ceil(len(keys) / COLUMNS), min(COLUMNS, len(keys))
    fig, grid = plt.subplots(rows, cols, figsize=(2.0 + 3.1 * cols, 0.6 + 2.7 * rows), sharey=True, squeeze=False)
    axes = [list(grid.ravel())]
    for ax in axes[0][len(keys):]:
        ax.set_visible(False)
    methods = sorted({m for k in keys for m in data[k]})
    spare = iter(f"C{i}" for i in range(5, 10))
    colours = {m: COLOURS.get(m) or next(spare) for m in methods}
    t = np.asarray(times)
    trials = 0
    for ax, key in zip(axes[0], keys):
        for method, runs in data[key].items():
            trials = max(trials, len(runs))
            units = [r[-1] for r in runs]
            stats = np.array([t_interval(nest([r[j] for r in runs], units)) for j in range(len(times))])
            n_units = len(set(units))
            ax.plot(t, stats[:, 0], color=colours[method], label=f"{method} (n={n_units} units)", lw=1.4)
            ax.fill_between(t, stats[:, 1], stats[:, 2], color=colours[method], alpha=0.25, lw=0)
        ax.set_title(_label(key), fontsize=9)
        ax.set_xlabel("simulated time (s)")
        ax.grid(alpha=0.3)
    for ax in grid[:, 0]:
        ax.set_ylabel("team completion (%)")
    handles, labels = [], []
    for ax in axes[0]:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab.split(" (")[0] not in [x.split(" (")[0] for x in labels]:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="center right", fontsize=8, frameon=False)
    fig.suptitle(f"{name}\nmean over run seeds (layouts averaged), band: {100 * LEVEL:g} % t interval",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1 - 1.6 / fig.get_figwidth(), 0.94))
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}_completion.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    log.info("wrote %s (%d panels, up to %d trials per method)", path, len(keys), trials)
    return path


def draw_all(results: Path, out: Path) -> list[Path]:
    """:func:`draw` for every ``<experiment>/runs_timeline.csv`` under ``results``, the figures into
    ``out``; :class:`InputError` when there is none or one cannot be read."""
    found = sorted(results.glob("*/runs_timeline.csv"))
    if not found:
        raise InputError(f"{results}: no <experiment>/runs_timeline.csv below it; expected the folder of "
                         f"archived sweeps (docs/results/paper) after 'ramensim report' ran on each.")
    return [draw(csv_path.parent.name, csv_path, out) for csv_path in found]
