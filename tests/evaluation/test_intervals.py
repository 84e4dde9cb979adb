"""``evaluation/intervals.py``: paired t intervals over trials, the bootstrap of a pooled standard
deviation, and the three-way verdict (holds / fails / inconclusive) a claim gets from them."""
from __future__ import annotations

import math

import pytest

from ramensim.evaluation import intervals as iv


def test_t_interval_is_students_over_the_trials():
    got = iv.t_interval([1.0, 2.0, 3.0])
    # mean 2, sample std 1, t_{2, 0.975} = 4.302653: half width 4.302653 / sqrt(3)
    assert got.estimate == pytest.approx(2.0)
    assert (got.lo, got.hi) == pytest.approx((2.0 - 2.484138, 2.0 + 2.484138), abs=1e-6)
    assert got.n == 3 and got.defined


def test_one_trial_or_none_gives_no_interval():
    one = iv.t_interval([4.0, math.nan])
    assert one.n == 1 and one.estimate == 4.0 and not one.defined
    assert iv.t_interval([]).n == 0
    assert iv.verdict(one, 0.0, ">") == iv.INCONCLUSIVE


@pytest.mark.parametrize("values, threshold, side, want", [
    ([3.0, 3.1, 2.9, 3.05], 0.0, ">", iv.HOLDS),          # clears zero from above
    ([-3.0, -3.1, -2.9, -3.05], 0.0, ">", iv.FAILS),      # wholly on the wrong side
    ([-1.0, 1.0, -0.5, 0.6], 0.0, ">", iv.INCONCLUSIVE),  # straddles the threshold
    ([-3.2, -3.4, -3.1, -3.3], -5.0, ">=", iv.HOLDS),     # within 5 of centralised
    ([0.9, 0.8, 0.85], 0.0, "<=", iv.FAILS),
    ([-0.9, -0.8, -0.85], 0.0, "<", iv.HOLDS),
    ([-0.2, 0.3, 0.1], 0.0, "<", iv.INCONCLUSIVE),
])
def test_verdict_by_where_the_interval_lies(values, threshold, side, want):
    assert iv.verdict(iv.t_interval(values), threshold, side) == want


def test_a_mean_on_the_right_side_is_not_enough():
    """Five of six trials above the threshold, the mean above it, the interval straddling it: inconclusive."""
    values = [1.0, 1.2, 0.8, 1.1, 0.9, -4.0]
    got = iv.t_interval(values)
    assert got.estimate > 0 and got.lo < 0 < got.hi
    assert iv.verdict(got, 0.0, ">") == iv.INCONCLUSIVE


def test_ratio_interval_is_t_on_the_logs():
    got = iv.ratio_interval([10.0, 100.0])
    assert got.estimate == pytest.approx(math.sqrt(1000.0))
    logs = iv.t_interval([math.log(10.0), math.log(100.0)])
    assert (got.lo, got.hi) == pytest.approx((math.exp(logs.lo), math.exp(logs.hi)))
    assert iv.ratio_interval([12.0, -1.0, math.inf]).n == 1   # only positive finite ratios count


def test_pooled_std_interval_equals_the_enumerated_bootstrap():
    trials = [([73.0, 73.2, 72.9], [69.0, 69.1]), ([75.0, 74.8, 75.1], [70.5, 70.4, 70.6]),
              ([74.0, 74.1, 73.8], [71.5, 71.4, 71.6]), ([72.5, 72.6, 72.4], [68.9, 69.0, 69.2])]
    fast = iv.pooled_std_interval(trials)
    slow = iv.bootstrap_interval(trials, iv.pooled_std_difference)
    assert fast.estimate == pytest.approx(slow.estimate)
    assert (fast.lo, fast.hi) == pytest.approx((slow.lo, slow.hi), abs=1e-9)
    assert fast.method == "bootstrap" and fast.n == 4


def test_bootstrap_over_two_identical_trials_has_no_spread():
    trials = [([1.0, 3.0], [2.0, 2.0]), ([1.0, 3.0], [2.0, 2.0])]
    got = iv.pooled_std_interval(trials)
    assert (got.estimate, got.lo, got.hi) == pytest.approx((1.0, 1.0, 1.0))
    assert iv.verdict(got, 0.0, "<=") == iv.FAILS


def test_combine_needs_every_comparison():
    assert iv.combine([iv.HOLDS, iv.HOLDS]) == iv.HOLDS
    assert iv.combine([iv.HOLDS, iv.INCONCLUSIVE]) == iv.INCONCLUSIVE
    assert iv.combine([iv.INCONCLUSIVE, iv.FAILS]) == iv.FAILS
    assert iv.combine([]) == iv.INCONCLUSIVE


def test_unknown_side_is_refused():
    with pytest.raises(ValueError, match="side"):
        iv.verdict(iv.t_interval([1.0, 2.0]), 0.0, "=")


def test_nest_averages_each_unit_first():
    from ramensim.evaluation.intervals import nest

    assert nest([1.0, 3.0, 10.0], ["a", "a", "b"]) == [2.0, 10.0]            # eq. U-1
    assert nest([2.0, 8.0, 5.0], [0, 0, 1], "ratio") == pytest.approx([4.0, 5.0])  # geometric mean
    assert nest([([1.0], [2.0]), ([3.0], [4.0])], [0, 0], "pooled std") == [([1.0, 3.0], [2.0, 4.0])]
    assert nest([1.0, 2.0], [0, 1]) == [1.0, 2.0]                            # one trial a unit: unchanged
    with pytest.raises(ValueError):
        nest([1.0], [0, 1])
