"""Nothing crosses a closed window or a link out of range; a path graph has no shortcuts."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ramensim.channels.config import WindowConfig
from ramensim.core.events import LinkChange
from ramensim.channels.windows import Windows


def _traffic(env, ch, rng, n_msgs, pairs, max_bytes, gap):
    def proc():
        for _ in range(n_msgs):
            a, b = pairs[int(rng.integers(len(pairs)))]
            ch.send(a, b, None, int(rng.integers(0, max_bytes)), env.now)
            yield env.timeout(float(rng.exponential(gap)))

    env.process(proc())


def test_windows_class() -> None:
    w = Windows(WindowConfig(kind="periodic", period_s=30.0, open_s=2.0, phase_s=5.0), 2)
    assert w.is_open(0, 1, 5.0) and w.is_open(0, 1, 6.9) and not w.is_open(0, 1, 7.0)
    assert not w.is_open(0, 1, 4.99) and w.is_open(0, 1, 35.5) and w.is_open(0, 1, -25.0)
    assert w.close_after(0, 1, 6.0) == 7.0 and w.close_after(0, 1, 8.0) == 8.0
    assert w.next_open(0, 1, 8.0) == 35.0 and w.next_open(0, 1, 6.0) == 6.0
    assert w.is_open(0, 1, 5.0 + 3 * 30.0)  # an opening computed as phase + k * period
    s = Windows(WindowConfig(kind="schedule", schedule={"1-0": [(1.0, 2.0), (1.5, 3.0), (10.0, 11.0)],
                                                          "*": [(0.0, 0.5)]}), 3)
    assert s.is_open(0, 1, 2.5) and not s.is_open(0, 1, 3.0) and not s.is_open(0, 1, 0.2)
    assert s.next_open(1, 0, 3.0) == 10.0 and s.next_open(0, 1, 11.0) is None
    assert s.close_after(0, 1, 1.2) == 3.0
    assert s.is_open(1, 2, 0.2) and not s.is_open(1, 2, 1.2)
    with pytest.raises(ValueError, match="names agent 4"):
        Windows(WindowConfig(kind="schedule", schedule={"0-4": [(0.0, 1.0)]}), 3)


@pytest.mark.parametrize("mode", ["message", "packet"])
@pytest.mark.parametrize("windows", [
    {"kind": "periodic", "period_s": 10.0, "open_s": 3.0, "phase_s": 1.0},
    {"kind": "schedule", "schedule": {"0-1": [[0.0, 4.0], [20.0, 21.5], [40.0, 47.0]], "*": [[5.0, 9.0]]}},
])
def test_nothing_crosses_a_closed_window(make, mode, windows) -> None:
    env, ch, _ = make(n=3, mode=mode, windows=windows, bandwidth_bps=8000.0, header_bytes=0,
                      mtu_bytes=200, packet_loss=0.0)
    rng = np.random.default_rng(1)
    _traffic(env, ch, rng, 600, [(0, 1), (1, 0), (1, 2), (2, 0)], 1500, 0.1)
    env.run()
    r = ch.log.records()
    ok = r[r["status"] == 0]
    assert ok.size > 20 and (r["reason"] == 4).sum() > 20  # both outcomes occur (4 = window_closed)
    for m in ok:
        a, b = int(m["src"]), int(m["dst"])
        t0 = float(m["t_start"])
        t1 = t0 + float(m["wire_bytes"]) * 8.0 / 8000.0
        assert ch.window_open(a, b, float(m["t_sent"])) and ch.window_open(a, b, t0)
        assert t1 <= ch.windows.close_after(a, b, t0) + 1e-12
    for m in r[r["reason"] == 4]:  # dropped for the window at send, start or closing time: closed then
        assert not ch.window_open(int(m["src"]), int(m["dst"]), float(m["t_done"]))


def _moving(agent: int, t: float) -> np.ndarray:
    """Agent 1 oscillates along x between 0 and 20 m (period 40 s); agent 0 sits at 0."""
    if agent == 0:
        return np.zeros(3)
    return np.array([10.0 - 10.0 * math.cos(2 * math.pi * t / 40.0), 0.0, 0.0])


@pytest.mark.parametrize("mode", ["message", "packet"])
def test_nothing_crosses_out_of_range(make, mode) -> None:
    env, ch, _ = make(mode=mode, range_m=12.0, position=_moving, bandwidth_bps=8000.0,
                      header_bytes=0, mtu_bytes=500, range_check_resolution_s=0.0)
    rng = np.random.default_rng(2)
    _traffic(env, ch, rng, 400, [(0, 1), (1, 0)], 4000, 0.5)
    env.run()
    r = ch.log.records()
    ok, oor = r[r["status"] == 0], r[r["reason"] == 3]  # 3 = out_of_range
    assert ok.size > 50 and oor.size > 50
    for m in ok:
        t0 = float(m["t_start"])
        t1 = t0 + float(m["wire_bytes"]) * 8.0 / 8000.0
        assert abs(_moving(1, t0)[0]) <= 12.0 and abs(_moving(1, t1)[0]) <= 12.0
        if mode == "packet":  # every packet boundary was in range
            for tb in np.arange(t0, t1, 500 * 8.0 / 8000.0):
                assert _moving(1, tb)[0] <= 12.0
    # Drops for range happen at a time when the agents are out of range.
    for m in oor:
        assert _moving(1, float(m["t_done"]))[0] > 12.0


def test_packet_mode_aborts_at_first_bad_boundary(make) -> None:
    def pos(agent: int, t: float) -> np.ndarray:
        return np.array([0.0, 0, 0]) if agent == 0 else np.array([t, 0.0, 0.0])  # leaves range at t=10

    env, ch, _ = make(mode="packet", range_m=10.0, position=pos, bandwidth_bps=8.0, header_bytes=0,
                      mtu_bytes=3, range_check_resolution_s=0.0, latency={"kind": "constant", "mean_s": 0.0})
    m = ch.send(0, 1, None, 30, 0.0)  # packets end at 3, 6, 9, 12 ...: 12 is the first boundary out of range
    env.run()
    assert m.reason == "out_of_range" and m.t_done == 12.0 and m.wire_bytes == 12
    # Thinned checks (at most every 7 s): boundaries 9 and 15 are checked, so the abort is at 15.
    env, ch, _ = make(mode="packet", range_m=10.0, position=pos, bandwidth_bps=8.0, header_bytes=0,
                      mtu_bytes=3, range_check_resolution_s=7.0, latency={"kind": "constant", "mean_s": 0.0})
    m = ch.send(0, 1, None, 30, 0.0)
    env.run()
    assert m.reason == "out_of_range" and m.t_done == 15.0
    env, ch, _ = make(mode="message", range_m=10.0, position=pos, bandwidth_bps=8.0, header_bytes=0,
                      latency={"kind": "constant", "mean_s": 0.0})
    m = ch.send(0, 1, None, 30, 0.0)  # message mode checks start and end only
    env.run()
    assert m.reason == "out_of_range" and m.t_done == 30.0


def test_path_graph_has_no_shortcut(make) -> None:
    env, ch, inbox = make(n=3, topology="path", success_rate=0.7)

    def chatter(i):
        for _ in range(200):
            ch.broadcast(i, f"from {i}", 100, env.now)
            yield env.timeout(0.01)

    for i in range(3):
        env.process(chatter(i))
    env.run()
    assert {m.src for _, m in inbox[0]} == {1}
    assert {m.src for _, m in inbox[2]} == {1}
    assert {m.src for _, m in inbox[1]} == {0, 2}
    m = ch.send(2, 0, "direct", 10, env.now)
    assert m.status == "dropped" and m.reason == "no_link"
    assert ch.neighbours(0) == [1] and ch.neighbours(1) == [0, 2]


def test_link_monitor_reports_changes(make) -> None:
    events: list = []
    env, ch, _ = make(n=2, windows={"kind": "periodic", "period_s": 10.0, "open_s": 4.0},
                      link_monitor_period_s=1.0, emit=events.append)
    env.run(until=25.0)
    changes = [(e.t, e.up, e.cause) for e in events if isinstance(e, LinkChange)]
    assert changes == [(0.0, True, "initial"), (4.0, False, "window"), (10.0, True, "window"),
                       (14.0, False, "window"), (20.0, True, "window"), (24.0, False, "window")]


def test_disk_topology_in_channel(make) -> None:
    def pos(agent: int, t: float) -> np.ndarray:
        return np.array([0.0, 0, 0]) if agent == 0 else np.array([t, 0.0, 0.0])

    env, ch, _ = make(n=2, topology="disk", position=pos, topo_kw={"disk_radius_m": 5.0})
    out = []

    def proc():
        out.append(ch.broadcast(0, None, 10, env.now))
        yield env.timeout(6.0)
        out.append(ch.broadcast(0, None, 10, env.now))
        out.append([ch.send(0, 1, None, 10, env.now)])

    env.process(proc())
    env.run()
    assert len(out[0]) == 1 and out[0][0].status == "delivered"
    assert out[1] == [] and out[2][0].reason == "no_link"


def test_reachable_and_window_queries(make) -> None:
    env, ch, _ = make(n=3, windows={"kind": "schedule", "schedule": {"0-1": [[0.0, 5.0]]}})
    assert ch.reachable(0) == [1] and ch.neighbours(0) == [1, 2]
    assert ch.link_up(0, 1) and not ch.link_up(0, 2)
    assert ch.next_window_open(0, 2, 0.0) is None and ch.next_window_open(1, 0, 0.0) == 0.0
    ms = ch.broadcast(0, None, 1, 0.0)
    assert [m.reason for m in ms] == ["", "window_closed"]
    assert [m.dst for m in ch.broadcast(0, None, 1, 0.0, reachable_only=True)] == [1]
