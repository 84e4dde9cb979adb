"""``ramensim compare RUN_A RUN_B ...``: the paper's metrics, coverage and bytes of several
runs side by side, and a plot of the completion ratio over simulated time.

Each RUN is a run folder (or its ``metrics.json``). Per-agent metrics are shown as mean ± std
over the run's maps (population std); the plot draws, per run, the mean over maps of the
periodic evaluations (``evaluation.every_s``) and the final evaluation at the run's end.
``--at T`` compares the runs at their periodic evaluation at simulated time T (s) instead of
their end: the per-map metrics of that evaluation, the consensus error of the last probe at or
before T; message counts stay the run's totals. T may also be a run's end (its ``sim_time_s``),
where the final evaluation is taken (the periodic ones stop before it); the table's title says
which evaluations the rows come from (JSON: ``at_evaluation``). The far-part column (completion on what only
robots beyond a map's graph neighbours saw) is shown when some run has it.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
from pathlib import Path
from typing import Any, Sequence

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

AGENT_COLUMNS = (("completion_ratio_pct", "completion %"), ("artifacts_cm", "artifacts cm"),
                 ("holes_cm", "holes cm"), ("own_coverage_pct", "own coverage %"),
                 ("completion_own_pct", "own part compl. %"), ("completion_unseen_pct", "unseen part compl. %"),
                 ("completion_far_pct", "far part compl. %"))
"""Per-map metrics (key, column title): the paper's three (eq. in docs/ALGORITHM.md, cm and %)
and what communication brought (docs/ALGORITHM.md section 5, "Coverage parts")."""
OPTIONAL_COLUMNS = ("completion_far_pct",)
"""Columns the table shows only when some run has a value (runs on a graph with a far part)."""


def add_parser(sub) -> None:
    p = sub.add_parser("compare", help="compare runs: metrics table and completion over time",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders (or their metrics.json)")
    p.add_argument("--labels", default=None, help="comma-separated names for the runs (default: folder names)")
    p.add_argument("--plot", default="compare_completion.png",
                   help="where to write the completion-over-time plot (.png, .svg, .pdf; default: %(default)s)")
    p.add_argument("--no-plot", action="store_true", help="print the table only")
    p.add_argument("--json", action="store_true", help="print the rows as JSON on stdout instead of a table")
    p.add_argument("--at", type=float, default=None, metavar="T",
                   help="compare at the periodic evaluation at simulated time T (s) instead of the runs' end")
    p.set_defaults(func=run)


def _labels(paths: Sequence[Path], labels: Sequence[str] | None) -> list[str]:
    if labels is not None:
        if len(labels) != len(paths):
            raise InputError(f"--labels: {len(labels)} names for {len(paths)} runs; expected one name per run.")
        return list(labels)
    names = [p.name for p in paths]
    return [n if names.count(n) == 1 else f"{n} ({i + 1})" for i, n in enumerate(names)]


def _mean_std(values: list[float]) -> tuple[float, float]:
    vals = [v for v in values if math.isfinite(v)]
    if not vals:
        return math.nan, math.nan
    m = sum(vals) / len(vals)
    return m, math.sqrt(sum((v - m) ** 2 for v in vals) / len(vals))


def _run_dir(path: str | Path) -> Path:
    p = Path(path)
    return p.parent if p.name == "metrics.json" else p


def completion_curve(result: Any) -> tuple[list[float], list[float]]:
    """(t s, mean completion ratio % over maps) from the periodic evaluations, then the final
    evaluation at the run's end (when it has one)."""
    by_t: dict[float, list[float]] = {}
    for row in result.timeline:
        v = row.get("completion_ratio_pct")
        if isinstance(v, (int, float)) and math.isfinite(v) and row.get("agent", 0) >= 0:
            by_t.setdefault(float(row["t"]), []).append(float(v))
    ts = sorted(by_t)
    ys = [sum(by_t[t]) / len(by_t[t]) for t in ts]
    final, _ = _mean_std(list(result.metric("completion_ratio_pct").values()))
    if math.isfinite(final) and (not ts or result.sim_time_s > ts[-1]):
        ts.append(float(result.sim_time_s))
        ys.append(final)
    return ts, ys


def _float(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


def _has_final(result: Any) -> bool:
    """Whether the run ended with a final evaluation (a map with a finite completion; a
    partial metrics.json flushed before a kill has none)."""
    return any(math.isfinite(_float(v)) for v in result.metric("completion_ratio_pct").values())


def at_time(result: Any, t: float, label: str) -> dict[str, Any]:
    """The per-map metrics (``<key>``, ``<key>_std``: mean and population std over maps), team
    coverage (%) and consensus error of ``result`` at its periodic evaluation at ``t`` (s), with
    ``at_evaluation`` = ``"periodic"``; at the run's end (``t`` = its ``sim_time_s``) with no
    periodic evaluation there, those of its final evaluation (``"final"``); else an InputError
    naming the run and the times it has."""
    rows = [row for row in result.timeline if row.get("agent", 0) >= 0 and abs(float(row["t"]) - t) < 1e-6]
    end = float(result.sim_time_s or 0.0)
    if not rows and abs(end - t) < 1e-6 and _has_final(result):
        return {"sim_time_s": end, "at_evaluation": "final"}  # the row's end-of-run values stand
    if not rows:
        times = sorted({float(row["t"]) for row in result.timeline})
        have = (", ".join(f"{x:g}" for x in times[:12]) + (" ..." if len(times) > 12 else "")) if times else "none"
        final = f"; the final one at its end, {end:g}" if _has_final(result) else ""
        raise InputError(f"--at {t:g}: run {label} has no evaluation at t = {t:g} s (its periodic evaluations: "
                         f"{have}{final}); expected one of those times.")
    out: dict[str, Any] = {"sim_time_s": t, "at_evaluation": "periodic"}
    for key, _ in AGENT_COLUMNS:
        out[key], out[f"{key}_std"] = _mean_std([_float(row.get(key)) for row in rows])
    out["team_coverage_pct"] = _float(rows[0].get("team_coverage_pct"))
    probes = [p for p in result.consensus_timeline if float(p["t"]) <= t + 1e-6]
    out["consensus_error"] = _float(probes[-1].get("consensus_error")) if probes else math.nan
    return out


def compare_runs(runs: Sequence[str | Path], labels: Sequence[str] | None = None,
                 at: float | None = None) -> list[dict[str, Any]]:
    """One row per run: label, folder, method, success rate, status, per-map metrics as
    ``<key>`` (mean over maps) and ``<key>_std``, team coverage %, consensus error, messages
    sent and delivered fraction, bytes sent and delivered; with ``at`` (s) the metrics, team
    coverage and consensus error are those of the periodic evaluation at that time
    (:func:`at_time`)."""
    from ramensim.api import RunOutput

    paths = [_run_dir(r) for r in runs]
    rows = []
    for label, path in zip(_labels(paths, labels), paths):
        r = RunOutput.load(path)
        row: dict[str, Any] = {"run": label, "folder": str(path), "scenario": r.scenario, "method": r.method,
                               "n_agents": r.n_agents, "seed": r.seed, "success_rate": r.success_rate,
                               "status": r.status, "sim_time_s": r.sim_time_s}
        for key, _ in AGENT_COLUMNS:
            row[key], row[f"{key}_std"] = _mean_std(list(r.metric(key).values()))
        comm = r.communication or {}
        row.update(team_coverage_pct=r.team_coverage_pct, consensus_error=r.consensus_error,
                   messages_sent=comm.get("sent", 0), delivered_fraction=comm.get("delivered_fraction"),
                   bytes_sent=comm.get("bytes_sent", 0), bytes_delivered=comm.get("bytes_delivered", 0))
        if at is not None:
            row.update(at_time(r, at, label))
        row["_build"] = getattr(r, "build", None)
        row["_curve"] = completion_curve(r)
        rows.append(row)
    return rows


def plot_completion(rows: Sequence[dict[str, Any]], out: str | Path) -> Path:
    """Completion ratio (%) over simulated time (s), one line per run."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4), dpi=120)
    ax = fig.add_subplot()
    for row in rows:
        ts, ys = row["_curve"]
        ax.plot(ts, ys, marker="o", markersize=3, label=row["run"])
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("completion ratio (%), mean over maps")
    ax.set_title("Completion over simulated time")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, title="run", title_fontsize=8)
    fig.text(0.01, 0.01, "each point is one of the run's evaluations: the periodic ones (evaluation.every_s) "
             "and the final one", fontsize=7, color="0.35")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        fig.savefig(out)
    except (ValueError, OSError) as exc:
        raise InputError(f"--plot {out}: cannot write the plot ({exc}); expected a writable .png, .svg or "
                         f".pdf path.") from None
    return out


def _fmt(v: Any, digits: int = 2) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v:.{digits}f}" if isinstance(v, float) else str(v)


def _bytes(n: Any) -> str:
    n = float(n or 0)
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return str(n)


def _warn_plugin_code(rows: Sequence[dict[str, Any]]) -> None:
    """Warn when two runs loaded the same plugin file (by name) with different code."""
    from ramensim.provenance import plugin_code_differs

    for i, a in enumerate(rows):
        for b in rows[i + 1:]:
            names = plugin_code_differs(a.get("_build"), b.get("_build"))
            if names:
                log.warning("runs %s and %s used different code of plugin %s (SHA-256 of the source differs; "
                            "the run folders' plugins/ hold each copy): they compare two versions of it",
                            a["run"], b["run"], ", ".join(names))


def run(args: argparse.Namespace) -> int:
    from ramensim.terminal import stdout_console
    from rich.table import Table

    labels = [s.strip() for s in args.labels.split(",")] if args.labels else None
    rows = compare_runs(args.runs, labels, at=args.at)
    _warn_plugin_code(rows)
    columns = [(k, t) for k, t in AGENT_COLUMNS
               if k not in OPTIONAL_COLUMNS or any(math.isfinite(_float(r[k])) for r in rows)]
    if args.json:
        print(json.dumps([{k: v for k, v in r.items() if k not in ("_curve", "_build")} | {"completion_curve": r["_curve"]}
                          for r in rows], indent=2, default=str))
    else:
        sources = sorted({r.get("at_evaluation", "final") for r in rows})
        when = "at the end" if args.at is None else (
            f"at t = {args.at:g} s, {' and '.join(sources)} evaluation{'s' if len(sources) > 1 else ''} "
            f"(messages: the runs' totals)")
        table = Table(title=f"run comparison {when} (per-map metrics: mean ± std over maps)")
        table.add_column("run")
        for title in ("method", "success", "status", *(t for _, t in columns), "team cov. %",
                      "consensus err", "delivered %", "bytes sent"):
            table.add_column(title, justify="right")
        for r in rows:
            cells = [r["run"], r["method"], _fmt(r["success_rate"]), r["status"]]
            cells += [f"{_fmt(r[k])} ± {_fmt(r[k + '_std'])}" if r[k] == r[k] else "-" for k, _ in columns]
            frac = r["delivered_fraction"]
            cells += [_fmt(r["team_coverage_pct"], 1), _fmt(r["consensus_error"], 4),
                      "-" if frac is None else _fmt(100 * frac, 1), _bytes(r["bytes_sent"])]
            table.add_row(*cells)
        # a pipe or file gets the whole table rather than rich's 80 columns
        stdout_console().print(table)
    if not args.no_plot:
        few = []
        for r in rows:
            n = len(r["_curve"][0])
            if n < 3:
                few.append(f"run {r['run']} has {n} evaluation{'' if n == 1 else 's'} over its "
                           f"{r['sim_time_s'] or 0:.0f} simulated s, so its completion curve has "
                           + ("one point, the final value" if n < 2 else f"only {n} points"))
        if few:  # the hint once, however many runs it concerns
            log.warning("%s; run %s with --set evaluation.every_s=S (S well below the duration) for a curve over "
                        "time", "; ".join(few), "it" if len(few) == 1 else "them")
        out = plot_completion(rows, args.plot)
        if not args.json:
            stdout_console().print(f"completion over simulated time: {out}")
    return 0
