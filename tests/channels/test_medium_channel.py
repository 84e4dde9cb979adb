"""The shared medium inside the channel (issue 66): fair shares, reuse out of hearing, broadcast,
busy <= 1, never more delivered than on private links, and bad input."""
from __future__ import annotations

import numpy as np
import pytest
import simpy
from pydantic import ValidationError

from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig

R = 100e6
B = 1_000_000  # bytes per message


def _run(medium: dict, n: int = 3, rounds: int = 1, nbytes: int = B, positions=None, topo: str = "complete",
         until: float = 30.0, **kw):
    env = simpy.Environment()
    cfg = ChannelConfig.model_validate({"bandwidth_bps": R, "header_bytes": 0, "latency": {"mean_s": 0.0},
                                        "medium": medium, **kw})
    topology = Topology(TopologyConfig(kind=topo), n)
    pos = positions or (lambda a, t: np.array([float(a), 0.0, 0.0]))
    ch = Channel(env, cfg, topology, n, np.random.default_rng(0), position=pos)

    def agent(i):
        for _ in range(rounds):
            for j in topology.neighbours(i):
                ch.send(i, j, None, nbytes, env.now)
            yield env.timeout(1.0)

    for i in range(n):
        env.process(agent(i))
    env.run(until=until)
    return ch, ch.log.records()


def test_links_fair_alone_is_a_private_link():
    _, links = _run({"kind": "links"}, n=2, topo="path", rounds=1)
    _, fair = _run({"kind": "shared", "access": "fair"}, n=2, topo="path", rounds=1)
    # two senders that hear each other: each at R / 2 while both send
    assert np.allclose(links["t_done"], 8 * B / R)
    assert np.allclose(fair["t_done"], 2 * 8 * B / R, atol=1e-8)


@pytest.mark.parametrize("n", [2, 3, 5])
def test_fair_n_saturated_senders_get_one_nth(n):
    """n radios, one message each to one neighbour, all start at 0: each gets R / n."""
    env = simpy.Environment()
    cfg = ChannelConfig.model_validate({"bandwidth_bps": R, "header_bytes": 0, "latency": {"mean_s": 0.0},
                                        "medium": {"kind": "shared", "access": "fair"}})
    ch = Channel(env, cfg, Topology(TopologyConfig(kind="ring" if n > 2 else "path"), n), n,
                 np.random.default_rng(0), position=lambda a, t: np.zeros(3))
    msgs = [ch.send(i, (i + 1) % n, None, B, 0.0) for i in range(n)]
    env.run(until=10)
    assert all(m.status == "delivered" for m in msgs)
    assert [m.t_done for m in msgs] == pytest.approx([n * 8 * B / R] * n, abs=1e-8)
    med = ch.medium_summary()
    assert med["domains"][0]["airtime_fraction"] == pytest.approx(8 * B * n / R / 10, rel=1e-6)
    assert med["domains"][0]["busy_fraction"] <= 1.0


def test_out_of_hearing_the_air_is_reused():
    """Two pairs 100 m apart with a 50-m sense range: each pair has the air to itself."""
    far = {0: 0.0, 1: 1.0, 2: 100.0, 3: 101.0}
    env = simpy.Environment()
    cfg = ChannelConfig.model_validate({"bandwidth_bps": R, "header_bytes": 0, "latency": {"mean_s": 0.0},
                                        "medium": {"kind": "shared", "access": "fair", "sense_range_m": 50.0}})
    ch = Channel(env, cfg, Topology(TopologyConfig(kind="complete"), 4), 4, np.random.default_rng(0),
                 position=lambda a, t: np.array([far[a], 0.0, 0.0]))
    a, b = ch.send(0, 1, None, B, 0.0), ch.send(2, 3, None, B, 0.0)
    c = ch.send(0, 2, None, B, 0.0)  # queued behind 0 -> 1; 2 does not hear 0: never delivered
    env.run(until=10)
    assert a.t_done == pytest.approx(8 * B / R) and b.t_done == pytest.approx(8 * B / R)
    assert c.status == "dropped" and c.reason == "out_of_range"
    assert len(ch.medium_summary()["domains"]) == 2


def test_hearing_follows_the_robots():
    """Robot 1 walks away at 1 m/s from t = 0; sense range 5 m: early messages arrive, later ones
    are unheard (out_of_range), because hearing is recomputed every update_s."""
    env = simpy.Environment()
    cfg = ChannelConfig.model_validate({"bandwidth_bps": R, "header_bytes": 0, "latency": {"mean_s": 0.0},
                                        "medium": {"kind": "shared", "access": "dcf", "sense_range_m": 5.0,
                                                   "update_s": 0.5}})
    ch = Channel(env, cfg, Topology(TopologyConfig(kind="path"), 2), 2, np.random.default_rng(0),
                 position=lambda a, t: np.array([a * t, 0.0, 0.0]))

    def sender():
        for _ in range(10):
            ch.send(0, 1, None, 1000, env.now)
            yield env.timeout(1.0)

    env.process(sender())
    env.run(until=12)
    r = ch.log.records()
    ok = r["status"] == 0
    assert ok[:5].all() and not ok[6:].any()
    assert ch.medium.hearing.recomputes >= 10


@pytest.mark.parametrize("access", ["fair", "dcf"])
def test_three_robots_busy_at_most_one_and_never_more_than_private_links(access):
    rounds = 4
    _, links = _run({"kind": "links"}, rounds=rounds, until=40.0)
    ch, shared = _run({"kind": "shared", "access": access}, rounds=rounds, until=40.0)
    med = ch.medium_summary()
    for d in med["domains"]:
        assert 0.0 < d["busy_fraction"] <= 1.0
    for r in med["radios"]:
        assert r["busy_fraction"] <= 1.0 and r["tx_fraction"] <= 1.0
    assert (shared["status"] == 0).sum() <= (links["status"] == 0).sum()
    lat = lambda r: (r["t_done"] - r["t_sent"])[r["status"] == 0].mean()  # noqa: E731
    assert lat(shared) > lat(links)  # three senders in one room wait for each other
    if access == "dcf":
        assert med["domains"][0]["collisions"] > 0 and shared["retries"].sum() > 0
        assert shared["wire_bytes"].sum() > links["wire_bytes"].sum()  # MAC headers and retransmissions


def test_broadcast_sends_once_for_every_neighbour():
    ch_u, uni = _run({"kind": "shared", "access": "fair"}, rounds=1)
    ch_b, bro = _run({"kind": "shared", "access": "fair", "delivery": "broadcast"}, rounds=1)
    assert (uni["status"] == 0).all() and (bro["status"] == 0).all()
    assert bro["t_done"].max() == pytest.approx(uni["t_done"].max() / 2, rel=1e-6)
    assert bro["wire_bytes"].sum() == uni["wire_bytes"].sum() // 2
    assert ch_b.medium_summary()["jobs"] == 3 and ch_u.medium_summary()["jobs"] == 6


def test_dcf_broadcast_collisions_are_named():
    ch, r = _run({"kind": "shared", "access": "dcf", "delivery": "broadcast", "cw_min": 2, "max_stage": 0},
                 n=6, rounds=3, nbytes=200_000)
    reasons = set(ch.log.summary()["total"]["dropped_by_reason"])
    assert {"collision", "retry_limit"} <= reasons
    assert ch.log.summary()["total"]["dropped_by_reason"]["collision"] > 0


def test_private_links_list_no_medium_reasons_and_no_medium_section():
    ch, _ = _run({"kind": "links"}, rounds=1)
    s = ch.log.summary()
    assert "collision" not in s["total"]["dropped_by_reason"] and "medium" not in s["total"]
    assert ch.medium_summary() is None


def test_same_seed_same_log():
    _, a = _run({"kind": "shared", "access": "dcf"}, rounds=3)
    _, b = _run({"kind": "shared", "access": "dcf"}, rounds=3)
    assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("medium,words", [
    ({"sense_range_m": 0}, "greater than 0"),
    ({"cw_min": 24}, "power of two"),
    ({"cw_min": 0}, "greater than or equal to 1"),
    ({"max_stage": -1}, "greater than or equal to 0"),
    ({"max_stage": 17}, "less than or equal to 16"),
    ({"max_frame_bytes": 30}, "does not exceed"),
    ({"access": "csma"}, "'fair' or 'dcf'"),
])
def test_bad_medium_settings_name_the_key(medium, words):
    with pytest.raises(ValidationError) as e:
        ChannelConfig.model_validate({"medium": {"kind": "shared", **medium}})
    assert words in str(e.value)


def test_packet_mode_and_a_full_trace_are_refused_on_a_shared_medium(tmp_path):
    with pytest.raises(ValidationError, match="cannot be combined"):
        ChannelConfig.model_validate({"mode": "packet", "medium": {"kind": "shared"}})
    trace = tmp_path / "t.csv"
    trace.write_text("time,from,to,delivered,latency\n0,0,1,1,0.01\n0,1,0,1,0.01\n")
    cfg = ChannelConfig.model_validate({"trace": {"path": str(trace)}, "medium": {"kind": "shared"}})
    with pytest.raises(ValueError, match="trace lists every link"):
        Channel(simpy.Environment(), cfg, Topology(TopologyConfig(kind="path"), 2), 2, np.random.default_rng(0),
                position=lambda a, t: np.zeros(3))


def test_loss_per_frame_costs_airtime_instead_of_messages():
    """loss: frame at 50 % success: a unicast frame lost is retried (more airtime, later arrival)
    where loss: message loses half the messages at the end of an unchanged transfer."""
    kw = dict(rounds=2, nbytes=200_000, success_rate=0.5, until=60.0)
    ch_m, per_msg = _run({"kind": "shared", "access": "dcf"}, **kw)
    ch_f, per_frame = _run({"kind": "shared", "access": "dcf", "loss": "frame", "retry_limit": 30}, **kw)
    assert (per_frame["status"] == 0).all()  # every frame gets through in the end
    assert 0 < (per_msg["status"] == 0).sum() < len(per_msg)
    assert per_frame["retries"].sum() > 2 * per_msg["retries"].sum() + len(per_frame)
    assert per_frame["wire_bytes"].sum() > 1.5 * per_msg["wire_bytes"].sum()
    with pytest.raises(ValidationError, match="needs channel.medium.access = 'dcf'"):
        ChannelConfig.model_validate({"medium": {"kind": "shared", "access": "fair", "loss": "frame"}})


@pytest.mark.parametrize("access", ["fair", "dcf"])
def test_queue_limit_counts_what_waits_behind_the_message_on_the_air(access):
    """queue_limit 0: an idle radio sends, a busy one drops (queue_overflow) what it cannot send
    now; queue_limit 1: one message waits."""
    for limit, delivered in ((0, 3), (1, 6)):
        ch, r = _run({"kind": "shared", "access": access}, rounds=1, queue_limit=limit)
        reasons = ch.log.summary()["total"]["dropped_by_reason"]
        assert (r["status"] == 0).sum() == delivered, (limit, reasons)
        assert reasons["queue_overflow"] == 6 - delivered


def test_walls_decide_who_hears_whom_with_path_loss():
    """With channel.path_loss on, a radio hears another only while eq. PL-1's received power,
    walls included, reaches cs_threshold_dbm: a wall plane at x = 5 m (a fake ray caster)
    splits four robots into two collision domains although all are within sense range."""
    from ramensim.channels.config import PathLossConfig
    from ramensim.channels.medium.config import MediumConfig
    from ramensim.channels.medium.hearing import Hearing

    xs = {0: 1.0, 1: 2.0, 2: 8.0, 3: 9.0}

    def first_hit(origins, directions):  # distance to the plane x = 5 (inf when moving away / past it)
        o, d = np.asarray(origins, float), np.asarray(directions, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (5.0 - o[:, 0]) / d[:, 0]
        return np.where(t > 1e-9, t, np.inf)

    pl = PathLossConfig(enabled=True, wall_loss_db=40.0)
    h = Hearing(MediumConfig(kind="shared", sense_range_m=50.0), 4, lambda a, t: np.array([xs[a], 0.0, 0.0]),
                pl, first_hit)
    assert h.domains(0) == [(0, 1), (2, 3)]
    assert h.listeners(0, 0) == (1,) and h.listeners(2, 0) == (3,)
    thin = Hearing(MediumConfig(kind="shared", sense_range_m=50.0), 4, lambda a, t: np.array([xs[a], 0.0, 0.0]),
                   PathLossConfig(enabled=True, wall_loss_db=1.0), first_hit)
    assert thin.domains(0) == [(0, 1, 2, 3)]  # a thin wall: everyone hears everyone
