"""Completion over simulated time, per condition, from a sweep's run timelines.

Every run evaluates its maps every ``evaluation.every_s`` simulated seconds (metrics.json
``timeline``: one entry per agent and evaluation) and once more at the end (``per_agent``).
From those this module derives, for ``ramensim report``:

- ``runs_timeline.csv``: one row per run: its settings (the swept keys), status, wall time,
  final metrics (team mean over agents) and the team-mean completion and unseen-part
  completion at every evaluation (``completion_ratio_pct@30``, ... columns; times in s);
- ``plots/completion_over_time.png|svg``: completion and unseen-part completion (%) against
  simulated time (s), one line per condition (the swept keys other than the seeds), mean ±
  std over trials (every combination of the seed axes: run seed x house layout);
- ``time_to_consensus.csv`` / ``.md``: per condition, the *time to consensus*: the first
  evaluation time t* (s) after which the run's team completion stays within ``margin``
  (5) points of the centralised run's of the same trial at every later evaluation, over
  the trials that have a centralised run; ``never`` when a run ends outside the margin.

The centralised reference of a trial is a run of the same seeds with ``method: centralised``
(other swept keys ignored: centralised does not communicate), from this sweep or from a
reference sweep folder (``ramensim report --references DIR``), whose ``local`` and
``centralised`` curves are also drawn as references, averaged over this sweep's own trials
only (:func:`matching_references`). A run whose metrics.json has no
timeline (made with ``evaluation.every_s: null``, or before timelines existed) is listed by
name as missing, never a traceback.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ramensim.sweep import store
from ramensim.evaluation.summary import finite_values
from ramensim.evaluation.tables import to_csv, to_markdown
from ramensim.sweep.aggregate import RunRecord, load_runs
from ramensim.sweep.spec import is_replicate_axis

log = logging.getLogger(__name__)

CURVE_METRICS = ("completion_ratio_pct", "completion_unseen_pct")
"""Metrics drawn over time (%), team mean over agents."""
FINAL_METRICS = ("completion_ratio_pct", "completion_unseen_pct", "artifacts_cm", "holes_cm",
                 "own_coverage_pct")
"""Per-agent metrics averaged over the team in runs_timeline.csv's final columns."""


def _spec(method: Any) -> Any:
    """The registry's spec of a run's method (None for a name it does not know)."""
    from ramensim.agents.consensus.registry import get_method

    try:
        return get_method(str(method))
    except ValueError:
        return None


def is_reference(method: Any) -> bool:
    """Whether ``method`` is a floor or ceiling (the registry's ``reference``: local, centralised)."""
    spec = _spec(method)
    return bool(spec is not None and spec.reference)


def is_ceiling(method: Any) -> bool:
    """Whether ``method`` is the ceiling every other method is measured against: the reference
    that learns from every robot's frames (the registry's ``merges_frames``: centralised)."""
    spec = _spec(method)
    return bool(spec is not None and spec.reference and spec.merges_frames)


MARGIN_PCT = 5.0
"""Points of completion within which a run counts as having caught up with centralised."""


@dataclass
class RunCurve:
    """The team-mean metrics of one run at each evaluation time."""

    name: str
    axes: dict[str, Any]
    times: list[float]
    values: dict[str, list[float]]
    """Metric -> team mean at each of ``times`` (NaN where no agent had a finite value)."""
    final: dict[str, float] = field(default_factory=dict)
    wall_s: float = math.nan
    source: str = ""
    """The sweep folder the run came from."""


def _team_mean(entries: Sequence[Mapping[str, Any]], key: str) -> float:
    vals = finite_values(e.get(key) for e in entries)
    return float(np.mean(vals)) if vals else math.nan


def run_curve(name: str, axes: Mapping[str, Any], metrics: Mapping[str, Any], source: str = "") -> RunCurve | None:
    """The curve of one run's metrics.json: its periodic evaluations plus the final one at the
    simulated time reached; None when it has no periodic evaluation."""
    timeline = metrics.get("timeline")
    if not isinstance(timeline, list) or not timeline:
        return None
    by_t: dict[float, list[Mapping[str, Any]]] = {}
    for e in timeline:
        if isinstance(e, Mapping) and isinstance(e.get("t"), (int, float)):
            by_t.setdefault(round(float(e["t"]), 6), []).append(e)
    if not by_t:
        return None
    per_agent = metrics.get("per_agent")
    final_entries = [a for a in per_agent.values() if isinstance(a, Mapping)] if isinstance(per_agent, Mapping) else []
    t_end = metrics.get("sim_time_s")
    if final_entries and isinstance(t_end, (int, float)):
        by_t[round(float(t_end), 6)] = final_entries  # the final evaluation replaces one at the same time
    times = sorted(by_t)
    values = {m: [_team_mean(by_t[t], m) for t in times] for m in CURVE_METRICS}
    final = {m: _team_mean(final_entries, m) for m in FINAL_METRICS} if final_entries else {}
    for key in ("consensus_error", "consensus_error_weighted"):
        v = metrics.get(key)
        final[key] = float(v) if isinstance(v, (int, float)) else math.nan
    wall = metrics.get("wall_time_s")
    return RunCurve(name, dict(axes), times, values, final, float(wall) if isinstance(wall, (int, float)) else math.nan,
                    source)


def load_curves(sweep_dir: Path, records: Sequence[RunRecord],
                read: Mapping[str, Any] | None = None) -> tuple[list[RunCurve], list[str]]:
    """Curves of the completed runs of a sweep folder, and the names of completed runs without
    a timeline; ``read``: their metrics.json already read, by run name."""
    curves, missing = [], []
    for rec in records:
        if rec.status not in store.COMPLETE:
            continue
        metrics = read[rec.name] if read is not None and rec.name in read else \
            store.read_json(sweep_dir / store.RUNS / rec.name / store.METRICS)
        curve = run_curve(rec.name, rec.axes, metrics, str(sweep_dir)) if isinstance(metrics, Mapping) else None
        if curve is None:
            missing.append(rec.name)
        else:
            curves.append(curve)
    return curves, missing


def trial_key(axes: Mapping[str, Any]) -> tuple:
    """The trial of a run: its values of the seed axes (run seed, house layout...)."""
    return tuple(sorted((k, str(v)) for k, v in axes.items() if is_replicate_axis(k)))


def condition_label(axes: Mapping[str, Any], keys: Sequence[str]) -> str:
    """The condition of a run: its values of the non-seed axes in ``keys``, each named by the
    last two parts of its key (``compute.jitter=0.5``), then the method's bare name:
    ``channel.success_rate=0.2, ramen``."""
    named = [f"{'.'.join(k.split('.')[-2:])}={axes.get(k)}" for k in keys if k != "method"]
    return ", ".join(named + [str(axes.get(k)) for k in keys if k == "method"]) or "all"


def _condition_keys(keys: Sequence[str]) -> list[str]:
    """``keys`` with the method last (as :func:`condition_label` writes them)."""
    return [k for k in keys if k != "method"] + [k for k in keys if k == "method"]


def condition_words(axes: Mapping[str, Any], keys: Sequence[str]) -> str:
    """A condition as a figure's legend shows it: its values in words, method last
    (``20 %, ramen``; the legend's title, :func:`condition_title`, names the keys)."""
    from ramensim.evaluation.plots import format_value

    return ", ".join(format_value(k, axes.get(k)) for k in _condition_keys(keys)) or "all"


def condition_title(keys: Sequence[str]) -> str:
    """The keys of :func:`condition_words` in words (``Communication success rate, method``)."""
    from ramensim.evaluation.plots import key_words

    text = ", ".join(key_words(k) for k in _condition_keys(keys))
    return text[:1].upper() + text[1:]


def condition_sort_key(axes: Mapping[str, Any], keys: Sequence[str], values: Mapping[str, Sequence[Any]]) -> tuple:
    """Sort key of a condition: each key's value by its rank in
    :func:`ramensim.evaluation.plots.value_order` of ``values[key]`` (the sweep's values)."""
    from ramensim.evaluation.plots import value_order

    rank = []
    for k in keys:
        order = value_order(k, list(values.get(k, [])))
        v = axes.get(k)
        rank.append(order.index(v) if v in order else len(order))
    return tuple(rank)


def trial_words(keys: Sequence[str]) -> str:
    """What a trial is, from the replicate axes a sweep has: ``run seed × scene layout``,
    ``run seed``, or ``one run per condition`` when it has none."""
    from ramensim.evaluation.plots import key_words

    seeds = [k for k in keys if is_replicate_axis(k)]
    return " × ".join(key_words(k) for k in seeds) if seeds else "one run per condition"


def mean_curves(curves: Sequence[RunCurve], keys: Sequence[str], metric: str,
                label_fn: Any = None) -> dict[str, list[tuple[float, float, float]]]:
    """Per condition (named by ``label_fn(axes, keys)``, default :func:`condition_label`):
    (t, mean, std over trials) at every evaluation time some run reached."""
    by: dict[str, dict[float, list[float]]] = {}
    for c in curves:
        label = (label_fn or condition_label)(c.axes, keys)
        for t, v in zip(c.times, c.values[metric]):
            if math.isfinite(v):
                by.setdefault(label, {}).setdefault(t, []).append(v)
    return {label: [(t, float(np.mean(v)), float(np.std(v))) for t, v in sorted(pts.items())]
            for label, pts in by.items()}


def matching_references(refs: Sequence[RunCurve], curves: Sequence[RunCurve]) -> list[RunCurve]:
    """The reference runs (local, centralised from ``--references``) of the trials that
    ``curves`` hold: the floor and ceiling drawn beside a sweep are averaged over the same
    seeds and layouts as its own runs, never over trials it has not run."""
    trials = {trial_key(c.axes) for c in curves}
    return [r for r in refs if trial_key(r.axes) in trials]


def time_to_consensus(run: RunCurve, reference: RunCurve, margin: float = MARGIN_PCT) -> float | None:
    """First evaluation time t* (s) such that at t* and every later common evaluation the run's
    team completion is >= the reference's - ``margin`` points; None if it never settles there
    (e.g. outside the margin at its last evaluation)."""
    ref = dict(zip(reference.times, reference.values["completion_ratio_pct"]))
    pts = [(t, v, ref[t]) for t, v in zip(run.times, run.values["completion_ratio_pct"]) if t in ref]
    t_star = None
    for t, v, r in pts:
        ok = math.isfinite(v) and math.isfinite(r) and v >= r - margin
        if ok and t_star is None:
            t_star = t
        elif not ok:
            t_star = None
    return t_star


@dataclass
class Timecourse:
    """What :func:`write_timecourse` found and wrote."""

    curves: list[RunCurve]
    missing_timeline: list[str]
    references: list[RunCurve]
    files: list[Path] = field(default_factory=list)
    ttc_rows: list[dict[str, Any]] = field(default_factory=list)
    drawn_references: list[str] = field(default_factory=list)
    """Methods of the reference runs drawn beside the conditions (from ``--references``)."""
    trials: int = 0
    """Trials (combinations of the seed axes) the completion-over-time figure averages."""


def _wide_rows(curves: Sequence[RunCurve], keys: Sequence[str]) -> tuple[list[dict[str, Any]], list[str]]:
    times = sorted({t for c in curves for t in c.times})
    seeds = sorted({k for c in curves for k in c.axes if is_replicate_axis(k)})
    cols = ["name", *seeds, *keys, "wall_time_s", *[f"final_{m}" for m in (*FINAL_METRICS, "consensus_error",
                                                                            "consensus_error_weighted")]]
    cols += [f"{m}@{t:g}" for m in CURVE_METRICS for t in times]
    rows = []
    for c in curves:
        row: dict[str, Any] = {"name": c.name, **{k: c.axes.get(k) for k in (*seeds, *keys)}, "wall_time_s": c.wall_s}
        for m in (*FINAL_METRICS, "consensus_error", "consensus_error_weighted"):
            row[f"final_{m}"] = c.final.get(m, math.nan)
        for m in CURVE_METRICS:
            at = dict(zip(c.times, c.values[m]))
            for t in times:
                row[f"{m}@{t:g}"] = at.get(t, math.nan)
        rows.append(row)
    return rows, cols


def _ttc_rows(curves: Sequence[RunCurve], refs: Sequence[RunCurve], keys: Sequence[str]) -> list[dict[str, Any]]:
    central = {trial_key(c.axes): c for c in refs if is_ceiling(c.axes.get("method"))}
    central.update({trial_key(c.axes): c for c in curves if is_ceiling(c.axes.get("method"))})
    groups: dict[str, list[tuple[RunCurve, float | None]]] = {}
    for c in curves:
        if is_reference(c.axes.get("method")):
            continue
        ref = central.get(trial_key(c.axes))
        if ref is None:
            continue
        groups.setdefault(condition_label(c.axes, keys), []).append((c, time_to_consensus(c, ref)))
    values: dict[str, list[Any]] = {}
    for c in curves:
        for k in keys:
            if c.axes.get(k) not in values.setdefault(k, []):
                values[k].append(c.axes.get(k))
    rows = []
    for label, items in sorted(groups.items(), key=lambda g: condition_sort_key(g[1][0][0].axes, keys, values)):
        reached = [t for _, t in items if t is not None]
        gap = [c.final.get("completion_ratio_pct", math.nan) - central[trial_key(c.axes)].final.get(
            "completion_ratio_pct", math.nan) for c, _ in items]
        rows.append({"condition": label, "label": condition_words(items[0][0].axes, keys),
                     "trials": len(items), "reached": len(reached),
                     "t_consensus_mean_s": float(np.mean(reached)) if reached else math.nan,
                     "t_consensus_max_s": float(np.max(reached)) if reached else math.nan,
                     "final_gap_to_centralised_pts": float(np.nanmean(gap)) if gap else math.nan,
                     "per_trial_s": " ".join("never" if t is None else f"{t:g}" for _, t in items)})
    return rows


def write_timecourse(root: Path, records: Sequence[RunRecord], keys: Sequence[str], title: str,
                     formats: Sequence[str], references: Sequence[Path] = (),
                     metrics: Mapping[str, Any] | None = None) -> Timecourse:
    """Write runs_timeline.csv, time_to_consensus.csv/.md and plots/completion_over_time.*
    for the sweep folder ``root`` (see the module docstring); ``metrics``: the runs'
    metrics.json already read, by run name."""
    from ramensim.evaluation.plots import plot_timeline_panels, save_figure

    curves, missing = load_curves(root, records, metrics)
    refs: list[RunCurve] = []
    for ref_dir in references:
        _, ref_records = load_runs(ref_dir)
        found, ref_missing = load_curves(Path(ref_dir), [r for r in ref_records
                                                        if is_reference(r.axes.get("method"))])
        refs += found
        missing += [f"{ref_dir}/{n}" for n in ref_missing]
    tc = Timecourse(curves, missing, refs)
    if missing:
        log.warning("sweep %s: %d run(s) have no timeline (evaluation.every_s off, or made before "
                    "timelines): %s", title, len(missing), ", ".join(missing[:10]))
    if not curves:
        return tc
    rows, cols = _wide_rows(curves, keys)
    store.atomic_write_text(root / "runs_timeline.csv", to_csv(rows, cols))
    tc.files.append(root / "runs_timeline.csv")
    tc.ttc_rows = _ttc_rows(curves, refs, keys)
    if tc.ttc_rows:
        cols = ["condition", "trials", "reached", "t_consensus_mean_s", "t_consensus_max_s",
                "final_gap_to_centralised_pts", "per_trial_s"]
        store.atomic_write_text(root / "time_to_consensus.csv", to_csv(tc.ttc_rows, cols))
        md_rows = [{**r, **{k: (f"{r[k]:.1f}" if isinstance(r[k], float) and math.isfinite(r[k]) else
                                ("—" if isinstance(r[k], float) else r[k])) for k in r}} for r in tc.ttc_rows]
        text = (f"# Time to consensus: {title}\n\nFirst evaluation after which the team's completion stays within "
                f"{MARGIN_PCT:g} points of the centralised run of the same trial (s); trials = seed x layout "
                f"pairs with a centralised run; never = outside the margin at the last evaluation.\n\n"
                + to_markdown(md_rows, cols))
        store.atomic_write_text(root / "time_to_consensus.md", text)
        tc.files += [root / "time_to_consensus.csv", root / "time_to_consensus.md"]
    ref_keys = ["method"]
    drawn = matching_references(refs, curves)
    tc.drawn_references = list(dict.fromkeys(str(c.axes.get("method")) for c in drawn))
    if refs and not drawn:
        log.warning("sweep %s: the reference sweep(s) hold no run of this sweep's trials (seed x layout); "
                    "no reference curve drawn", title)
    values: dict[str, list[Any]] = {}
    for c in curves:
        for k in keys:
            if c.axes.get(k) not in values.setdefault(k, []):
                values[k].append(c.axes.get(k))
    order = {condition_words(c.axes, keys): condition_sort_key(c.axes, keys, values) for c in curves}
    panels = {}
    for m in CURVE_METRICS:
        found = mean_curves(curves, keys, m, condition_words)
        lines = {label: found[label] for label in sorted(found, key=lambda lb: order.get(lb, ()))}
        for label, pts in mean_curves(drawn, ref_keys, m).items():
            lines.setdefault(f"{label} (reference)", pts)
        panels[m] = lines
    trials = tc.trials = len({trial_key(c.axes) for c in curves})
    all_axes = sorted({k for c in curves for k in c.axes})
    fig = plot_timeline_panels(panels, title=f"{title}: mean ± std over {trials} trial(s) ({trial_words(all_axes)})",
                               legend_title=condition_title(keys) if keys else None)
    tc.files += save_figure(fig, root / "plots" / "completion_over_time", formats)
    return tc
