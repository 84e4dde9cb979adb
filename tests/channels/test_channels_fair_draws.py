"""Fair comparisons: with keyed draws (eq. D-1, D-2 of ``ramensim.channels.draws``) a message's
fate depends on its link and send time, not on how many messages were sent before it."""
from __future__ import annotations

import numpy as np
import pytest

from ramensim.channels import ChannelConfig
from ramensim.channels.draws import KeyedDraws

LAT = {"kind": "lognormal", "mean_s": 0.02, "std_s": 0.01}


def _fates(make, times: dict[tuple[int, int], list[float]], seed: int = 3, **cfg) -> dict[tuple[int, int, float], tuple]:
    """Send one message per (link, time); return (status, reason, latency) per (src, dst, t_sent)."""
    env, ch, _ = make(n=3, seed=seed, **cfg)
    events = sorted((t, src, dst) for (src, dst), ts in times.items() for t in ts)

    def sender():
        for t, src, dst in events:
            if t > env.now:
                yield env.timeout(t - env.now)
            ch.send(src, dst, None, 1000, env.now)

    env.process(sender())
    env.run()
    d = ch.log.records()
    return {(int(r["src"]), int(r["dst"]), round(float(r["t_sent"]), 9)):
            (int(r["status"]), int(r["reason"]), round(float(r["t_done"] - r["t_sent"]), 12)) for r in d}


def _rounds(step: float, n: int) -> list[float]:
    """Send times of a method sending every ``step`` s, accumulated as a compute clock does."""
    t, out = 0.0, []
    for _ in range(n):
        t += step
        out.append(t)
    return out


@pytest.mark.parametrize("draws,same", [("keyed", True), ("send_order", False)])
def test_same_seed_same_outcome_at_equal_send_times(make, draws: str, same: bool) -> None:
    """A round-based method (one message a second per link) and a per-step one (ten a second)
    meet the same loss and latency at the send times they share, with keyed draws only."""
    links = [(0, 1), (1, 0), (0, 2), (2, 1)]
    sparse = _fates(make, {k: _rounds(1.0, 40) for k in links}, success_rate=0.5, latency=LAT, draws=draws)
    dense = _fates(make, {k: _rounds(0.1, 400) for k in links}, success_rate=0.5, latency=LAT, draws=draws)
    common = sorted(set(sparse) & set(dense))
    assert len(common) >= 150  # 0.1-step sums hit the integer seconds to within the 1-us slot
    agree = sum(sparse[k] == dense[k] for k in common)
    lost = sum(sparse[k][0] == 1 for k in common)
    assert 0.3 < lost / len(common) < 0.7
    if same:
        assert agree == len(common)
    else:
        assert agree < 0.8 * len(common)  # another realisation of the same link


def test_keyed_draws_do_not_depend_on_other_links(make) -> None:
    """Traffic on another link leaves a link's outcomes unchanged."""
    alone = _fates(make, {(0, 1): _rounds(0.5, 60)}, success_rate=0.4, latency=LAT)
    busy = _fates(make, {(0, 1): _rounds(0.5, 60), (1, 0): _rounds(0.3, 100), (2, 0): _rounds(0.7, 40)},
                  success_rate=0.4, latency=LAT)
    assert all(busy[k] == v for k, v in alone.items())


def test_keyed_draws_differ_between_seeds_and_links(make) -> None:
    a = _fates(make, {(0, 1): _rounds(1.0, 200), (1, 0): _rounds(1.0, 200)}, seed=1, success_rate=0.5)
    b = _fates(make, {(0, 1): _rounds(1.0, 200)}, seed=2, success_rate=0.5)
    same_seed_links = sum(a[(0, 1, k[2])][0] == a[(1, 0, k[2])][0] for k in a if k[0] == 0)
    other_seed = sum(a[k][0] == b[k][0] for k in b)
    assert 60 < same_seed_links < 140 and 60 < other_seed < 140  # independent coins agree about half the time


def test_messages_at_one_instant_get_their_own_draws(make) -> None:
    """Several messages on one link at one time are told apart by their index k (eq. D-1)."""
    env, ch, _ = make(n=2, seed=5, success_rate=0.5, queue_limit=1000)
    for _ in range(400):
        ch.send(0, 1, None, 10, 0.0)
    env.run()
    lost = int((ch.log.records()["status"] == 1).sum())
    assert 140 < lost < 260


def test_packet_draws_are_keyed_too(make) -> None:
    cfg = dict(mode="packet", packet_loss=0.05, mtu_bytes=200, reassembly="retransmit", bandwidth_bps=1e7)
    sparse = _fates(make, {(0, 1): _rounds(1.0, 50)}, **cfg)
    dense = _fates(make, {(0, 1): _rounds(0.25, 200)}, **cfg)
    common = set(sparse) & set(dense)
    assert len(common) == 50 and all(sparse[k] == dense[k] for k in common)


def test_edge_round_shares_one_coin_per_edge_and_round(make) -> None:
    """The authors' model (eq. D-2): both directions of an edge, and every message on it in one
    round, share one Bernoulli; the long-run success is still success_rate."""
    times = {(0, 1): [r + f for r in range(300) for f in (0.1, 0.6)], (1, 0): [r + 0.3 for r in range(300)]}
    f = _fates(make, times, success_rate=0.3, loss_unit="edge_round", loss_round_s=1.0)
    by_round: dict[int, set[int]] = {}
    for (src, dst, t), (status, _, _) in f.items():
        by_round.setdefault(int(t), set()).add(status)
    assert all(len(s) == 1 for s in by_round.values())
    delivered = sum(1 for s in by_round.values() if s == {0})
    assert 60 < delivered < 120  # 300 rounds at 30 %


def test_edge_round_needs_keyed_draws() -> None:
    with pytest.raises(ValueError, match="draws"):
        ChannelConfig(loss_unit="edge_round", draws="send_order")


def test_message_key_counts_within_a_slot() -> None:
    d = KeyedDraws(np.random.SeedSequence(0))
    assert d.message_key(0, 1, 1.0) == (0, 1, 1_000_000, 0)
    assert d.message_key(0, 1, 1.0 + 1e-12) == (0, 1, 1_000_000, 1)  # same microsecond
    assert d.message_key(1, 0, 1.0) == (1, 0, 1_000_000, 0)
    assert d.message_key(0, 1, 2.0) == (0, 1, 2_000_000, 0)
    assert d.edge_round(2, 1, 0.9999999999) == (1, 2, 1)  # a float sum just short of a round
    u = [d.uniform(1, (0, 1, s, 0)) for s in range(2000)]
    assert 0.0 <= min(u) and max(u) < 1.0 and abs(np.mean(u) - 0.5) < 0.03


def test_drop_reasons_are_spelled_once():
    """Every drop reason comes from ramensim.core.events.Fate: the channel's codes, messages.csv's
    reason column, the run totals, the events and the recorder's colours all derive from it."""
    from ramensim.channels.accounting import REASON_CODES
    from ramensim.channels.message import REASONS
    from ramensim.core.events import DROP_REASONS, Fate
    from ramensim.recording import style

    assert REASONS == DROP_REASONS == tuple(f.name.lower() for f in Fate)[1:]
    assert all(REASON_CODES[f] == f.reason for f in Fate)
    assert all(style.lost_color(r) != style._LOST_OTHER for r in DROP_REASONS)  # each has its colour


def test_a_new_drop_reason_is_one_member_and_its_colour(monkeypatch):
    """Adding a reason: a member of Fate (and a colour); accounting picks it up from there."""
    import enum

    from ramensim.channels import accounting
    from ramensim.core import events

    nxt = max(f.value for f in events.Fate) + 1
    Extended = enum.IntEnum("Fate", [(f.name, f.value) for f in events.Fate] + [("JAMMED", nxt)])
    reasons = tuple(f.name.lower() for f in Extended if f.value)
    monkeypatch.setattr(events, "DROP_REASONS", reasons)
    log = accounting.MessageLog()
    log.append((0, 0, 1, 10, 74, 0.0, 0.0, 0.1, 0.0, 1, nxt, 1, 0))
    monkeypatch.setattr(accounting, "REASON_CODES", ("",) + reasons)
    assert log.summary()["total"]["dropped_by_reason"]["jammed"] == 1
