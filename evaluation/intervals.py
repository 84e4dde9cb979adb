"""Paired 95 % intervals over trials and the three-way verdict a claim gets from them.

A claim compares one quantity per trial (a trial: one run seed on one house layout; e.g. RAMEN's
team completion minus centralised's, in points) against a threshold on one side. Over the
trials the quantity gets an interval:

- :func:`t_interval`: Student t over the per-trial values (for a difference of two methods run
  on the same trial, the paired t interval): ``mean ± t_{n-1, 0.975} s / sqrt(n)``, ``s`` the
  sample standard deviation (ddof = 1); units those of the values.
- :func:`ratio_interval`: the same over ``log`` of positive per-trial ratios, mapped back: an
  interval on the geometric mean ratio (dimensionless, e.g. a fall of the consensus error).
- :func:`bootstrap_interval`: a statistic of all trials together (e.g. the standard deviation
  pooled over every robot of every trial, as Table I reports it) resampled over whole trials,
  so a trial's runs stay paired; percentile interval. With ``n`` trials and ``n^n`` at most
  :data:`EXACT_MAX` every resample is enumerated (exact, no random numbers); beyond that
  :data:`RESAMPLES` resamples from a generator seeded with ``seed``.

**Independent units.** Trials are the repetitions a table pools; the *unit* is what makes two
trials independent. Two house layouts run with one run seed meet the same channel realisation
(the channel's draws are keyed by the run seed, link and send time) and the same map
initialisation, so they are one unit, not two. :func:`nest` averages the per-trial values within
each unit first (eq. U-1: ``x_u = mean_{trials i of u} x_i``; for ratios the geometric mean, for
a pooled std the unit's robots pooled), and the intervals above are then taken over the units:
``n`` is the count of independent units.

:func:`verdict`: *holds* when the interval clears the threshold on the claim's side, *fails*
when it lies wholly on the wrong side, *inconclusive* when it straddles it or when there is no
interval (fewer than two trials).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

LEVEL = 0.95
"""Two-sided confidence level of every interval."""
EXACT_MAX = 1_000_000
"""Largest number of resamples (``n^n``) the bootstrap enumerates exactly."""
RESAMPLES = 20_000
"""Resamples drawn when ``n^n`` exceeds :data:`EXACT_MAX`."""
HOLDS, FAILS, INCONCLUSIVE = "holds", "fails", "inconclusive"
SIDES = (">=", ">", "<=", "<")


@dataclass(frozen=True)
class Interval:
    """An estimate with its two-sided :data:`LEVEL` interval over ``n`` trials (``lo``/``hi``
    NaN when ``n`` < 2: no interval). ``method``: ``"t"``, ``"t on log"`` or ``"bootstrap"``."""
    estimate: float
    lo: float
    hi: float
    n: int
    method: str

    @property
    def defined(self) -> bool:
        return self.n >= 2 and math.isfinite(self.lo) and math.isfinite(self.hi)


def _finite(values: Sequence[float]) -> np.ndarray:
    arr = np.asarray([float(v) for v in values], dtype=np.float64)
    return arr[np.isfinite(arr)]


def nest(values: Sequence[Any], units: Sequence[Any], kind: str = "t") -> list[Any]:
    """Per-trial ``values`` grouped by their independent ``units`` (eq. U-1 of the module
    docstring), in the order units first appear: ``kind`` ``"t"`` gives each unit the mean of its
    trials' finite values (NaN if none), ``"ratio"`` the geometric mean of its positive finite
    ratios, ``"pooled std"`` one ``(a values, b values)`` pair holding all its trials' robots.
    Values keep their units (points, %, a dimensionless ratio); with one trial per unit the
    values come back unchanged."""
    if len(values) != len(units):
        raise ValueError(f"nest: {len(values)} values but {len(units)} unit labels")
    groups: dict[Any, list[Any]] = {}
    for v, u in zip(values, units):
        groups.setdefault(u, []).append(v)
    out: list[Any] = []
    for vs in groups.values():
        if len(vs) == 1:
            out.append(vs[0])
        elif kind == "pooled std":
            out.append(([x for a, _ in vs for x in a], [x for _, b in vs for x in b]))
        elif kind == "ratio":
            x = _finite(vs)
            x = x[x > 0.0]
            out.append(float(np.exp(np.log(x).mean())) if x.size else math.nan)
        else:
            x = _finite(vs)
            out.append(float(x.mean()) if x.size else math.nan)
    return out


def _t_quantile(df: int, level: float) -> float:
    from scipy.stats import t

    return float(t.ppf(0.5 + level / 2.0, df))


def t_interval(values: Sequence[float], level: float = LEVEL) -> Interval:
    """Student t interval of the mean of the per-trial ``values`` (non-finite ones left out)."""
    x = _finite(values)
    n = int(x.size)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0, "t")
    mean = float(x.mean())
    if n < 2:
        return Interval(mean, math.nan, math.nan, n, "t")
    half = _t_quantile(n - 1, level) * float(x.std(ddof=1)) / math.sqrt(n)
    return Interval(mean, mean - half, mean + half, n, "t")


def ratio_interval(ratios: Sequence[float], level: float = LEVEL) -> Interval:
    """Student t interval over ``log`` of positive per-trial ratios, exponentiated: the geometric
    mean ratio and its interval (ratios that are not positive and finite are left out)."""
    x = _finite(ratios)
    got = t_interval(np.log(x[x > 0.0]), level)
    return Interval(math.exp(got.estimate) if got.n else math.nan, math.exp(got.lo) if got.defined else math.nan,
                    math.exp(got.hi) if got.defined else math.nan, got.n, "t on log")


def bootstrap_interval(trials: Sequence[Any], statistic: Callable[[Sequence[Any]], float],
                       level: float = LEVEL, seed: int = 0) -> Interval:
    """Percentile bootstrap interval of ``statistic`` over resamples of whole ``trials`` (with
    replacement, ``n`` of ``n``): every resample when ``n^n`` ≤ :data:`EXACT_MAX`, else
    :data:`RESAMPLES` drawn with ``numpy.random.default_rng(seed)``. The estimate is the statistic
    of the trials as they are."""
    n = len(trials)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0, "bootstrap")
    estimate = float(statistic(trials))
    if n < 2:
        return Interval(estimate, math.nan, math.nan, n, "bootstrap")
    if n ** n <= EXACT_MAX:
        picks: Any = itertools.product(range(n), repeat=n)
    else:
        picks = np.random.default_rng(seed).integers(0, n, size=(RESAMPLES, n))
    stats = np.array([statistic([trials[i] for i in pick]) for pick in picks], dtype=np.float64)
    stats = stats[np.isfinite(stats)]
    if stats.size == 0:
        return Interval(estimate, math.nan, math.nan, n, "bootstrap")
    lo, hi = np.quantile(stats, [0.5 - level / 2.0, 0.5 + level / 2.0])
    return Interval(estimate, float(lo), float(hi), n, "bootstrap")


def pooled_std_interval(trials: Sequence[tuple[Sequence[float], Sequence[float]]], level: float = LEVEL,
                        seed: int = 0) -> Interval:
    """:func:`bootstrap_interval` of :func:`pooled_std_difference` over whole trials, computed from
    each trial's counts, sums and sums of squares (the same numbers, vectorised: a resample's
    pooled variance is ``Q/N - (S/N)^2`` of its trials' totals, values centred first)."""
    n = len(trials)
    estimate = pooled_std_difference(trials) if n else math.nan
    if n < 2:
        return Interval(estimate, math.nan, math.nan, n, "bootstrap")
    if n ** n <= EXACT_MAX:
        idx = np.array(list(itertools.product(range(n), repeat=n)), dtype=np.int64)
    else:
        idx = np.random.default_rng(seed).integers(0, n, size=(RESAMPLES, n))
    counts = np.zeros((idx.shape[0], n))
    np.add.at(counts, (np.repeat(np.arange(idx.shape[0]), n), idx.ravel()), 1.0)

    def std(side: int) -> np.ndarray:
        per = [_finite(tr[side]) for tr in trials]
        every = np.concatenate(per) if per else np.zeros(0)
        centre = float(every.mean()) if every.size else 0.0
        k = np.array([p.size for p in per], dtype=np.float64)
        s = np.array([(p - centre).sum() for p in per])
        q = np.array([((p - centre) ** 2).sum() for p in per])
        big_n, big_s, big_q = counts @ k, counts @ s, counts @ q
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.sqrt(np.maximum(big_q / big_n - (big_s / big_n) ** 2, 0.0))

    stats = std(0) - std(1)
    stats = stats[np.isfinite(stats)]
    if stats.size == 0:
        return Interval(estimate, math.nan, math.nan, n, "bootstrap")
    lo, hi = np.quantile(stats, [0.5 - level / 2.0, 0.5 + level / 2.0])
    return Interval(estimate, float(lo), float(hi), n, "bootstrap")


def pooled_std_difference(trials: Sequence[tuple[Sequence[float], Sequence[float]]]) -> float:
    """Population standard deviation (ddof = 0, as Table I's) of every ``a`` value of every trial,
    minus that of every ``b`` value; ``trials``: per trial ``(a values, b values)``, e.g. each
    robot's completion (%) under two methods. NaN when either side has no finite value."""
    a = _finite([v for tr in trials for v in tr[0]])
    b = _finite([v for tr in trials for v in tr[1]])
    return float(a.std() - b.std()) if a.size and b.size else math.nan


def verdict(interval: Interval, threshold: float, side: str) -> str:
    """:data:`HOLDS` when the interval clears ``threshold`` on ``side`` (``">="``: ``lo`` ≥ it;
    ``">"``: ``lo`` > it; ``"<="``: ``hi`` ≤ it; ``"<"``: ``hi`` < it), :data:`FAILS` when it lies
    wholly on the other side, :data:`INCONCLUSIVE` when it straddles the threshold or is undefined."""
    if side not in SIDES:
        raise ValueError(f"side must be one of {SIDES}, not {side!r}")
    if not interval.defined:
        return INCONCLUSIVE
    lo, hi = interval.lo, interval.hi
    if side == ">=":
        ok, bad = lo >= threshold, hi < threshold
    elif side == ">":
        ok, bad = lo > threshold, hi <= threshold
    elif side == "<=":
        ok, bad = hi <= threshold, lo > threshold
    else:
        ok, bad = hi < threshold, lo >= threshold
    return HOLDS if ok else (FAILS if bad else INCONCLUSIVE)


def combine(verdicts: Sequence[str]) -> str:
    """A claim that needs several comparisons at once: fails if any fails, holds if all hold,
    else inconclusive (and inconclusive without any)."""
    if any(v == FAILS for v in verdicts):
        return FAILS
    if verdicts and all(v == HOLDS for v in verdicts):
        return HOLDS
    return INCONCLUSIVE
