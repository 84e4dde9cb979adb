"""Radio models with known answers: Gilbert-Elliott burst loss, path loss through walls, trace replay."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import trimesh
from channel_traffic import log_bytes, run_traffic
from pydantic import ValidationError

from ramensim.channels.burst import BAD, mean_good_s, mean_loss_run, stationary_bad, stay_bad_probability
from ramensim.channels.config import ChannelConfig, PathLossConfig
from ramensim.core.events import LinkQuality
from ramensim.channels.pathloss import count_walls, received_power_dbm, success_of_power

Z99 = 2.5758  # two-sided 99 % normal quantile


def _within_binomial_99(k: int, n: int, p: float) -> bool:
    return abs(k / n - p) <= Z99 * math.sqrt(p * (1 - p) / n) + 1e-12


def _periodic(ch, env, n: int, dt: float, src: int = 0, dst: int = 1, nbytes: int = 100) -> None:
    def proc():
        for _ in range(n):
            ch.send(src, dst, None, nbytes, env.now)
            yield env.timeout(dt)

    env.process(proc())
    env.run()


GE = {"kind": "gilbert_elliott", "mean_bad_s": 1.5}


# --- Gilbert-Elliott ----------------------------------------------------------------------------

def test_ge_formulas() -> None:
    # (GE-3): s = 0.5 with h_G = 0, h_B = 1 -> half the time bad, T_G = T_B.
    assert stationary_bad(0.5, 0.0, 1.0) == pytest.approx(0.5)
    assert mean_good_s(0.5, 0.0, 1.0, 2.0) == pytest.approx(2.0)
    assert mean_good_s(1.0, 0.0, 1.0, 2.0) == math.inf
    # (GE-2) back from (GE-3): s = (1 - pi)(1 - hG) + pi (1 - hB).
    pi = stationary_bad(0.7, 0.1, 0.6)
    assert (1 - pi) * 0.9 + pi * 0.4 == pytest.approx(0.7)
    # (GE-4): far apart -> the stationary share; no gap -> certainly still bad.
    assert stay_bad_probability(0.5, 0.0, 1.0, 1.0, 1e3) == pytest.approx(0.5)
    assert stay_bad_probability(0.5, 0.0, 1.0, 1.0, 0.0) == pytest.approx(1.0)


@pytest.mark.parametrize("s,good,bad", [(0.5, 0.0, 1.0), (0.8, 0.05, 0.7), (0.2, 0.0, 1.0)])
def test_ge_long_run_success_matches(make, s: float, good: float, bad: float) -> None:
    # Messages 20 s apart on a chain that mixes in ~1 s are independent draws of the
    # stationary success, so the delivered count is binomial(n, s).
    env, ch, _ = make(success_rate=s, burst={**GE, "good_loss": good, "bad_loss": bad})
    n = 20_000
    _periodic(ch, env, n, 20.0)
    k = ch.log.summary()["total"]["delivered"]
    assert _within_binomial_99(k, n, s)
    assert not _within_binomial_99(k, n, s + 0.05)  # a wrong mean would fail


def test_ge_mean_burst_length_matches(make) -> None:
    # Bad sojourns are exponential of mean T_B: their sample mean lies in mean +- z T_B / sqrt(k).
    t_bad, s = 1.5, 0.5
    env, ch, _ = make(success_rate=s, burst={**GE, "mean_bad_s": t_bad})
    dt, n = 0.1, 40_000
    _periodic(ch, env, n, dt)
    chain = ch.models.chain(0, 1)
    sw = np.asarray(chain.switches)
    # Alternating sojourns; find which switches enter the bad state from the state at the end.
    ends_bad = chain.state(env.now) == BAD
    n_sw = len(sw)
    enter_bad = [i for i in range(n_sw) if ((n_sw - 1 - i) % 2 == 0) == ends_bad]
    soj = np.array([sw[i + 1] - sw[i] for i in enter_bad if i + 1 < n_sw])
    assert len(soj) > 500
    assert abs(soj.mean() - t_bad) <= Z99 * t_bad / math.sqrt(len(soj))
    # Runs of consecutive losses (h_G = 0, h_B = 1) are geometric of mean 1 / (1 - P(B|B)) (GE-4).
    lost = ch.log.records()["status"] == 1
    edges = np.flatnonzero(np.diff(np.concatenate([[0], lost.astype(np.int8), [0]])))
    runs = (edges[1::2] - edges[::2]).astype(np.float64)
    p_bb = stay_bad_probability(s, 0.0, 1.0, t_bad, dt)
    mean = mean_loss_run(s, 0.0, 1.0, t_bad, dt)
    sd = math.sqrt(p_bb) / (1 - p_bb)
    assert abs(runs.mean() - mean) <= Z99 * sd / math.sqrt(len(runs))
    # i.i.d. loss at the same mean has runs of mean 1 / s = 2: far shorter.
    assert runs.mean() > 3 * (1 / s)


def test_ge_state_independent_of_traffic(make) -> None:
    # The chain of a link is a function of seed, link and time: other traffic does not move it.
    env, ch, _ = make(n=3, success_rate=0.5, burst=GE, seed=3)
    _periodic(ch, env, 2000, 0.5)
    env2, ch2, _ = make(n=3, success_rate=0.5, burst=GE, seed=3)

    def other():
        for _ in range(3000):
            ch2.send(2, 1, None, 10, env2.now)
            ch2.send(1, 2, None, 10, env2.now)
            yield env2.timeout(0.3)

    env2.process(other())
    _periodic(ch2, env2, 2000, 0.5)
    a = ch.log.records()
    b = ch2.log.records()
    b = b[(b["src"] == 0) & (b["dst"] == 1)]
    assert ch.models.chain(0, 1).switches == ch2.models.chain(0, 1).switches[: len(ch.models.chain(0, 1).switches)]
    assert len(a) == len(b)


# --- path loss ------------------------------------------------------------------------------------

def _wall_caster(walls_x):
    """first_hit for infinite walls at x = c +- 0.06 (analytic, for counting)."""
    planes = sorted(x for c in walls_x for x in (c - 0.06, c + 0.06))

    def first_hit(o, d):
        out = np.full(len(o), np.inf)
        for i, (oi, di) in enumerate(zip(o, d)):
            if abs(di[0]) < 1e-12:
                continue
            ts = [(x - oi[0]) / di[0] for x in planes]
            ts = [t for t in ts if t >= 0.0]
            if ts:
                out[i] = min(ts)
        return out

    return first_hit


def test_count_walls_analytic() -> None:
    fh = _wall_caster([1.0, 2.5, 4.0])
    p = np.array([[0.0, 0, 1], [0.0, 0, 1], [3.0, 0, 1], [0.0, 0, 1]])
    q = np.array([[5.0, 0, 1], [2.0, 1, 1], [0.0, 0, 1], [0.5, 0, 1]])
    assert count_walls(fh, p, q).tolist() == [3, 1, 2, 0]


def _embree_wall():
    """first_hit of the world's Embree caster on one 12 cm wall at x = 0 (4 m x 3 m)."""
    from ramensim.world.camera import MeshRayCaster

    wall = trimesh.creation.box(extents=[0.12, 4.0, 3.0])
    wall.apply_translation([0.0, 0.0, 1.5])
    caster = MeshRayCaster(wall, threads=1)
    return lambda o, d: caster.cast(o, d)[0]


def test_embree_counts_the_wall() -> None:
    fh = _embree_wall()
    p = np.array([[-2.0, 0.0, 1.0], [-2.0, 0.0, 1.0], [-2.0, 3.0, 1.0]])
    q = np.array([[2.0, 0.5, 1.2], [-0.5, 0.0, 1.0], [2.0, 3.0, 1.0]])  # through, short of, beside
    assert count_walls(fh, p, q).tolist() == [1, 0, 0]


CURVE = [(-100.0, 0.0), (-40.0, 1.0)]  # 1/60 success per dB


@pytest.mark.parametrize("wall_db", [6.0, 12.0])
def test_wall_lowers_success_by_its_attenuation(make, wall_db: float) -> None:
    """Two robots 4 m apart, a wall between them or not: the success differs by exactly the
    wall's attenuation on the curve, and the delivered counts follow (binomial 99 %)."""
    fh = _embree_wall()
    pl = {"enabled": True, "tx_power_dbm": 0.0, "exponent": 3.0, "wall_loss_db": wall_db, "curve": CURVE,
          "time_step_s": 3600.0}  # the robots stand still: one geometry step
    results = {}
    for name, y in (("wall", 0.0), ("open", 3.0)):  # the wall spans |y| <= 2
        pos = (lambda y: lambda a, t: np.array([-2.0 if a == 0 else 2.0, y, 1.0]))(y)
        events = []
        env, ch, _ = make(position=pos, path_loss=pl, first_hit=fh, emit=events.append)
        n = 20_000
        _periodic(ch, env, n, 0.5)
        p, walls, dist = ch.models.path.quality(0, 1, 0.0)
        results[name] = (p, walls, ch.log.summary()["total"]["delivered"])
        quality = [e for e in events if isinstance(e, LinkQuality)]
        assert len(quality) == 1 and quality[0].walls == walls and quality[0].success == p
        assert _within_binomial_99(results[name][2], n, p)
    p_wall, w1, _ = results["wall"]
    p_open, w0, _ = results["open"]
    assert (w1, w0) == (1, 0)
    # (PL-1, PL-2) by hand: 4 m at n = 3 is -40 - 30 log10(4) = -58.06 dBm, 1/60 success per dB above -100
    p_rx = -40.0 - 30.0 * math.log10(4.0)
    assert p_open == pytest.approx((p_rx + 100.0) / 60.0, abs=1e-12)
    assert p_wall == pytest.approx((p_rx - wall_db + 100.0) / 60.0, abs=1e-12)
    assert p_open - p_wall == pytest.approx(wall_db / 60.0, abs=1e-12)


def test_range_is_a_consequence(make) -> None:
    cfg = PathLossConfig(enabled=True, wall_loss_db=0.0)
    # Default curve: success 0 below -92 dBm; 0 dBm, 40 dB at 1 m, n = 3 -> d = 10^(52/30) m.
    d_max = 10 ** (52 / 30)
    assert success_of_power(cfg, received_power_dbm(cfg, d_max * 1.01, 0)) == 0.0
    assert success_of_power(cfg, received_power_dbm(cfg, d_max * 0.9, 0)) > 0.0
    pos = lambda a, t: np.array([a * (t * 0.5), 0.0, 0.0])  # noqa: E731 - 1 leaves at 0.5 m/s
    env, ch, _ = make(position=pos, path_loss={"enabled": True, "wall_loss_db": 0.0})
    _periodic(ch, env, 200, 1.0)
    r = ch.log.records()
    t_far = 2 * d_max
    far = r[r["t_sent"] >= t_far + 0.1]  # quality steps 0.1 s
    assert (far["reason"] == 3).all() and len(far) > 0  # out_of_range
    near = r[r["t_sent"] < 2 * 4.0]
    assert (near["status"] == 0).all()  # 4 m: -58 dBm, success 1


def test_wall_loss_needs_geometry(make) -> None:
    with pytest.raises(ValueError, match="wall_loss_db"):
        make(position=lambda a, t: np.zeros(3), path_loss={"enabled": True})


def test_curve_must_be_monotone() -> None:
    with pytest.raises(ValidationError, match=r"curve\[1\].*monotone"):
        PathLossConfig(curve=[(-90.0, 0.5), (-80.0, 0.2)])
    with pytest.raises(ValidationError, match=r"curve\[1\].*strictly increase"):
        PathLossConfig(curve=[(-90.0, 0.0), (-90.0, 1.0)])
    with pytest.raises(ValidationError, match="probability"):
        PathLossConfig(curve=[(-90.0, 0.0), (-80.0, 1.5)])
    with pytest.raises(ValidationError):
        PathLossConfig(exponent=float("nan"))


def test_ge_config_errors() -> None:
    with pytest.raises(ValidationError, match="success_rate"):
        ChannelConfig(success_rate=0.2, burst={**GE, "bad_loss": 0.5})
    with pytest.raises(ValidationError, match="bad_loss"):
        ChannelConfig(success_rate=0.9, burst={**GE, "good_loss": 0.3, "bad_loss": 0.3})
    with pytest.raises(ValidationError, match="mean_bad_s"):
        ChannelConfig(burst={**GE, "mean_bad_s": float("inf")})


# --- trace replay ---------------------------------------------------------------------------------

TRACE = """# measured on two robots
time,from,to,delivered,latency
0.0,0,1,1,0.004
0.5,0,1,0,
1.0,0,1,1,0.031
1.0,1,0,1,0.002
1.5,0,1,1,0.25
2.0,0,1,0,
2.5,0,1,1,0.0125
"""


def _trace_run(make, tmp_path, times, end="clip", src=0, dst=1):
    f = tmp_path / "trace.csv"
    f.write_text(TRACE)
    env, ch, inbox = make(header_bytes=0, success_rate=0.3, trace={"path": str(f), "end": end},
                          latency={"kind": "exponential", "mean_s": 1.0})

    def proc():
        for t in times:
            yield env.timeout(t - env.now)
            ch.send(src, dst, None, 0, env.now)

    env.process(proc())
    env.run()
    return ch.log.records()


def test_trace_reproduced_exactly(make, tmp_path) -> None:
    times = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]
    r = _trace_run(make, tmp_path, times)
    delivered = r["status"] == 0
    assert delivered.tolist() == [True, False, True, True, False, True]
    # Exactly: every delivered message arrives at t_sent + the trace's latency (bit for bit).
    ok = r[delivered]
    assert (ok["t_done"] == ok["t_sent"] + np.array([0.004, 0.031, 0.25, 0.0125])).all()


def test_trace_hold_clip_and_loop(make, tmp_path) -> None:
    # Between rows the latest earlier row holds; clip holds the last row after the end.
    r = _trace_run(make, tmp_path, [0.2, 1.2, 9.0])
    assert (r["status"] == 0).tolist() == [True, True, True]
    assert (r["t_done"] - r["t_sent"]).tolist() == pytest.approx([0.004, 0.031, 0.0125])
    # Loop: the period is 2.5 s + the smallest step 0.5 s = 3 s, so t = 3.5 replays t = 0.5.
    r = _trace_run(make, tmp_path, [3.0, 3.5, 4.0], end="loop")
    assert (r["status"] == 0).tolist() == [True, False, True]


def test_trace_unlisted_link_keeps_the_model(make, tmp_path) -> None:
    f = tmp_path / "t.csv"
    f.write_text("time,from,to,delivered,latency\n0,0,1,1,0.1\n")
    env, ch, _ = make(n=3, trace={"path": str(f)})
    ch.send(0, 1, None, 10, 0.0)
    ch.send(0, 2, None, 10, 0.0)
    env.run()
    r = ch.log.records()
    assert (r["status"] == 0).all()
    assert r["t_done"][0] > 0.1 and r["t_done"][1] < 0.01


@pytest.mark.parametrize("body,line,what", [
    ("time,from,to,delivered,latency\n0,0,5,1,0.1\n", 2, "unknown agent"),
    ("time,from,to,delivered,latency\n1,0,1,1,0.1\n0.5,0,1,1,0.1\n", 3, "sorted"),
    ("time,from,to,delivered,latency\n0,0,1,1,nan\n", 2, "finite"),
    ("time,from,to,delivered,latency\ninf,0,1,1,0.1\n", 2, "finite"),
    ("time,from,to,delivered,latency\n0,0,1,1,0.1\n-1,0,1,1,0.1\n", 3, ">= 0"),
    ("time,from,to,delivered,latency\n0,0,1,1,-0.1\n", 2, ">= 0"),
    ("time,from,to,delivered,latency\n0,0,1,1,\n", 2, "needs a latency"),
    ("t,a,b\n", 1, "header"),
    ("time,from,to,delivered,latency\n0,0,1,maybe,0.1\n", 2, "delivered"),
])
def test_bad_trace_names_file_and_line(make, tmp_path, body, line, what) -> None:
    f = tmp_path / "bad.csv"
    f.write_text(body)
    with pytest.raises(ValueError) as exc:
        make(n=2, trace={"path": str(f)})
    msg = str(exc.value)
    assert str(f) in msg and f"line {line}" in msg and what in msg


# --- determinism ----------------------------------------------------------------------------------

def _mixed_run(make, seed, tmp_path, name):
    f = tmp_path / "trace.csv"
    f.write_text(TRACE)
    pos = lambda a, t: np.array([a * 3.0 + 2.0 * math.sin(0.2 * t + a), 0.0, 1.0])  # noqa: E731
    env, ch, _ = make(n=3, topology="complete", seed=seed, position=pos, success_rate=0.6,
                      burst={**GE, "good_loss": 0.05}, trace={"path": str(f), "end": "loop"},
                      path_loss={"enabled": True, "wall_loss_db": 0.0, "curve": CURVE},
                      latency={"kind": "lognormal", "mean_s": 0.01, "std_s": 0.005})
    run_traffic(env, ch, 3, 300, traffic_seed=5)
    return log_bytes(ch, tmp_path / f"{name}.csv"), json.dumps(ch.log.summary(), sort_keys=True)


def test_radio_models_same_seed_same_bytes(make, tmp_path) -> None:
    a = _mixed_run(make, 7, tmp_path, "a")
    b = _mixed_run(make, 7, tmp_path, "b")
    c = _mixed_run(make, 8, tmp_path, "c")
    assert a == b
    assert a[0] != c[0]


def test_batched_steps_match_the_formula() -> None:
    """Every pair recomputed in one batch per time step equals (PL-1, PL-2) at the step's start."""
    from ramensim.channels.pathloss import PathLoss

    cfg = PathLossConfig(enabled=True, wall_loss_db=5.0, curve=CURVE, time_step_s=0.5)
    fh = _wall_caster([1.0, 4.0])
    pos = lambda a, t: np.array([a * 1.7 + 0.3 * t, 0.2 * a, 1.0])  # noqa: E731
    pl = PathLoss(cfg, pos, fh)
    for t in (0.0, 0.2, 0.7, 0.9, 3.3):
        for a, b in ((0, 1), (0, 2), (1, 3), (2, 3)):
            s, w, d = pl.quality(a, b, t)
            ts = math.floor(t / 0.5) * 0.5
            pa, pb = pos(a, ts), pos(b, ts)
            assert d == pytest.approx(float(np.linalg.norm(pa - pb)))
            assert w == int(count_walls(fh, pa[None], pb[None])[0])
            assert s == pytest.approx(success_of_power(cfg, received_power_dbm(cfg, d, w)), abs=1e-12)
    assert pl.batches == 3  # steps 0, 1, 6 (t = 0.2 shares step 0, t = 0.9 step 1)
