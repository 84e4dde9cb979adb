"""A sweep's numbers over its trials: the 95 % interval of each point's team mean, the paired
comparison of the completion ratio between the values of each swept key, and the runs the
report could not count or marks (``ramensim report``: summary.md, its terminal output,
report.html, summary.csv).

A *trial* is one combination of the sweep's replicate axes (every axis whose key ends in
``seed``: run seed, scene layout ...); a *point* (a row of the summary table) is a combination
of the other axes and holds one run per trial. A run's *team mean* of a metric is the mean over
its robots of their finite values (a diverged robot's NaN left out), or its one value for a
run-level metric; units those of the metric (% for the completion ratio, cm for artifacts).

- :func:`summarize` gives, per point and each of :data:`TRIAL_METRICS`, the Student t interval
  over the point's trials' team means (``ramensim.evaluation.intervals.t_interval``:
  ``mean ± t_{n-1, 0.975} s / sqrt(n)``, ``s`` the sample std, ddof = 1), and for each swept
  key with two values or more (a *condition* axis: method, success rate, ...) in a sweep that
  plans two trials or more per condition, each value against a reference (RAMEN on the
  method axis when the sweep has it, else the key's first value in the order the tables show)
  as the paired difference of team means, run minus the reference's run with the same trial
  and the same value of every other axis, its t interval over those pairs (points, for the
  completion ratio) and their number. A point or a pair with one trial has no interval: the
  report prints ``n/a (1 trial)``.
- Runs not counted are named with the reason: a status other than ok / diverged (its error
  read from status.json, e.g. a missing or unreadable metrics.json), or a finished run without
  a finite value of a metric (a partial metrics.json: left out of that metric's interval only).
  A run whose metrics.json ``build`` names another host than most of the sweep's runs
  (``ramensim.provenance.same_host``) is counted and named, as claims.md does (runs of two hosts
  differ by float rounding, docs/DESIGN.md); a pair of such runs is counted in the comparison's
  "†" column. Nothing here raises on a run's content.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

from ramensim.evaluation.intervals import Interval, nest, t_interval
from ramensim.evaluation.summary import finite_mean
from ramensim.sweep import store
from ramensim.sweep.spec import _canonical, is_replicate_axis

UNIT_AXES = ("seed", "channel.seed")
"""The replicate axes that key the random generators every other replicate axis shares (the run
seed keys the channel's draws and the map's initialisation; ``channel.seed`` the channel's): two
trials are independent units only if they differ in one of these. Trials that differ only in
another replicate axis (a layout, ``world.scene.seed``) under one run seed are one unit."""
TRIAL_METRICS = ("completion_ratio_pct", "artifacts_cm", "holes_cm")
"""The metrics whose team mean gets an interval over trials: the paper's three (%, cm, cm)."""
PAIRED_METRIC = "completion_ratio_pct"
"""The metric of the paired comparisons (completion ratio, %; differences in points)."""
METHOD_AXIS = "method"
"""The axis whose reference is the paper's method (:func:`reference`)."""
MIXED = "†"
"""Marks the pairs whose two runs ran on different hosts."""


@dataclass
class Comparison:
    """The paired comparison along one condition axis: ``rows`` hold the other varying
    condition axes' values, the axis's value, ``interval`` (of value minus reference over the
    paired trials) and ``mixed`` (pairs whose runs ran on different hosts)."""
    axis: str
    reference: Any
    others: list[str]
    rows: list[dict[str, Any]] = field(default_factory=list)


@dataclass
class TrialSummary:
    """What :func:`summarize` found (see the module docstring)."""
    seeds: list[str]
    """The replicate axes a trial is made of (empty: one run per condition)."""
    metrics: list[str]
    """The metrics with an interval per point."""
    unit_axes: list[str] = field(default_factory=list)
    """The replicate axes that make trials independent units (:data:`UNIT_AXES` among the sweep's
    axes; empty: every trial of the sweep shares one run seed, so all its trials are one unit)."""
    nested: bool = False
    """Whether some unit holds more than one trial (layouts sharing a run seed)."""
    points: list[dict[str, Any]] = field(default_factory=list)
    """Per summary row, in its order: ``trials`` (counted runs) and metric -> :class:`Interval`."""
    metric: str | None = None
    """The paired comparisons' metric (None: no comparison)."""
    comparisons: list[Comparison] = field(default_factory=list)
    notes: list[tuple[str, str]] = field(default_factory=list)
    """(run, or a group of runs in words; why it is not counted or is marked), in the plan's order."""
    runs: set[str] = field(default_factory=set)
    """The names of the sweep's runs (to tell a run's note from a group's)."""


def team_mean(values: Mapping[str, Sequence[float]], metric: str) -> float:
    """The mean of a run's finite values of ``metric`` (one per robot, or one per run); NaN when
    it has none (:func:`ramensim.evaluation.summary.finite_mean`)."""
    return finite_mean(values.get(metric))


def machine(build: Mapping[str, Any] | None) -> str:
    """A run's host in words: CPU model, SIMD level, device (and the host fingerprint)."""
    if not build:
        return "no host record"
    words = ", ".join(str(build[k]) for k in ("cpu", "simd", "device") if build.get(k))
    return (words or "unnamed host") + (f", host {build['host']}" if build.get("host") else "")


def _build(metrics: Any) -> dict[str, Any] | None:
    b = metrics.get("build") if isinstance(metrics, Mapping) else None
    return dict(b) if isinstance(b, Mapping) and b else None


def _host_notes(records: Sequence[Any], builds: Mapping[str, dict[str, Any] | None]) -> list[tuple[str, str]]:
    """The runs whose host differs from the one most of the sweep's recorded runs share (ties:
    the first in the plan's order), and how many carry no host record."""
    from ramensim.provenance import same_host

    groups: list[list[str]] = []
    unrecorded = 0
    for r in records:
        if r.status not in store.COMPLETE:
            continue
        b = builds.get(r.name)
        if not b:
            unrecorded += 1
            continue
        for g in groups:
            if same_host(builds[g[0]], b):
                g.append(r.name)
                break
        else:
            groups.append([r.name])
    notes: list[tuple[str, str]] = []
    if len(groups) > 1:
        main = max(groups, key=len)
        where = machine(builds[main[0]])
        for g in groups:
            if g is not main:
                notes.append((f"{len(g)} run{'s' if len(g) != 1 else ''} on {machine(builds[g[0]])}",
                              f"another host than the {len(main)} runs on {where}; counted, their pairs marked "
                              f"{MIXED} (runs of two hosts differ by float rounding, docs/DESIGN.md): "
                              + ", ".join(g)))
    if unrecorded and groups:
        notes.append((f"({unrecorded} run{'s' if unrecorded != 1 else ''})",
                      "no host record in metrics.json (made before 2026-11-25): their host is unknown"))
    return notes


def summarize(records: Sequence[Any], axes: Mapping[str, Sequence[Any]], rows: Sequence[Mapping[str, Any]],
              names: Sequence[str], metrics_by_run: Mapping[str, Any]) -> TrialSummary:
    """Intervals per point, paired comparisons and notes (the module docstring) of a sweep's
    ``records`` (``aggregate.load_runs``), its plan's ``axes``, the summary ``rows`` and metric
    ``names`` of ``aggregate.aggregate``, and each finished run's metrics.json
    (``metrics_by_run``, by run name: read for its ``build``)."""
    from ramensim.evaluation.plots import value_order

    keys = [k for k in axes if not is_replicate_axis(k)]
    seeds = [k for k in axes if is_replicate_axis(k)]
    chosen = [m for m in TRIAL_METRICS if m in names] or [m for m in names][:3]
    ts = TrialSummary(seeds=seeds, metrics=chosen, runs={r.name for r in records},
                      unit_axes=[k for k in seeds if k in UNIT_AXES])

    def unit(r: Any) -> str:
        """A run's independent unit (eq. U-1 of ramensim.evaluation.intervals)."""
        return _canonical({k: r.axes.get(k) for k in ts.unit_axes})
    done = [r for r in records if r.status in store.COMPLETE]
    team = {r.name: {m: team_mean(r.values, m) for m in chosen} for r in done}
    builds = {r.name: _build(metrics_by_run.get(r.name)) for r in done}

    for r in records:
        if r.status not in store.COMPLETE:
            ts.notes.append((r.name, f"status {r.status!r}" + (f": {r.error}" if r.error else "")
                             + "; not counted"))
            continue
        lacking = [m for m in chosen if not math.isfinite(team[r.name][m])]
        if lacking:
            ts.notes.append((r.name, f"no finite {', '.join(lacking)} in its metrics.json; left out of "
                                     f"{'that interval' if len(lacking) == 1 else 'those intervals'}"))
    ts.notes += _host_notes(records, builds)

    def point_of(ax: Mapping[str, Any], ks: Sequence[str]) -> str:
        return _canonical({k: ax.get(k) for k in ks})

    by_point: dict[str, list[Any]] = {}
    for r in done:
        by_point.setdefault(point_of(r.axes, keys), []).append(r)
    for row in rows:
        runs = by_point.get(point_of(row, keys), [])
        point: dict[str, Any] = {k: row.get(k) for k in keys}
        point["trials"] = len(runs)
        point["units"] = len({unit(r) for r in runs})
        ts.nested = ts.nested or point["units"] < point["trials"]
        for m in chosen:
            kept = [r for r in runs if math.isfinite(team[r.name][m])]
            point[m] = t_interval(nest([team[r.name][m] for r in kept], [unit(r) for r in kept]))
        ts.points.append(point)

    planned = math.prod(len(axes[k]) for k in seeds) if seeds else 1
    metric = PAIRED_METRIC if PAIRED_METRIC in chosen else (chosen[0] if chosen else None)
    cond = [k for k in keys if len(axes.get(k) or []) > 1]
    if metric is None or planned < 2 or not cond:
        return ts
    ts.metric = metric
    from ramensim.provenance import same_host

    for axis in cond:
        order = value_order(axis, list(axes[axis]))
        ref = reference(axis, order)
        others = [k for k in cond if k != axis]
        comp = Comparison(axis=axis, reference=ref, others=others)
        by_key: dict[str, Any] = {}
        for r in done:
            if _canonical(r.axes.get(axis)) == _canonical(ref):
                by_key[_canonical({k: v for k, v in r.axes.items() if k != axis})] = r
        other_values = [value_order(k, list(axes[k])) for k in others]
        for combo in itertools.product(*other_values):
            fixed = dict(zip(others, combo))
            for value in order:
                if _canonical(value) == _canonical(ref):
                    continue
                diffs, units, mixed = [], [], 0
                for r in done:
                    if _canonical(r.axes.get(axis)) != _canonical(value) or \
                            any(_canonical(r.axes.get(k)) != _canonical(v) for k, v in fixed.items()):
                        continue
                    partner = by_key.get(_canonical({k: v for k, v in r.axes.items() if k != axis}))
                    if partner is None:
                        continue
                    d = team[r.name][metric] - team[partner.name][metric]
                    if not math.isfinite(d):
                        continue
                    diffs.append(d)
                    units.append(unit(r))
                    a, b = builds.get(r.name), builds.get(partner.name)
                    if a and b and not same_host(a, b):
                        mixed += 1
                comp.rows.append({**fixed, axis: value, "interval": t_interval(nest(diffs, units)),
                                  "pairs": len(diffs), "mixed": mixed})
        ts.comparisons.append(comp)
    return ts


def reference(axis: str, order: Sequence[Any]) -> Any:
    """The value the others of ``axis`` are compared with: on the method axis the paper's
    method, RAMEN (the registered method that sends visit counts, eq. 18) when the sweep has it,
    else the first value in ``order`` (the tables' order: success rates from 100 % down, other
    numbers ascending, names as planned)."""
    if axis == METHOD_AXIS:
        from ramensim.agents.consensus.registry import get_method

        for v in order:
            try:
                if get_method(str(v)).sends_uncertainty:
                    return v
            except (ValueError, KeyError):  # a method this installation does not know (a plugin's): not the paper's
                continue
    return order[0]


def interval_cell(iv: Interval, digits: int = 2, signed: bool = False) -> str:
    """``mean [lo, hi]`` (``+`` signs on a difference), ``mean, n/a (1 trial)`` with one trial,
    ``n/a (0 trials)`` / an en dash with none."""
    fmt = f"{{:{'+' if signed else ''}.{digits}f}}"
    if iv.n == 0 or not math.isfinite(iv.estimate):
        return "n/a (0 trials)" if signed else "–"
    est = fmt.format(iv.estimate)
    if not iv.defined:
        return f"{est}, n/a ({iv.n} trial{'s' if iv.n != 1 else ''})"
    return f"{est} [{fmt.format(iv.lo)}, {fmt.format(iv.hi)}]"


def _metric_header(metric: str) -> str:
    from ramensim.evaluation.plots import metric_label

    return metric_label(metric)


def point_table(ts: TrialSummary, keys: Sequence[str], digits: int = 2,
                value: Callable[[str, Any], str] = lambda k, v: str(v)) -> tuple[list[dict[str, str]], list[str],
                                                                                    dict[str, str]]:
    """The per-point interval table: (rows of text cells, columns, headers); ``value`` writes an
    axis value (summary.md: as planned; report.html: in words)."""
    cells = []
    for p in ts.points:
        row = {k: value(k, p.get(k)) for k in keys}
        row["trials"] = _trials_units(p["trials"], p.get("units", p["trials"]))
        for m in ts.metrics:
            iv = p[m]
            text = interval_cell(iv, digits)
            if iv.defined and iv.n != p.get("units", p["trials"]):
                text += f" ({iv.n} units)"
            row[m] = text
        cells.append(row)
    headers = {"trials": "trials (units)", **{m: _metric_header(m) for m in ts.metrics}}
    return cells, [*keys, "trials", *ts.metrics], headers


def _trials_units(trials: int, units: int) -> str:
    """``"6"`` when every trial is its own unit, ``"6 (3 units)"`` when layouts share run seeds."""
    return str(trials) if units == trials else f"{trials} ({units} unit{'s' if units != 1 else ''})"


def comparison_table(ts: TrialSummary, comp: Comparison, digits: int = 2,
                     value: Callable[[str, Any], str] = lambda k, v: str(v),
                     header: Callable[[str], str] = lambda k: k) -> tuple[list[dict[str, str]], list[str],
                                                                         dict[str, str]]:
    """One comparison's table: (rows of text cells, columns, headers); ``value`` writes an axis
    value and ``header`` an axis' name (summary.md: as planned; report.html: in words)."""
    unit = " (points)" if (ts.metric or "").endswith("_pct") else ""
    diff = f"difference from {value(comp.axis, comp.reference)}{unit}"
    cells = []
    for row in comp.rows:
        iv = row["interval"]
        cells.append({**{k: value(k, row.get(k)) for k in [*comp.others, comp.axis]},
                      "trials": _trials_units(row.get("pairs", iv.n), iv.n), MIXED: str(row["mixed"]),
                      "diff": interval_cell(iv, digits, signed=True)})
    cols = [*comp.others, comp.axis, "trials", *([MIXED] if any(r["mixed"] for r in comp.rows) else []), "diff"]
    headers = {comp.axis: header(comp.axis), **{k: header(k) for k in comp.others}, "trials": "trials (units)",
               MIXED: f"{MIXED} (hosts differ)", "diff": diff}
    return cells, cols, headers


def unit_words(ts: TrialSummary) -> str:
    """What the independent unit of the intervals is, in words (eq. U-1 of
    ramensim.evaluation.intervals)."""
    from ramensim.sweep.timecourse import trial_words

    if not ts.seeds:
        return ""
    if ts.unit_axes == ts.seeds or (ts.unit_axes and not ts.nested):
        return "each trial is an independent unit (its own run seed)"
    if ts.unit_axes:
        return (f"the independent unit is the {trial_words(ts.unit_axes)}: trials that share it (the same channel "
                f"realisation and map initialisation) are averaged first, and the interval is over the units")
    return ("every trial ran with one run seed, so all share the channel realisation and map initialisation: one "
            "unit, no interval (give each trial its own run seed, e.g. with the sweep file's 'trials')")


def intro(ts: TrialSummary) -> str:
    """The sentence under the interval table's heading: what a trial, the team mean and the
    interval are."""
    from ramensim.sweep.timecourse import trial_words

    what = f"a trial: {trial_words(ts.seeds)}" if ts.seeds else "one run per condition, so no interval"
    return (f"Team mean (a run's mean over its robots) per point, mean over the trials and its 95 % interval, "
            f"Student t over the trials' team means (t with n − 1 degrees of freedom; "
            f"evaluation/intervals.py); {what}; {unit_words(ts) or 'no unit'}. One unit: n/a (1 trial).")


def comparison_intro(ts: TrialSummary) -> str:
    """The sentence under the paired comparisons' heading."""
    from ramensim.evaluation.plots import metric_label

    label = metric_label(ts.metric or "").replace(" ↑", "").replace(" ↓", "")
    from ramensim.sweep.timecourse import trial_words

    return (f"{label}: each condition's team mean minus its reference's on the same trial "
            f"({trial_words(ts.seeds)}) with every other setting the same, mean over the paired trials and its "
            f"95 % interval "
            f"(paired Student t; {unit_words(ts)}); trials: the pairs counted (and the units they form); {MIXED}: "
            f"pairs whose two runs ran on different hosts (ramensim.provenance.same_host). One unit: n/a (1 trial).")


def markdown(ts: TrialSummary, keys: Sequence[str], digits: int = 2) -> str:
    """The sections summary.md gains (and `ramensim report` prints): the interval table, the
    paired comparisons, the runs not counted or marked."""
    from ramensim.evaluation.plots import key_words
    from ramensim.evaluation.tables import to_markdown

    if not ts.points:
        return ""
    cells, cols, headers = point_table(ts, keys, digits)
    parts = ["## 95 % interval over trials", "", intro(ts), "", to_markdown(cells, cols, headers=headers)]
    if ts.comparisons:
        parts += ["## Paired comparisons over trials", "", comparison_intro(ts), ""]
        for comp in ts.comparisons:
            rows, ccols, cheads = comparison_table(ts, comp, digits)
            parts += [f"### {key_words(comp.axis)[:1].upper() + key_words(comp.axis)[1:]} against {comp.reference}",
                      "", to_markdown(rows, ccols, headers=cheads)]
    if ts.notes:
        parts += ["## Runs not counted or marked", ""]
        runs = {r for r, _ in ts.notes if r in ts.runs}
        parts += [f"- {f'`{name}`' if name in runs else name}: {why}" for name, why in ts.notes]
        parts.append("")
    return "\n".join(parts)


def csv_columns(ts: TrialSummary) -> list[str]:
    """The columns summary.csv gains, after its own: per metric the mean over trials of the team
    mean, its interval's ends and the trials counted."""
    return [f"{m}_{s}" for m in ts.metrics for s in ("trial_mean", "ci95_lo", "ci95_hi", "trials", "units")]


def add_to_rows(ts: TrialSummary, rows: Sequence[dict[str, Any]]) -> None:
    """Write :func:`csv_columns` into the summary rows (same order as ``ts.points``)."""
    for row, p in zip(rows, ts.points):
        for m in ts.metrics:
            iv = p[m]
            row[f"{m}_trial_mean"], row[f"{m}_ci95_lo"], row[f"{m}_ci95_hi"] = iv.estimate, iv.lo, iv.hi
            row[f"{m}_trials"] = p["trials"] if iv.n else 0
            row[f"{m}_units"] = iv.n
