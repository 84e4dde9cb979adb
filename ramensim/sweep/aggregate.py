"""Aggregate a sweep folder: one row per sweep point with mean ± std over agents and seeds.

Rows group the runs by every axis except the replicate axes (``seed``); each metric pools the
per-agent values of all runs of the group (Table I: "three trials per agent per method ... mean
and standard deviation"); run-level numbers (e.g. consensus error, bytes) pool one value per
run. Standard deviations are population ones (ddof=0). Failed runs are counted, not averaged.
Reads only committed point folders (``runs/NAME``), never a run still being written.
"""
from __future__ import annotations

import logging
import math
import numbers
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from ramensim.evaluation.tables import format_mean_std, mean_std, to_csv, to_markdown
from ramensim.core.errors import InputError
from ramensim.sweep import store
from ramensim.sweep.spec import _canonical, is_replicate_axis

log = logging.getLogger(__name__)

PRIMARY_METRICS = ("artifacts_cm", "holes_cm", "completion_ratio_pct", "own_coverage_pct",
                   "completion_unseen_pct", "completion_far_pct")
"""The paper's three metrics (cm, cm, %), then what communication brings (own coverage %,
completion on the part only teammates saw %, and on the part only robots beyond the map's graph
neighbours saw %, docs/ALGORITHM.md section 5; a run whose graph leaves no such part has none
and the column is left out), per agent."""
SECONDARY_METRICS = ("consensus_error", "consensus_error_peak", "consensus_error_weighted",
                     "consensus_error_weighted_peak", "communication.bytes_sent", "communication.delivered_fraction",
                     "bytes_sent", "bytes")
"""Run-level numbers shown in the Markdown table when a run reports them."""
_AGENT_KEYS = ("agents", "per_agent")
_SUMMARY_KEYS = ("mean", "std", "min", "max", "median", "summary")
_IGNORED_KEYS = ("seed", "n_agents", "success_rate", "timeline", "communication_links", "scenario", "method",
                 "status", "error", "build")
"""Top-level entries of a run's metrics.json that are settings or series, not results to average."""


@dataclass
class RunRecord:
    """One committed point folder."""

    name: str
    axes: dict[str, Any]
    status: str
    error: str | None = None
    values: dict[str, list[float]] = field(default_factory=dict)
    """Metric -> values of this run (one per agent for per-agent metrics, else one)."""


def _is_number(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _numeric_leaves(d: Mapping[str, Any], prefix: str = "") -> dict[str, float]:
    out: dict[str, float] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if _is_number(v):
            out[key] = float(v)
        elif isinstance(v, Mapping):
            out.update(_numeric_leaves(v, key + "."))
    return out


def run_values(metrics: Mapping[str, Any]) -> dict[str, list[float]]:
    """Metric name -> values of one run, from a ``metrics.json`` dict.

    Per-agent metrics come from ``agents``/``per_agent`` (a list of dicts, or a dict of agent
    id -> dict), or from ``METRIC: {per_agent|values: [...]}`` or ``METRIC: [...]``; a summary
    ``METRIC: {mean: x, std: s}`` alone gives ``[x]``. Other numeric leaves (nested dicts are
    flattened to dotted names) are run-level: one value each. Top-level ``mean``/``std``/...
    summaries (and ``summary``) are ignored, as they are recomputed, and so are the echoed
    settings and series in ``_IGNORED_KEYS`` (seed, timeline, per-link counters...).
    """
    out: dict[str, list[float]] = defaultdict(list)
    for key in _AGENT_KEYS:
        agents = metrics.get(key)
        entries = list(agents.values()) if isinstance(agents, Mapping) else agents
        if isinstance(entries, list):
            for entry in entries:
                if isinstance(entry, Mapping):
                    for k, v in _numeric_leaves(entry).items():
                        if k.startswith("metrics."):
                            k = k[len("metrics."):]
                        if k in ("id", "agent", "index"):
                            continue
                        out[k].append(v)
            break
    for key, value in metrics.items():
        if key in _AGENT_KEYS or key in _SUMMARY_KEYS or key in _IGNORED_KEYS or key in out:
            continue
        if _is_number(value):
            out[key].append(float(value))
        elif isinstance(value, list) and value and all(_is_number(v) or v is None for v in value):
            out[key].extend(math.nan if v is None else float(v) for v in value)
        elif isinstance(value, Mapping):
            listed = value.get("per_agent", value.get("values"))
            if isinstance(listed, list) and all(_is_number(v) or v is None for v in listed):
                out[key].extend(math.nan if v is None else float(v) for v in listed)
            elif "mean" in value and _is_number(value["mean"]):
                out[key].append(float(value["mean"]))
            else:
                for k, v in _numeric_leaves(value, key + ".").items():
                    out[k].append(v)
    for key in ("consensus_error", "consensus_error_weighted"):
        peak = _timeline_peak(metrics.get("consensus_timeline"), metrics.get(key), key)
        if peak is not None:
            out[f"{key}_peak"].append(peak)
    return dict(out)


def _timeline_peak(timeline: Any, final: Any, key: str = "consensus_error") -> float | None:
    """Largest consensus error ``key`` (unweighted or weighted) of a run (Theta units): over its
    periodic probes and the final value; None when the run has no probes of it. With the final
    value it gives the fall from the peak that docs/RESULTS.md reports."""
    if not isinstance(timeline, list):
        return None
    vals = [float(p[key]) for p in timeline if isinstance(p, Mapping) and _is_number(p.get(key))]
    if _is_number(final):
        vals.append(float(final))
    vals = [v for v in vals if math.isfinite(v)]
    return max(vals) if vals else None


def load_plan(sweep_dir: Path) -> dict[str, Any] | None:
    """The ``sweep.json`` of a sweep folder, or None when it has none."""
    data = store.read_json(Path(sweep_dir) / store.PLAN)
    return data if isinstance(data, dict) else None


def load_runs(sweep_dir: str | Path) -> tuple[dict[str, Any], list[RunRecord]]:
    """The plan and the committed runs of a sweep folder (points of the current plan only; a
    folder left from an older plan is ignored). Raises InputError if it is not a sweep folder."""
    root = Path(sweep_dir)
    runs = root / store.RUNS
    plan = load_plan(root)
    if plan is None and not runs.is_dir():
        raise InputError(f"{root}: not a sweep folder (no {store.PLAN} and no {store.RUNS}/ inside); expected "
                         f"the --out folder of 'ramensim sweep'.")
    wanted: list[str] | None = None
    plan_axes: dict[str, dict[str, Any]] = {}
    if plan is not None:
        wanted = [p["name"] for p in plan.get("points", []) if isinstance(p, Mapping) and "name" in p]
        plan_axes = {p["name"]: dict(p.get("axes") or {}) for p in plan.get("points", [])
                     if isinstance(p, Mapping) and "name" in p}
    names = wanted if wanted is not None else sorted(
        c.name for c in runs.iterdir() if c.is_dir() and not c.name.startswith("."))
    records = []
    for name in names:
        status = store.read_status(runs / name)
        if status is None:
            if (runs / name).is_dir():  # a committed folder without a readable status: say so
                log.warning("sweep point %s: %s missing or unreadable; counted as failed (a resume runs it again)",
                            name, store.STATUS)
                records.append(RunRecord(name=name, axes=plan_axes.get(name, {}), status="failed",
                                         error=f"{store.STATUS} missing or unreadable", values={}))
            continue
        values: dict[str, list[float]] = {}
        state = str(status.get("status", "unknown"))
        if state in store.COMPLETE:
            metrics = store.read_json(runs / name / store.METRICS)
            if isinstance(metrics, Mapping):
                values = run_values(metrics)
            else:
                state, status["error"] = "failed", f"{store.METRICS} missing or unreadable"
        records.append(RunRecord(name=name, axes=dict(status.get("axes") or {}), status=state,
                                 error=status.get("error"), values=values))
    if plan is None:
        axes: dict[str, list[Any]] = {}
        for r in records:
            for k, v in r.axes.items():
                if v not in axes.setdefault(k, []):
                    axes[k].append(v)
        plan = {"name": root.name, "axes": axes, "points": [{"name": r.name, "axes": r.axes} for r in records]}
    return plan, records


def group_axes(axes: Mapping[str, Sequence[Any]]) -> list[str]:
    """The axes rows are grouped by: every axis except the replicate (seed) axes."""
    return [k for k in axes if not is_replicate_axis(k)]


def aggregate(records: Sequence[RunRecord], axes: Mapping[str, Sequence[Any]],
              metrics: Sequence[str] | None = None) -> tuple[list[dict[str, Any]], list[str]]:
    """Summary rows (one per combination of non-seed axis values: axes in plan order, the first
    slowest, each axis's values in the order of :func:`ramensim.evaluation.plots.value_order`,
    numbers sorted, success rates from 100 % down, names as planned) and the metric
    names found. Row keys: each grouping axis, ``runs``, ``ok``, ``diverged``, ``failed``, and per
    metric ``M_mean``, ``M_std``, ``M_n`` (values pooled over agents and seeds)."""
    keys = group_axes(axes)
    groups: dict[str, dict[str, Any]] = {}
    pooled: dict[str, dict[str, list[float]]] = {}
    found: list[str] = []
    for r in records:
        combo = {k: r.axes.get(k) for k in keys}
        gid = _canonical(combo)
        row = groups.setdefault(gid, {**combo, "runs": 0, "ok": 0, "diverged": 0, "failed": 0})
        pooled.setdefault(gid, defaultdict(list))
        row["runs"] += 1
        row[r.status if r.status in ("ok", "diverged") else "failed"] += 1
        if r.status in store.COMPLETE:
            for m, vals in r.values.items():
                pooled[gid][m].extend(vals)
                if m not in found:
                    found.append(m)
    unknown = [m for m in (metrics or []) if m not in found]
    if unknown and found:
        raise InputError(f"--metrics: {', '.join(map(repr, unknown[:20]))} "
                         f"{'is' if len(unknown) == 1 else 'are'} not among the metrics the runs wrote; "
                         f"expected some of: {', '.join(_ordered(found)[:40])}.")
    names = list(metrics) if metrics else _ordered(found)
    from ramensim.evaluation.plots import value_order

    ordered_axes = {k: value_order(k, list(axes[k])) for k in keys}
    order = {_canonical({k: v for k, v in zip(keys, vals)}): i for i, vals in enumerate(_product(ordered_axes, keys))}
    rows = []
    for gid in sorted(groups, key=lambda g: order.get(g, len(order))):
        row = groups[gid]
        for m in names:
            row[f"{m}_mean"], row[f"{m}_std"], row[f"{m}_n"] = mean_std(pooled[gid].get(m, []))
        rows.append(row)
    return rows, names


def _product(axes: Mapping[str, Sequence[Any]], keys: Sequence[str]) -> list[tuple[Any, ...]]:
    import itertools

    return list(itertools.product(*(axes[k] for k in keys)))


def _ordered(found: Sequence[str]) -> list[str]:
    first = [m for m in PRIMARY_METRICS if m in found]
    return first + [m for m in found if m not in first]


def table_metrics(names: Sequence[str]) -> list[str]:
    """Metrics shown in the Markdown table: the paper's three and the usual run-level ones
    when present; every metric when none of those are."""
    chosen = [m for m in (*PRIMARY_METRICS, *SECONDARY_METRICS) if m in names]
    return chosen or list(names)


def summary_tables(rows: Sequence[Mapping[str, Any]], axes_keys: Sequence[str], names: Sequence[str],
                   md_metrics: Sequence[str] | None = None, digits: int = 2,
                   extra_csv: Sequence[str] = (), single_alone: bool = False) -> tuple[str, str]:
    """(CSV with separate mean/std/n columns for every metric, then the ``extra_csv`` columns of
    the rows (the intervals over trials, ``ramensim.sweep.trials``), Markdown with ``mean ± std``
    cells; fractions such as the delivered share in percent there). ``single_alone``: a cell
    that rests on one value (``M_n`` 1) shows the value alone, not ``± 0`` (the paper style)."""
    from ramensim.evaluation.plots import is_fraction_key

    counts = ["runs", "ok", "diverged", "failed"]
    csv_cols = [*axes_keys, *counts] + [f"{m}_{s}" for m in names for s in ("mean", "std", "n")] + list(extra_csv)
    md_names = list(md_metrics) if md_metrics is not None else table_metrics(names)
    md_rows = []
    for row in rows:
        cells = {k: row.get(k) for k in (*axes_keys, *counts)}
        for k in axes_keys:
            cells[k] = str(row.get(k))
        for m in md_names:
            mean, std = row.get(f"{m}_mean"), row.get(f"{m}_std")
            if single_alone and row.get(f"{m}_n") == 1:
                std = None
            if is_fraction_key(m):  # in percent, as its header says (the CSV keeps the fraction)
                mean, std = (None if v is None else 100.0 * v for v in (mean, std))
                cells[m] = format_mean_std(mean, std, 1)
            else:
                cells[m] = format_mean_std(mean, std, digits)
        md_rows.append(cells)
    md_cols = [*axes_keys, "runs", "failed", *md_names]
    from ramensim.evaluation.plots import metric_label

    headers = {m: metric_label(m) for m in md_names}
    return to_csv(rows, csv_cols), to_markdown(md_rows, md_cols, headers=headers)


def run_table(records: Sequence[RunRecord], axes_keys: Sequence[str], names: Sequence[str]) -> str:
    """CSV with one line per run: status, error, and each metric's mean over agents."""
    rows = []
    for r in records:
        row: dict[str, Any] = {"name": r.name, **{k: r.axes.get(k) for k in axes_keys},
                               "status": r.status, "error": r.error or ""}
        for m in names:
            row[m], _, _ = mean_std(r.values.get(m, []))
        rows.append(row)
    for row in rows:
        for k in axes_keys:
            row[k] = str(row[k])
    return to_csv(rows, ["name", *axes_keys, "status", "error", *names])
