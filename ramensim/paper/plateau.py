"""Where a run's consensus error levels off, run by run (a cause study, docs/results/table1.md
and fig5.md, "Why RAMEN's consensus error levels off" and "The consensus error with every message
delivered"; ``ramensim paper plateau``): the last probe alone is one noisy sample of the level, so
this also averages the probes of a late window.

For each run folder (or its metrics.json) it reads ``consensus_timeline`` (a probe every
``consensus_probe_s``, 2 s by default: the unweighted error CE-1 and the error weighted by
eq. 19's weights CE-2, docs/ALGORITHM.md, both RMS over parameters, in the map's parameter
units) and gives, per error: the peak (largest probe), the end (the run's final value,
metrics.json's top-level ``consensus_error`` / ``consensus_error_weighted``, taken at the run's
end; the last probe where a run has none), their ratio (the claim's "falls >= 10x from its
peak", as ``ramensim claims`` judges it) and the mean and population std of the probes with
``t >= t_from`` (simulated s). Outputs: ``consensus_plateau.json`` and ``consensus_plateau.md``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ramensim.core.errors import InputError

ERRORS = (("consensus_error", "CE-1"), ("consensus_error_weighted", "CE-2"))
"""The two errors of a probe (metrics.json key, name in docs/ALGORITHM.md)."""


def read_probes(run: Path) -> tuple[str, list[dict[str, Any]], dict[str, Any]]:
    """(the run's label, its consensus probes, its final values by error key) from a run folder
    or its metrics.json; :class:`InputError` naming a missing or malformed file."""
    path = run / "metrics.json" if run.is_dir() else run
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected a finished run folder holding metrics.json, "
                         f"or the file itself.")
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not readable as JSON ({exc}); expected a ramensim metrics.json.") from None
    probes = data.get("consensus_timeline") if isinstance(data, dict) else None
    if not isinstance(probes, list) or not probes:
        raise InputError(f"{path}: key 'consensus_timeline' is missing or empty; expected the list of "
                         f"consensus probes a run of two or more communicating robots writes.")
    return path.parent.name, probes, {key: data.get(key) for key, _ in ERRORS}


def plateau(probes: list[dict[str, Any]], t_from: float, key: str, end: Any = None) -> dict[str, Any]:
    """Peak, end (``end`` when finite, else the last probe), their ratio, and mean / population
    std / count of the probes at ``t >= t_from`` (s) of one error ``key``; probes without a
    finite value are skipped."""
    pts = [(float(p["t"]), float(p[key])) for p in probes
           if isinstance(p.get(key), (int, float)) and math.isfinite(p[key]) and "t" in p]
    if not pts:
        return {"peak": math.nan, "end": math.nan, "ratio": math.nan, "mean": math.nan, "std": math.nan, "n": 0}
    values = np.array([v for _, v in pts])
    late = np.array([v for t, v in pts if t >= t_from])
    peak = float(values.max())
    last = float(end) if isinstance(end, (int, float)) and math.isfinite(end) else float(values[-1])
    return {"peak": peak, "end": last, "ratio": peak / last if last > 0 else math.nan,
            "mean": float(late.mean()) if late.size else math.nan,
            "std": float(late.std()) if late.size else math.nan, "n": int(late.size)}


def render(rows: list[dict[str, Any]], t_from: float) -> str:
    """One Markdown row per run: each error's peak -> end (ratio) and its late mean +- std from ``t_from`` s."""
    head = " | ".join(f"{name} peak → end | {name} mean ± std from {t_from:g} s" for _, name in ERRORS)
    lines = [f"Consensus error: peak, end of run and the level from {t_from:g} s on", "",
             f"| run | {head} | probes |", "|---|" + "---|---:|" * len(ERRORS) + "---:|"]
    for r in rows:
        cells = []
        for key, _ in ERRORS:
            e = r[key]
            cells += [f"{e['peak']:.4f} → {e['end']:.4f} ({e['ratio']:.1f}x)", f"{e['mean']:.4f} ± {e['std']:.4f}"]
        lines.append(f"| {r['run']} | " + " | ".join(cells) + f" | {r[ERRORS[0][0]]['n']} |")
    return "\n".join(lines) + "\n"


def analyse(runs: list[Path], t_from: float) -> dict[str, Any]:
    """The study of several runs (folders or their metrics.json): ``{"from_s", "runs": [...]}``,
    per run its label, folder and :func:`plateau` of each error with the late window from
    ``t_from`` simulated s; :class:`InputError` for a ``t_from`` that is not finite or a run
    that cannot be read."""
    if not math.isfinite(t_from):
        raise InputError(f"--from {t_from}: expected a finite number of simulated seconds.")
    rows = []
    for run in runs:
        label, probes, ends = read_probes(run)
        rows.append({"run": label, "folder": str(run)}
                    | {key: plateau(probes, t_from, key, ends[key]) for key, _ in ERRORS})
    return {"from_s": t_from, "runs": rows}
