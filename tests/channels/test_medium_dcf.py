"""The shared medium's DCF against Bianchi's analytic model, hidden terminals and RTS/CTS (issue 66).

Bianchi's model (``channels/medium/bianchi.py``) is a formula, written apart from the event-driven
DCF (``channels/medium/dcf.py``): the reference the simulation must meet within 0.03 on both
figures. Simulated spans are bounded (seconds of simulated air), never wall time.
"""
from __future__ import annotations

import numpy as np
import pytest

from ramensim.channels.medium.bianchi import solve_tau
from ramensim.channels.medium.clock import EventClock, to_ns
from ramensim.channels.medium.dcf import Dcf, Frame
from ramensim.channels.medium.saturation import SaturationSetup, model, simulate


@pytest.mark.parametrize("n,w,m,rts", [
    (5, 32, 3, False), (20, 32, 5, False), (50, 128, 3, False), (35, 64, 4, False),
    (5, 128, 5, True), (20, 32, 3, True), (50, 32, 5, True),
])
def test_saturation_agrees_with_bianchi(n, w, m, rts):
    r = simulate(SaturationSetup(stations=n, cw_min=w, max_stage=m, rts_cts=rts, duration_s=40.0, seed=n + w))
    assert r.exchanges > 2000
    assert abs(r.throughput - r.model_throughput) <= 0.03, r
    assert abs(r.collision_probability - r.model_collision_probability) <= 0.03, r


def test_bianchi_fixed_point_and_limits():
    tau, p = solve_tau(1, 32, 5)
    assert p == 0.0 and tau == pytest.approx(2 / 33)
    for n, w, m in [(5, 32, 3), (50, 128, 5), (10, 16, 0)]:
        tau, p = solve_tau(n, w, m)
        assert p == pytest.approx(1 - (1 - tau) ** (n - 1), abs=1e-9)
        want = 2 * (1 - 2 * p) / ((1 - 2 * p) * (w + 1) + p * w * (1 - (2 * p) ** m))
        assert tau == pytest.approx(want, rel=1e-6)
    # more stations collide more; a wider window collides less
    assert solve_tau(50, 32, 5)[1] > solve_tau(10, 32, 5)[1] > solve_tau(10, 128, 5)[1]
    # RTS/CTS keeps throughput up where basic access falls with n (Bianchi's Fig. 6-7)
    basic = [model(SaturationSetup(stations=n))[0] for n in (5, 50)]
    rts = [model(SaturationSetup(stations=n, rts_cts=True))[0] for n in (5, 50)]
    assert basic[1] < basic[0] - 0.1 and abs(rts[1] - rts[0]) < 0.05


def _three_in_a_row(rts: bool, hidden: bool, seconds: float = 20.0) -> tuple[float, float]:
    """Stations 0 and 2 send saturated to 1; with ``hidden`` they do not hear each other."""
    st = SaturationSetup(stations=3, rts_cts=rts)
    hears = {0: (1,), 1: (0, 2), 2: (1,)} if hidden else {0: (1, 2), 1: (0, 2), 2: (0, 1)}
    clock = EventClock()
    dcf: Dcf

    def refill(f: Frame, _t: int, _out: dict[int, int]) -> None:
        dcf.push(f.src, Frame(f.src, (1,), 1023, False))

    dcf = Dcf(clock, 3, st.params(), np.random.default_rng(1).spawn(3), lambda i, _t: hears[i], refill)
    for i in (0, 2):
        dcf.push(i, Frame(i, (1,), 1023, False))
    clock.run(to_ns(seconds))
    bits = sum(s.delivered_bits for s in dcf.st)
    return bits / st.rate_bps / seconds, sum(s.failures for s in dcf.st) / sum(s.attempts for s in dcf.st)


def test_hidden_terminals_collapse_and_rts_cts_recovers_part():
    heard, _ = _three_in_a_row(rts=False, hidden=False)
    basic, p_basic = _three_in_a_row(rts=False, hidden=True)
    rts, p_rts = _three_in_a_row(rts=True, hidden=True)
    assert basic < 0.6 * heard  # the known collapse: the senders cannot defer to each other
    assert p_basic > 0.4
    assert basic * 1.5 < rts < heard  # RTS/CTS recovers part of it: collisions cost an RTS only
    assert p_rts < p_basic


def test_retry_limit_drops_frames_and_none_never_does():
    limited = simulate(SaturationSetup(stations=30, cw_min=4, max_stage=1, retry_limit=0, duration_s=5.0))
    never = simulate(SaturationSetup(stations=30, cw_min=4, max_stage=1, duration_s=5.0))
    # with retry_limit 0 every failed exchange drops its frame; without a limit none is dropped
    failed = round(limited.collision_probability * limited.exchanges)
    assert limited.dropped_frames > 0 and abs(limited.dropped_frames - failed) <= 30
    assert never.dropped_frames == 0 and never.collision_probability > 0.5


def test_same_seed_same_outcome_other_seed_other():
    a = simulate(SaturationSetup(stations=10, duration_s=5.0, seed=3))
    b = simulate(SaturationSetup(stations=10, duration_s=5.0, seed=3))
    c = simulate(SaturationSetup(stations=10, duration_s=5.0, seed=4))
    assert a.as_dict() == b.as_dict()
    assert (a.throughput, a.exchanges) != (c.throughput, c.exchanges)
