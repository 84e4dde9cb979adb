"""Aggregation of per-agent numbers (paper section V: "mean and standard deviation over agents
and trials"), the consensus error between agents' parameters, and a bytes-on-the-air summary."""
from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ramensim.evaluation.mesh import to_numpy

Stats = dict[str, float | int]
"""``{"mean", "std", "min", "max", "n", "n_nan"}`` of one metric."""


def _stats(values: Sequence[float], ddof: int) -> Stats:
    arr = np.asarray([float(v) for v in values], dtype=np.float64)
    finite = arr[np.isfinite(arr)]
    n = int(finite.size)
    out: Stats = {"mean": math.nan, "std": math.nan, "min": math.nan, "max": math.nan,
                  "n": n, "n_nan": int(arr.size - n)}
    if n:
        out["mean"] = float(finite.mean())
        out["min"] = float(finite.min())
        out["max"] = float(finite.max())
        out["std"] = float(finite.std(ddof=ddof)) if n > ddof else math.nan
    return out


def finite_values(values: Iterable[Any] | None) -> list[float]:
    """The finite numbers among ``values`` (one per robot of a run, or one per run), in order:
    None, non-numbers, booleans, NaN and infinities (a diverged robot's) are left out."""
    out = []
    for v in values or ():
        if _is_number(v) and math.isfinite(float(v)):
            out.append(float(v))
    return out


def finite_mean(values: Iterable[Any] | None) -> float:
    """The mean of :func:`finite_values` (a run's team mean over its robots, in the metric's
    unit); NaN when there is none."""
    vals = finite_values(values)
    return math.fsum(vals) / len(vals) if vals else math.nan


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def summarize_agents(per_agent: Mapping[Any, Mapping[str, Any]], ddof: int = 0) -> dict[str, Stats]:
    """Mean and standard deviation over agents of every numeric metric.

    ``per_agent`` maps agent id -> {metric name: value}. Non-numeric entries (e.g. the
    metrics' ``reason``) are skipped; NaN values (a failed evaluation) are left out of the
    statistics and counted in ``n_nan``. ``std`` is the standard deviation with ``ddof``
    degrees of freedom (0: population std, numpy's default; 1: sample std; NaN when fewer
    than ddof + 1 values). Returns {metric: {"mean", "std", "min", "max", "n", "n_nan"}}.
    """
    return summarize_runs([per_agent], ddof=ddof)


def summarize_runs(runs: Sequence[Mapping[Any, Mapping[str, Any]]], ddof: int = 0) -> dict[str, Stats]:
    """Mean and standard deviation over agents and trials: every (trial, agent) value of a
    metric is pooled into one sample (as the paper reports "over agents and trials").

    ``runs`` is one ``per_agent`` mapping per trial (see :func:`summarize_agents`). Adds
    ``n_trials`` to each metric's stats.
    """
    pooled: dict[str, list[float]] = {}
    for per_agent in runs:
        for metrics in per_agent.values():
            for key, value in metrics.items():
                if _is_number(value):
                    pooled.setdefault(key, []).append(float(value))
    out: dict[str, Stats] = {}
    for key, values in pooled.items():
        stats = _stats(values, ddof)
        stats["n_trials"] = len(runs)
        out[key] = stats
    return out


def consensus_error(thetas: Sequence[Any]) -> float:
    """Disagreement between the agents' flattened parameter vectors theta_1..theta_m.

    Exactly: the root mean square, over all unordered pairs i < j and all n coordinates k,
    of theta_i[k] - theta_j[k]::

        sqrt( (1 / (P n)) * sum_{i<j} ||theta_i - theta_j||^2 ),   P = m (m - 1) / 2,

    computed without forming pairs via sum_{i<j} ||theta_i - theta_j||^2
    = m * sum_i ||theta_i - mean||^2, in float64. Units are those of the parameters.
    Each entry may be a numpy array or a torch tensor (any shape, flattened); all must
    hold the same number of values. Fewer than two agents -> 0.0 (no pair disagrees).
    """
    if len(thetas) < 2:
        return 0.0
    flat = [to_numpy(t).astype(np.float64, copy=False).reshape(-1) for t in thetas]
    n = flat[0].size
    if any(f.size != n for f in flat):
        raise ValueError(f"consensus_error: parameter vectors of sizes {[f.size for f in flat]}; "
                         f"expected every agent's theta to hold the same number of values.")
    if n == 0:
        return 0.0
    m = len(flat)
    mean = np.zeros(n)
    for f in flat:
        mean += f
    mean /= m
    spread = sum(float(np.dot(f - mean, f - mean)) for f in flat)
    pairs = m * (m - 1) / 2
    return math.sqrt(m * spread / (pairs * n))


def airtime_summary(sent_bytes: Iterable[int], delivered_bytes: Iterable[int],
                    dropped_bytes: Mapping[str, Iterable[int]] | Iterable[int],
                    duration_s: float) -> dict[str, float | int | dict[str, int]]:
    """Bytes on the air over a run of ``duration_s`` simulated seconds.

    ``sent_bytes`` / ``delivered_bytes``: the size in bytes of each message sent / delivered;
    ``dropped_bytes``: sizes of the dropped messages, optionally grouped by drop reason.
    Returns message and byte counts, ``delivery_ratio`` (delivered / sent messages, NaN
    if none was sent), ``sent_rate_Bps`` and ``delivered_rate_Bps`` (bytes per simulated
    second) and ``dropped_by_reason`` (message counts).
    """
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"airtime_summary: duration_s = {duration_s!r}; expected a positive number "
                         f"of simulated seconds.")
    sent = [int(b) for b in sent_bytes]
    deliv = [int(b) for b in delivered_bytes]
    if isinstance(dropped_bytes, Mapping):
        groups = {str(k): [int(b) for b in v] for k, v in dropped_bytes.items()}
    else:
        groups = {"all": [int(b) for b in dropped_bytes]}
    dropped = [b for g in groups.values() for b in g]
    return {
        "messages_sent": len(sent),
        "messages_delivered": len(deliv),
        "messages_dropped": len(dropped),
        "bytes_sent": int(sum(sent)),
        "bytes_delivered": int(sum(deliv)),
        "bytes_dropped": int(sum(dropped)),
        "delivery_ratio": len(deliv) / len(sent) if sent else math.nan,
        "sent_rate_Bps": sum(sent) / duration_s,
        "delivered_rate_Bps": sum(deliv) / duration_s,
        "dropped_by_reason": {k: len(v) for k, v in groups.items()},
    }
