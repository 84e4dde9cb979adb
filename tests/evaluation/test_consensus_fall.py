"""``evaluation/consensus_fall.py``: the consensus error's peak after the start-up transient
against the mean of the last 60 s of readings (docs/ALGORITHM.md section 5)."""
from __future__ import annotations

import pytest

from ramensim.evaluation.consensus_fall import consensus_fall


def _timeline(values: dict[float, float], key: str = "consensus_error") -> list[dict[str, float]]:
    return [{"t": t, key: v} for t, v in values.items()]


def test_the_start_up_rise_is_not_the_peak_and_the_end_is_a_mean():
    # before the first exchange the error rises (0.09 -> 0.11); it falls at 6 s; later a bump at 8 s
    early = {2.0: 0.09, 4.0: 0.11, 6.0: 0.05, 8.0: 0.06, 10.0: 0.04}
    late = {t: (0.010 if int(t) % 4 else 0.014) for t in range(540, 600, 2)}   # 30 readings, mean 0.012
    fall = consensus_fall(_timeline({**early, **{float(t): v for t, v in late.items()}}), t_end=600.0)
    assert (fall.peak, fall.t_peak) == (0.06, 8.0)
    assert fall.n_settled == 30 and fall.settled == pytest.approx(0.012)
    assert fall.ratio == pytest.approx(5.0)


def test_the_window_is_the_last_minute_of_the_run():
    tl = _timeline({2.0: 0.1, 4.0: 0.05, 100.0: 0.02, 150.0: 0.01, 200.0: 0.03})
    fall = consensus_fall(tl, t_end=200.0, last_s=60.0)     # readings at 150 and 200 s
    assert fall.settled == pytest.approx(0.02) and fall.n_settled == 2
    assert consensus_fall(tl, t_end=400.0) is None           # nothing in the run's last minute


def test_a_weighted_key_and_junk_entries():
    tl = [{"t": 2.0, "consensus_error_weighted": 0.2}, {"t": 4.0, "consensus_error_weighted": 0.1},
          {"t": 6.0}, "junk", {"t": float("nan"), "consensus_error_weighted": 9.0},
          {"t": 8.0, "consensus_error_weighted": 0.05}]
    fall = consensus_fall(tl, "consensus_error_weighted", last_s=4.0)   # readings at 4 and 8 s
    assert (fall.peak, fall.t_peak, fall.settled) == (0.1, 4.0, pytest.approx(0.075))


def test_an_error_that_never_falls_has_no_fall():
    assert consensus_fall(_timeline({2.0: 0.1, 4.0: 0.2, 6.0: 0.3})) is None
    assert consensus_fall(None) is None
    assert consensus_fall([]) is None


def test_growth_is_the_settled_value_over_the_trough_after_start_up():
    """Maps that agreed (trough 0.02 at 40 s) and drift apart (the last minute's mean 0.4):
    growth 20x, above DRIFT; the start-up rise (2-4 s) is neither trough nor settled."""
    from ramensim.evaluation.consensus_fall import DRIFT, consensus_growth

    tl = _timeline({2.0: 0.01, 4.0: 0.09, 6.0: 0.05, 40.0: 0.02, 100.0: 0.1, 150.0: 0.3, 200.0: 0.5})
    grow = consensus_growth(tl, t_end=200.0)                  # settled: readings at 150 and 200 s
    assert (grow.trough, grow.t_trough) == (0.02, 40.0)
    assert grow.settled == pytest.approx(0.4) and grow.ratio == pytest.approx(20.0) and grow.ratio > DRIFT
    steady = consensus_growth(_timeline({2.0: 0.09, 4.0: 0.05, 100.0: 0.03, 180.0: 0.03}), t_end=180.0)
    assert steady.ratio == pytest.approx(1.0)
    assert consensus_growth(_timeline({2.0: 0.1, 4.0: 0.2})) is None         # never falls: no trough
