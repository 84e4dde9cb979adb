"""Where a run's consensus error levels off, run by run (a cause analysis, docs/RESULTS.md,
"Why RAMEN's consensus error levels off" and "The consensus error with every message
delivered"): the last probe alone is one noisy sample of the level, so this also averages the
probes of a late window.

For each run folder (or its metrics.json) it reads ``consensus_timeline`` (a probe every
``consensus_probe_s``, 2 s by default: the unweighted error CE-1 and the error weighted by
eq. 19's weights CE-2, docs/ALGORITHM.md, both RMS over parameters, in the map's parameter
units) and gives, per error: the peak (largest probe), the end (the run's final value,
metrics.json's top-level ``consensus_error`` / ``consensus_error_weighted``, taken at the run's
end; the last probe where a run has none), their ratio (the claim's "falls >= 10x from its
peak", as ``ramensim claims`` judges it) and the mean and population std of the probes with
``t >= --from`` (simulated s).

    python tools/consensus_plateau.py RUN [RUN ...] [--from 400] [--out DIR]

Writes ``consensus_plateau.json`` and ``consensus_plateau.md`` into ``--out`` (default: print only).
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from _cause import write_outputs

log = logging.getLogger("consensus_plateau")

ERRORS = (("consensus_error", "CE-1"), ("consensus_error_weighted", "CE-2"))
"""The two errors of a probe (metrics.json key, name in docs/ALGORITHM.md)."""


class InputProblem(Exception):
    """A missing or malformed metrics.json (reported as one paragraph, exit 2)."""


def read_probes(run: Path) -> tuple[str, list[dict[str, Any]], dict[str, Any]]:
    """(the run's label, its consensus probes, its final values by error key) from a run folder
    or its metrics.json."""
    path = run / "metrics.json" if run.is_dir() else run
    if not path.is_file():
        raise InputProblem(f"{path}: no such file; expected a finished run folder holding metrics.json, "
                           f"or the file itself.")
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise InputProblem(f"{path}: not readable as JSON ({exc}); expected a ramensim metrics.json.") from None
    probes = data.get("consensus_timeline") if isinstance(data, dict) else None
    if not isinstance(probes, list) or not probes:
        raise InputProblem(f"{path}: key 'consensus_timeline' is missing or empty; expected the list of "
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="finished run folders (or their metrics.json)")
    ap.add_argument("--from", dest="t_from", type=float, default=400.0,
                    help="start of the late window, simulated s (default 400)")
    ap.add_argument("--out", type=Path, default=None, help="write consensus_plateau.json / .md here")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if not math.isfinite(args.t_from):
        log.error("consensus_plateau: --from %s: expected a finite number of simulated seconds.", args.t_from)
        return 2
    rows = []
    try:
        for run in args.runs:
            label, probes, ends = read_probes(run)
            rows.append({"run": label, "folder": str(run)}
                        | {key: plateau(probes, args.t_from, key, ends[key]) for key, _ in ERRORS})
    except InputProblem as exc:
        log.error("consensus_plateau: %s", exc)
        return 2
    write_outputs(args.out, "consensus_plateau", {"from_s": args.t_from, "runs": rows}, render(rows, args.t_from))
    return 0


if __name__ == "__main__":
    sys.exit(main())
