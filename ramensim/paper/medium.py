"""What a shared medium does to the paper's comparisons (issue 66, item 5): the tables of
docs/results/medium.md from archived sweeps of scenarios/sweeps/medium/ (``ramensim paper medium``).

:func:`read` takes every ``runs/<point>/metrics.json`` of the archives (points named
``seed=S__variant=M_K``: method M, medium K) and per run the team mean (mean over its robots) of
the completion ratio (%) and of the completion on the part only teammates saw (%), the messages
delivered, the median age of a copy on arrival (s), the consensus error and the collision domain's
busy fraction; :func:`tables` writes Markdown tables: per variant the mean over trials with a 95 %
Student t interval (``ramensim.evaluation.intervals.t_interval``; a trial = a run seed, its runs
share the channel's coins), then the paired differences over trials that decide the verdicts: each
medium minus the reference medium for one method, and RAMEN minus DiNNO on each medium.
"""
from __future__ import annotations

import json
import re
from collections import defaultdict
from pathlib import Path

from ramensim.core.errors import InputError
from ramensim.evaluation.intervals import t_interval

_POINT = re.compile(r"seed=(?P<seed>\d+)__variant=(?P<method>[a-z]+)_(?P<medium>[a-z0-9_]+)$")


def _team(metrics: dict, key: str) -> float:
    """The mean over a run's robots of ``key`` (NaN when no robot has it)."""
    vals = [a.get(key) for a in metrics["per_agent"].values()]
    vals = [float(v) for v in vals if v is not None]
    return sum(vals) / len(vals) if vals else float("nan")


def read(*archives: Path) -> dict[tuple[str, str], dict[int, dict[str, float]]]:
    """(method, medium) -> run seed -> figures of that run, over every archive given: completion and
    unseen (%), delivered (messages), age_p50 (s), consensus (parameter units), busy (fraction),
    diverged (robots); :class:`InputError` naming a metrics.json that cannot be read."""
    out: dict[tuple[str, str], dict[int, dict[str, float]]] = defaultdict(dict)
    for f in sorted(f for a in archives for f in (a / "runs").glob("*/metrics.json")):
        m = _POINT.match(f.parent.name)
        if m is None:
            continue
        try:
            out[(m["method"], m["medium"])][int(m["seed"])] = _figures(json.loads(f.read_text()))
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise InputError(f"{f}: not a readable run result ({type(exc).__name__}: {exc}); expected the "
                             f"metrics.json of a finished run (per_agent, communication).") from None
    return out


def _figures(metrics: dict) -> dict[str, float]:
    """One run's figures (see :func:`read`) from its metrics.json."""
    comm = metrics.get("communication", {})
    med = comm.get("medium") or {}
    busy = max((d["busy_fraction"] for d in med.get("domains", [])), default=float("nan"))
    age = (comm.get("age_s") or {}).get("p50")
    return {
        "completion": _team(metrics, "completion_ratio_pct"),
        "unseen": _team(metrics, "completion_unseen_pct"),
        "delivered": float(comm.get("delivered", float("nan"))),
        "age_p50": float(age) if age is not None else float("nan"),
        "consensus": float(metrics.get("consensus_error") or float("nan")),
        "busy": busy,
        "diverged": float(len(metrics.get("diverged_agents") or [])),
    }


def _fmt(iv, digits: int = 2) -> str:
    """An interval as "estimate [lo, hi]", or "estimate (n = N)" where it is not defined."""
    if not iv.defined:
        return f"{iv.estimate:.{digits}f} (n = {iv.n})"
    return f"{iv.estimate:.{digits}f} [{iv.lo:.{digits}f}, {iv.hi:.{digits}f}]"


def _signed(iv) -> str:
    """A difference's interval with signs, as :func:`_fmt`."""
    if not iv.defined:
        return f"{iv.estimate:+.2f} (n = {iv.n})"
    return f"{iv.estimate:+.2f} [{iv.lo:+.2f}, {iv.hi:+.2f}]"


def _paired(a: dict[int, dict[str, float]], b: dict[int, dict[str, float]], key: str):
    """The t interval of ``a - b`` of ``key`` over the run seeds both have, and those seeds."""
    seeds = sorted(set(a) & set(b))
    return t_interval([a[s][key] - b[s][key] for s in seeds]), seeds


def tables(runs: dict[tuple[str, str], dict[int, dict[str, float]]], reference: str) -> str:
    """The page's tables (Markdown) of :func:`read`'s runs, differences against the medium ``reference``."""
    lines = ["| method | medium | trials | completion % | part only teammates saw % | delivered | copy age p50 s "
             "| consensus error | busy |", "|---|---|---|---|---|---|---|---|---|"]
    order = sorted(runs, key=lambda k: (k[0] != "ramen", k[0], k[1] != reference, k[1]))
    for key in order:
        trials = runs[key]
        col = {c: t_interval([t[c] for t in trials.values()]) for c in
               ("completion", "unseen", "delivered", "age_p50", "consensus", "busy")}
        lines.append(f"| {key[0]} | {key[1]} | {len(trials)} | {_fmt(col['completion'])} | {_fmt(col['unseen'])} | "
                     f"{col['delivered'].estimate:.0f} | {col['age_p50'].estimate:.1f} | "
                     f"{col['consensus'].estimate:.4f} | "
                     + ("-" if col['busy'].estimate != col['busy'].estimate else f"{col['busy'].estimate:.3f}")
                     + " |")
    lines += ["", "Paired over trials (same run seed: the same message coins), completion ratio, points:", "",
              "| comparison | trials | difference [95 %] |", "|---|---|---|"]
    methods = sorted({m for m, _ in runs})
    media = sorted({k for _, k in runs}, key=lambda k: (k != reference, k))
    for m in methods:
        for k in media:
            if k == reference or (m, k) not in runs or (m, reference) not in runs:
                continue
            iv, seeds = _paired(runs[(m, k)], runs[(m, reference)], "completion")
            lines.append(f"| {m}: {k} − {reference} | {len(seeds)} | {_signed(iv)} |")
    for k in media:  # a variant of RAMEN (e.g. at DiNNO's bytes) against RAMEN and DiNNO on the same medium
        for m in methods:
            if m in ("ramen", "dinno") or (m, k) not in runs:
                continue
            for other in ("ramen", "dinno"):
                if (other, k) in runs:
                    iv, seeds = _paired(runs[(m, k)], runs[(other, k)], "completion")
                    lines.append(f"| {m} − {other} on {k} | {len(seeds)} | {_signed(iv)} |")
    if "ramen" in methods and "dinno" in methods:
        for k in media:
            if ("ramen", k) in runs and ("dinno", k) in runs:
                iv, seeds = _paired(runs[("ramen", k)], runs[("dinno", k)], "completion")
                lines.append(f"| RAMEN − DiNNO on {k} | {len(seeds)} | {_signed(iv)} |")
        for k in media:
            if k == reference or ("ramen", k) not in runs or ("dinno", k) not in runs:
                continue
            seeds = sorted(set(runs[("ramen", k)]) & set(runs[("dinno", k)]) & set(runs[("ramen", reference)])
                           & set(runs[("dinno", reference)]))
            lead = [(runs[("ramen", k)][s]["completion"] - runs[("dinno", k)][s]["completion"])
                    - (runs[("ramen", reference)][s]["completion"] - runs[("dinno", reference)][s]["completion"])
                    for s in seeds]
            lines.append(f"| RAMEN's lead on {k} − on {reference} | {len(seeds)} | {_signed(t_interval(lead))} |")
    return "\n".join(lines) + "\n"
