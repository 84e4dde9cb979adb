"""What a claim is and how one is judged on numbers: the protocol's trials, the metrics' keys,
a claim's comparisons (:class:`Test`: a quantity against a threshold on one side, with the interval
it is judged by) and the claim itself (:class:`Claim`: its trials' values, the independent units
and the verdict), the per-run helpers every rule reads (team and per-robot completion, %), and the
four rules the sensitivity table judges again under other settings (:data:`CENTRAL_GAP`,
:data:`DINNO_LEAD`, :data:`RAMEN_DROP`, :data:`ABOVE_LOCAL`, points).

Completion is the paper's completion ratio (%, 5 cm); artifacts are in cm; a difference of two
completions is in points. The verdicts and intervals are ``evaluation/intervals.py``'s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from statistics import fmean
from typing import Any, Sequence

from ramensim.evaluation.summary import finite_values

TRIALS = [(s, lay) for s in (0, 1, 2) for lay in (0, 1)]
"""The protocol's trials: (run seed, house layout = ``world.scene.seed``)."""
COMPLETION, UNSEEN, ARTIFACTS = "completion_ratio_pct", "completion_unseen_pct", "artifacts_cm"
FAR = "completion_far_pct"
"""Completion on what only robots beyond a map's graph neighbours saw (runs made after 2026-11-25)."""
RATES = (1.0, 0.8, 0.6, 0.4, 0.2, 0.05, 0.01)
"""Fig. 5's success rates."""
MIXED, UNRECORDED = "†", "‡"
"""Mark a trial whose compared runs ran on different hosts (``ramensim.provenance.same_host``), and
one with a run whose metrics.json has no ``build`` record (archived before 2026-11-25)."""


class Unjudgeable(Exception):
    """A run lacks what a rule needs: the trial is not judged and the run is named."""


@dataclass
class Test:
    """One comparison of a claim: ``what`` (the quantity, with its unit) against ``threshold`` on
    ``side`` (``>=``, ``>``, ``<=``, ``<``). ``kind``: ``"t"`` (the per-trial value is a number;
    Student t), ``"ratio"`` (a positive ratio; t on its log) or ``"pooled std"`` (the per-trial
    value is ``(a values, b values)``; bootstrap over trials of the pooled std of ``a`` minus ``b``)."""
    what: str
    threshold: float
    side: str
    kind: str = "t"

    def interval(self, samples: Sequence[Any]):
        """The 95 % interval of ``samples`` (one value per independent unit) by :attr:`kind`; a pooled
        std over fewer than :data:`BOOTSTRAP_MIN_UNITS` units has no ends."""
        from ramensim.evaluation import intervals

        if self.kind == "ratio":
            return intervals.ratio_interval(samples)
        if self.kind == "pooled std":
            got = intervals.pooled_std_interval(list(samples))
            if got.n < BOOTSTRAP_MIN_UNITS:  # too few distinct resamples for percentile ends
                return intervals.Interval(got.estimate, math.nan, math.nan, got.n, got.method)
            return got
        return intervals.t_interval(samples)

    def clears(self, value: Any) -> bool:
        """Whether one trial's value is on the claim's side (the per-trial ✓)."""
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            return False
        t = self.threshold
        return {">=": value >= t, ">": value > t, "<=": value <= t, "<": value < t}[self.side]

    def describe(self, iv) -> str:
        """The quantity cell of claims.md: ``what: estimate [lo, hi], side threshold to hold (method)``."""
        if iv.n == 0:
            return f"{self.what}: —"
        if self.kind == "ratio":
            est = f"{iv.estimate:.1f}x"
            span = f" [{iv.lo:.1f}, {iv.hi:.1f}]" if iv.defined else " (no interval: one unit)"
        else:
            est = f"{iv.estimate:+.2f}"
            span = f" [{iv.lo:+.2f}, {iv.hi:+.2f}]" if iv.defined else \
                (f" (no interval: {iv.n} units are too few for a bootstrap)" if self.kind == "pooled std" and iv.n >= 2
                 else " (no interval: one unit)")
        return f"{self.what}: {est}{span}, {self.side} {self.threshold:g} to hold ({_METHOD[self.kind]})"


BOOTSTRAP_MIN_UNITS = 5
"""Fewest independent units a pooled std's bootstrap interval is taken over: n units give at most
C(2n - 1, n) distinct resamples (10 with 3 units, 126 with 5), too few below 5 for percentile ends
to mean anything; with fewer the claim has no interval (inconclusive)."""
_METHOD = {"t": "t", "ratio": "t on log, geometric mean", "pooled std": "bootstrap over units"}


@dataclass
class Claim:
    """One claim: its rule, its comparisons, the trials it could be judged on and the verdict."""
    name: str
    rule: str
    planned: int
    tests: list[Test] = field(default_factory=list)
    judged: list[tuple[str, bool, str]] = field(default_factory=list)
    """(trial label, the trial's values clear every threshold, the numbers)."""
    samples: list[tuple[Any, ...]] = field(default_factory=list)
    """Per trial judged, one value per test (for a pooled claim, per trial pooled)."""
    pooled: str = ""
    """For a claim judged on all trials together, what was pooled (``judged`` then holds one row)."""
    cause: str = ""
    """The measured cause (or the reading) behind the verdict; empty where none is needed."""

    units: list[Any] = field(default_factory=list)
    """Per sample, its independent unit (the run seed: the layouts of one run seed meet the same
    channel realisation and map initialisation, so they are nested in it; eq. U-1 of
    ``ramensim.evaluation.intervals``)."""

    def intervals(self) -> list:
        """Per test, the interval over the independent units (each unit's trials averaged first)."""
        from ramensim.evaluation.intervals import nest

        if len(self.units) != len(self.samples):
            raise ValueError(f"claim {self.name!r}: {len(self.samples)} samples but {len(self.units)} unit labels")
        return [t.interval(nest([s[i] for s in self.samples], self.units, t.kind)) for i, t in enumerate(self.tests)]

    def trial_intervals(self) -> list:
        """Per test, the interval with every trial taken as independent (the reading before
        2026-11-28, which overstated the count of independent units)."""
        return [t.interval([s[i] for s in self.samples]) for i, t in enumerate(self.tests)]

    def trial_verdict(self) -> str:
        """The verdict with every trial as a unit (:meth:`trial_intervals`)."""
        from ramensim.evaluation import intervals

        if not self.judged:
            return "no run yet"
        return intervals.combine([intervals.verdict(iv, t.threshold, t.side)
                                  for t, iv in zip(self.tests, self.trial_intervals())])

    def n_units(self) -> int:
        """How many independent units (run seeds) the judged trials form."""
        return len(dict.fromkeys(self.units))

    def verdicts(self) -> list[str]:
        """Per test, its verdict from its interval over the units."""
        from ramensim.evaluation import intervals

        return [intervals.verdict(iv, t.threshold, t.side) for t, iv in zip(self.tests, self.intervals())]

    def verdict(self) -> str:
        """``holds``, ``fails``, ``inconclusive`` (evaluation/intervals.py) or ``no run yet``."""
        from ramensim.evaluation import intervals

        if not self.judged:
            return "no run yet"
        return intervals.combine(self.verdicts())

    def n(self) -> int:
        """How many trials were judged (for a pooled claim: trials pooled)."""
        return len(self.samples)


def robots(v: dict[str, list[float]], key: str = COMPLETION) -> list[float]:
    """A run's per-robot values of ``key`` (non-finite ones, e.g. a diverged robot's, left out);
    raises :class:`Unjudgeable` naming the run when it has none."""
    vals = finite_values(v.get(key))
    if not vals:
        raise Unjudgeable(f"{getattr(v, 'where', 'a run')}: no finite {key} in its metrics.json")
    return vals


def team(v: dict[str, list[float]], key: str = COMPLETION) -> float:
    """The mean over a run's robots of ``key`` (a robot without a finite value, e.g. diverged, left out)."""
    return fmean(robots(v, key))


def alive(v: dict[str, list[float]], key: str = COMPLETION) -> str:
    """A run's team mean with its survivors named: ``"27.5"`` when no robot diverged, else e.g.
    ``"27.5, mean of 1 of 3 robots (2 diverged)"`` (metrics.json ``diverged_agents``; a diverged
    robot has no finite value and is left out of the mean)."""
    metrics = getattr(v, "metrics", None) or {}
    ok = len(finite_values(v.get(key) or []))
    n = int(metrics.get("n_agents") or len(v.get(key) or []))
    gone = len(metrics.get("diverged_agents") or [])
    mean = f"{team(v, key):.1f}"
    if not gone:
        return mean
    return f"{mean}, mean of {ok} of {n} robots ({gone} diverged)"


def pairs_min(a: Sequence[float], b: Sequence[float]) -> float:
    """The smallest ``a_i - b_j`` over every pair: how far every robot of ``a`` is above every robot of ``b``."""
    fa, fb = [x for x in a if math.isfinite(x)], [x for x in b if math.isfinite(x)]
    return min(fa) - max(fb) if fa and fb else math.nan


def per_robot(xs: Sequence[float]) -> str:
    """Per-robot values (%) as the pages show them: ``72.0 / 73.0 / 74.0``."""
    return " / ".join(f"{x:.1f}" for x in xs)


# The rules of the claims the sensitivity table (ramensim/paper/sensitivity.py) judges again under
# other settings: each a Test (quantity, threshold, side) and a function from a trial's runs to its
# value (points) and its numbers, shared so that both pages judge the same quantity against the
# same threshold.
CENTRAL_GAP = Test("RAMEN − centralised (points)", -5.0, ">=")
"""Table I: RAMEN within 5 points of centralised (:func:`central_gap`)."""
DINNO_LEAD = Test("RAMEN − DiNNO (points)", 0.0, ">")
"""Table I: DiNNO below RAMEN (:func:`dinno_lead`)."""
RAMEN_DROP = Test("RAMEN's drop (points)", 5.0, "<=")
"""Fig. 5: RAMEN loses at most 5 points from 100 to 20 % success (:func:`completion_drop`)."""
ABOVE_LOCAL = Test("smallest RAMEN robot − largest local robot (points)", 0.0, ">")
"""Fig. 5: at 1 % every RAMEN robot above every local robot (:func:`robots_above`)."""


def central_gap(ramen: dict[str, list[float]], centralised: dict[str, list[float]]) -> tuple[float, str]:
    """RAMEN's team completion minus centralised's (points, :data:`CENTRAL_GAP`), and the trial's numbers."""
    r, c = team(ramen), team(centralised)
    return r - c, f"{r:.1f} vs {c:.1f} ({r - c:+.1f})"


def dinno_lead(ramen: dict[str, list[float]], dinno: dict[str, list[float]]) -> tuple[float, str]:
    """RAMEN's team completion minus DiNNO's (points, :data:`DINNO_LEAD`), and the trial's numbers,
    named, with the same signed difference as the interval (``RAMEN 73.0 vs DiNNO 69.1 (+3.9)``)."""
    r, d = team(ramen), team(dinno)
    return r - d, f"RAMEN {r:.1f} vs DiNNO {d:.1f} ({r - d:+.1f})"


def completion_drop(high: dict[str, list[float]], low: dict[str, list[float]]) -> tuple[float, str]:
    """The team completion at the higher success rate minus at the lower one (points, the drop of
    :data:`RAMEN_DROP`), and the trial's numbers with the drop, the sign of its interval
    (``73.2 → 72.5 (drop +0.8)``; a rise is a negative drop)."""
    h, lo = team(high), team(low)
    return h - lo, f"{h:.1f} → {lo:.1f} (drop {h - lo:+.1f})"


def robots_above(ramen: dict[str, list[float]], local: dict[str, list[float]]) -> tuple[float, str]:
    """The smallest RAMEN robot's completion minus the largest local robot's (points,
    :data:`ABOVE_LOCAL`: every robot above every robot), and the trial's numbers."""
    gap = pairs_min(robots(ramen), robots(local))
    return gap, f"{per_robot(robots(ramen))} vs local {per_robot(robots(local))} (≥ {gap:+.1f})"


def label(seed: int, layout: int) -> str:
    """A trial as the pages name it: ``seed 0, layout 1`` (run seed, house layout)."""
    return f"seed {seed}, layout {layout}"
