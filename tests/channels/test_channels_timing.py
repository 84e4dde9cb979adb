"""Serialisation, queueing and latency give exact arrival times; queues overflow; senders never wait.

bandwidth 8 bit/s makes one wire byte take exactly one second, so expected times are exact.
"""
from __future__ import annotations

import pytest

from ramensim.core.events import MessageDelivered, MessageDropped, MessageSent

CONST = {"kind": "constant", "mean_s": 0.25}


def test_single_message_time(make) -> None:
    env, ch, inbox = make(bandwidth_bps=8.0, header_bytes=10, latency=CONST)
    m = ch.send(0, 1, {"theta": 1}, 90, stamp=-2.0)
    assert m.status == "queued"  # send returns at once
    env.run()
    (t, got), = inbox[1]
    assert got is m and got.payload == {"theta": 1}
    assert t == 100.25 and m.t_done == 100.25 and m.t_start == 0.0
    assert m.latency == 100.25 and m.age == 102.25 and m.wire_bytes == 100


def test_queueing_behind_a_big_message(make) -> None:
    env, ch, inbox = make(bandwidth_bps=8.0, header_bytes=0, latency=CONST)
    big = ch.send(0, 1, "map", 1000, 0.0)        # on the air 0 .. 1000
    other_link = ch.send(1, 0, "x", 10, 0.0)     # its own transmitter: not delayed

    def later():
        yield env.timeout(3.0)
        small = ch.send(0, 1, "u", 5, 3.0)  # waits for the map: 1000 .. 1005
        assert ch.queue_length(0, 1) == 1 and ch.busy_until(0, 1) == 1005.0
        yield env.timeout(1.0)
        small2 = ch.send(0, 1, "v", 7, 4.0)  # 1005 .. 1012
        res.extend([small, small2])

    res: list = []
    env.process(later())
    env.run()
    small, small2 = res
    assert big.t_done == 1000.25
    assert other_link.t_done == 10.25
    assert (small.t_start, small.t_done) == (1000.0, 1005.25)
    assert (small2.t_start, small2.t_done) == (1005.0, 1012.25)
    assert [m.id for _, m in inbox[1]] == [big.id, small.id, small2.id]
    assert small.latency == 1002.25 and small2.age == 1008.25


def test_queue_overflow(make) -> None:
    env, ch, _ = make(bandwidth_bps=8.0, header_bytes=0, queue_limit=2)
    ms = [ch.send(0, 1, i, 10, 0.0) for i in range(5)]  # 1 on the air, 2 waiting, 2 dropped
    env.run()
    assert [m.status for m in ms] == ["delivered"] * 3 + ["dropped"] * 2
    assert ms[3].reason == "queue_overflow" and ms[3].t_done == 0.0
    s = ch.log.summary()
    assert s["links"]["0->1"]["dropped_by_reason"]["queue_overflow"] == 2


def test_queue_frees_as_messages_start(make) -> None:
    env, ch, _ = make(bandwidth_bps=8.0, header_bytes=0, queue_limit=1)
    first = [ch.send(0, 1, i, 10, 0.0) for i in range(2)]  # 0..10 on air, 10..20 waiting
    out = []

    def later():
        yield env.timeout(10.0)  # the waiting one has just started: the queue is empty
        out.append(ch.send(0, 1, "c", 10, env.now))
        out.append(ch.send(0, 1, "d", 10, env.now))  # queue full again

    env.process(later())
    env.run()
    assert [m.status for m in first] == ["delivered", "delivered"]
    assert out[0].status == "delivered" and out[0].t_start == 20.0
    assert out[1].reason == "queue_overflow"


def test_per_agent_transmitter_shares_bandwidth(make) -> None:
    env, ch, _ = make(n=3, bandwidth_bps=8.0, header_bytes=0, transmitter="agent",
                      latency={"kind": "constant", "mean_s": 0.0})
    a = ch.send(0, 1, "a", 10, 0.0)
    b = ch.send(0, 2, "b", 10, 0.0)
    env.run()
    assert a.t_done == 10.0 and b.t_start == 10.0 and b.t_done == 20.0


def test_latency_distributions_are_seeded_and_right(make) -> None:
    env, ch, _ = make(latency={"kind": "uniform", "low_s": 0.1, "high_s": 0.3}, header_bytes=0,
                      bandwidth_bps=1e12)
    ms = [ch.send(0, 1, None, 0, 0.0) for _ in range(30)]
    env.run()
    lat = [m.latency for m in ms]
    assert all(0.1 <= x <= 0.3 for x in lat) and len(set(lat)) == 30
    env, ch, _ = make(latency={"kind": "exponential", "mean_s": 0.02, "offset_s": 0.01},
                      header_bytes=0, bandwidth_bps=1e12, queue_limit=10**6)
    ms = [ch.send(0, 1, None, 0, 0.0) for _ in range(20_000)]
    env.run()
    lat = [m.latency for m in ms]
    mean = sum(lat) / len(lat)
    assert min(lat) >= 0.01 and abs(mean - 0.03) < 4 * 0.02 / len(lat) ** 0.5
    env, ch, _ = make(latency={"kind": "lognormal", "mean_s": 0.05, "std_s": 0.02},
                      header_bytes=0, bandwidth_bps=1e12, queue_limit=10**6)
    ms = [ch.send(0, 1, None, 0, 0.0) for _ in range(20_000)]
    env.run()
    lat = [m.latency for m in ms]
    mean = sum(lat) / len(lat)
    sd = (sum((x - mean) ** 2 for x in lat) / len(lat)) ** 0.5
    assert mean == pytest.approx(0.05, rel=0.02) and sd == pytest.approx(0.02, rel=0.05)


def test_events_are_emitted(make) -> None:
    events: list = []
    env, ch, _ = make(bandwidth_bps=8.0, header_bytes=0, latency=CONST, success_rate=0.0,
                      emit=events.append)
    ch.send(0, 1, None, 4, 0.0)
    env.run()
    assert [type(e) for e in events] == [MessageSent, MessageDropped]
    assert events[1].reason == "loss" and events[1].t == 4.25
    events.clear()
    env, ch, _ = make(bandwidth_bps=8.0, header_bytes=0, latency=CONST, emit=events.append)
    ch.send(0, 1, None, 4, -1.0)
    env.run()
    assert [type(e) for e in events] == [MessageSent, MessageDelivered]
    assert events[1].latency == 4.25 and events[1].age == 5.25


def test_bad_sends_raise(make) -> None:
    _, ch, _ = make(n=2)
    with pytest.raises(ValueError, match="agent id 5"):
        ch.send(0, 5, None, 1, 0.0)
    with pytest.raises(ValueError, match="itself"):
        ch.send(1, 1, None, 1, 0.0)
    with pytest.raises(ValueError, match="nbytes"):
        ch.send(0, 1, None, -1, 0.0)
