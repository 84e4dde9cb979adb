"""The discrete-event core (ramensim.agents.process) wired by hand like ramensim/sim.py does, with the
toy least-squares learner (ramensim.agents.toy) as the mapper step's learner: camera times, the
compute clock, no waiting between agents, copy ages, radio schedules, honest message sizes,
determinism, divergence and DiNNO convergence through the loop. Times are simulated seconds."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import pytest
import simpy
import torch

from ramensim.agents.consensus import ConsensusConfig, make_method
from ramensim.agents.copies import CopyStore
from ramensim.agents.encoding import ARRAY_HEADER_BYTES, HEADER_BYTES, decode
from ramensim.core.frames import Frame, FrameFeed, Intrinsics
from ramensim.agents.process import AgentProcess, ClockModel, RadioSchedule
from ramensim.agents.step import ConsensusStep
from ramensim.agents.toy import LeastSquaresLearner, make_least_squares
from ramensim.channels.channel import Channel
from ramensim.channels.config import ChannelConfig, LatencyConfig, TopologyConfig, WindowConfig
from ramensim.core.events import Diverged, FrameCaptured, RoundCompleted
from ramensim.channels.topology import Topology
from ramensim.core.seeding import Seeds

TOL_T = 1e-9
"""Seconds: simulated times must match the cost model up to float rounding."""

N_PARAMS = 8
K = Intrinsics(2.0, 2.0, 0.5, 0.5, 2, 2)


def tiny_frame(times: list[float], k: int) -> Frame:
    """Frame k of a 2x2 pixel camera (a frame source for the camera process)."""
    return Frame(k, times[k], np.full((2, 2, 3), 0.5, np.float32), np.ones((2, 2), np.float32),
                 np.eye(4), K)


@dataclass
class Loop:
    """A wired simulation: environment, channel, per-agent processes/steps/learners, and
    everything the event sink and the receivers saw."""

    env: simpy.Environment
    channel: Channel
    procs: list[AgentProcess]
    steps: list[ConsensusStep]
    learners: list[LeastSquaresLearner]
    problem: object
    events: list = field(default_factory=list)
    delivered: list = field(default_factory=list)
    frames_added: dict = field(default_factory=dict)

    def of(self, kind, agent=None):
        return [e for e in self.events if isinstance(e, kind) and (agent is None or e.agent == agent)]

    def records(self):
        return self.channel.log.records()


class NaNAfter(LeastSquaresLearner):
    """A toy learner whose gradient turns NaN after ``good`` gradient evaluations."""

    def __init__(self, *args, good: int, **kw) -> None:
        super().__init__(*args, **kw)
        self.good = good
        self.calls = 0

    def loss_and_grad(self):
        scalars, grad = super().loss_and_grad()
        self.calls += 1
        if self.calls > self.good:
            grad.fill_(math.nan)
        return scalars, grad


def build(n: int = 3, *, seed: int = 0, method: str = "dinno", topology: str = "complete",
          speeds=None, delays=None, spi: float = 0.1, primal_steps: int = 5, jitter: float = 0.0,
          frame_times=(0.0,), keyframe_every: int = 1, radio: RadioSchedule | None = None,
          channel: ChannelConfig | None = None, encoding: str = "float32", lr: float = 0.5,
          rho: float = 0.1, nan_agent: int | None = None, nan_after: int = 0, dual: str = "node",
          primal: str = "joint") -> Loop:
    """Wire ``n`` agents: toy learner -> consensus method -> copy store -> ConsensusStep ->
    AgentProcess, over one Channel, with one event sink collecting every event."""
    seeds = Seeds(seed)
    env = simpy.Environment()
    problem = make_least_squares(n, N_PARAMS, 12, seeds.numpy("problem"))
    topo = Topology(TopologyConfig(kind=topology), n)
    loop = Loop(env, None, [], [], [], problem)  # type: ignore[arg-type]
    sink = loop.events.append
    ch = Channel(env, channel or ChannelConfig(), topo, n, seeds.numpy("channel"), emit=sink)
    loop.channel = ch
    cfg = ConsensusConfig(primal_steps=primal_steps, encoding=encoding, dual_update=dual, primal_update=primal,
                          dinno={"rho": rho}, ramen={"rho": rho, "beta_l": rho / 10})
    speeds = speeds or [1.0] * n
    delays = delays or [0.0] * n
    times = list(frame_times)
    for k in range(n):
        if k == nan_agent:
            learner = NaNAfter(problem.A[k], problem.b[k], problem.total_rows, problem.theta0,
                               lr=lr, good=nan_after)
        else:
            learner = problem.learner(k, lr=lr)
        neighbours = topo.neighbours(k)
        store = CopyStore(k, neighbours)
        added = loop.frames_added.setdefault(k, [])
        step = ConsensusStep(k, learner, make_method(method, cfg, problem.n, degree=len(neighbours), agent=k),
                             store, encoding, problem.theta0, partial(lambda a: len(ch.neighbours(a)), k),
                             add_frame=lambda f, kf, added=added: added.append((f.index, kf)))

        def deliver(msg, step=step):
            loop.delivered.append(msg)
            step.receive(msg.src, msg.payload, msg.stamp, env.now)

        ch.attach(k, deliver)
        feed = FrameFeed(times, partial(tiny_frame, times), lambda i: i % keyframe_every == 0, lambda i, k=k: k)
        clock = ClockModel(spi, speeds[k], jitter, start_delay=delays[k], rng=seeds.numpy(f"clock/{k}"))
        loop.procs.append(AgentProcess(env, k, step, feed, clock, radio=ch, schedule=radio or RadioSchedule(),
                                       emit=sink))
        loop.steps.append(step)
        loop.learners.append(learner)
    return loop


def expected_round_ends(start: float, cost: float, until: float) -> list[float]:
    """Round end times of a jitter-free mapper that starts at ``start`` (s); events at exactly
    ``until`` are not processed by ``env.run(until=...)``, so tests pick an ``until`` off the grid."""
    ends, t = [], start
    while t + cost < until:
        t = t + cost
        ends.append(t)
    return ends


# --- camera --------------------------------------------------------------------------

def test_camera_delivers_frames_at_k_over_fps_and_every_kth_is_keyframe():
    fps, n_frames, every = 10.0, 25, 4
    delays = [0.7, 0.0]
    loop = build(2, frame_times=[k / fps for k in range(n_frames)], keyframe_every=every, delays=delays)
    loop.env.run(until=10.0)
    for a in (0, 1):
        caps = loop.of(FrameCaptured, a)
        assert [e.index for e in caps] == list(range(n_frames))
        for k, e in enumerate(caps):
            assert e.t == pytest.approx(delays[a] + k / fps, abs=TOL_T)
            assert e.keyframe == (k % every == 0)
        assert loop.frames_added[a] == [(k, k % every == 0) for k in range(n_frames)]
        assert loop.procs[a].frames_seen == n_frames


# --- compute clock -------------------------------------------------------------------

def test_rounds_end_when_the_cost_model_says_with_speeds_and_start_delays():
    spi, steps, until = 0.1, 5, 20.03
    speeds, delays = [1.0, 2.5, 0.4], [0.0, 1.25, 3.0]
    # agent 2's first frame comes 2 s after its start: its mapper waits for data
    loop = build(3, speeds=speeds, delays=delays, spi=spi, primal_steps=steps, frame_times=[0.0],
                 radio=RadioSchedule("every_round"))
    loop.procs[2].frames = dataclasses.replace(loop.procs[2].frames, times=[2.0])
    loop.env.run(until=until)
    for a in range(3):
        cost = steps * spi * speeds[a]
        start = delays[a] + (2.0 if a == 2 else 0.0)
        want = expected_round_ends(start, cost, until)
        got = loop.of(RoundCompleted, a)
        assert len(got) == len(want) == loop.procs[a].rounds
        assert [e.round for e in got] == list(range(1, len(want) + 1))
        assert [e.t for e in got] == pytest.approx(want, abs=TOL_T)
        assert all(e.duration == pytest.approx(cost, rel=1e-12) for e in got)
        assert loop.procs[a].busy_s == pytest.approx(len(want) * cost, rel=1e-9)


def test_no_waiting_a_slow_silent_agent_does_not_slow_a_fast_one():
    until, spi, steps = 30.03, 0.1, 5
    # agent 1's first round would take 5000 s: it never finishes one, so it never sends
    loop = build(3, topology="path", speeds=[1.0, 10_000.0, 1.7], spi=spi, primal_steps=steps,
                 radio=RadioSchedule("every_round"))
    loop.env.run(until=until)
    for a, speed in ((0, 1.0), (2, 1.7)):
        assert loop.procs[a].rounds == len(expected_round_ends(0.0, steps * spi * speed, until))
        # its only neighbour (1) never sent: the copy was always left out
        assert all(e.copy_ages == {1: None} for e in loop.of(RoundCompleted, a))
    assert loop.procs[1].rounds == 0
    r = loop.records()
    assert r.size > 0 and not np.any(r["src"] == 1)


# --- copies and their ages -----------------------------------------------------------

def test_copy_ages_match_the_message_log():
    chan = ChannelConfig(success_rate=0.6, latency=LatencyConfig(kind="uniform", low_s=0.01, high_s=0.9))
    loop = build(3, speeds=[1.0, 1.37, 0.61], delays=[0.0, 0.3, 0.11], spi=0.1, primal_steps=5,
                 radio=RadioSchedule("every_round"), channel=chan)
    loop.env.run(until=40.0)
    r = loop.records()
    ok = r[r["status"] == 0]
    checked = none_seen = stale_seen = 0
    for e in loop.of(RoundCompleted):
        t0 = e.t - e.duration
        for j, age in e.copy_ages.items():
            arrived = ok[(ok["dst"] == e.agent) & (ok["src"] == j) & (ok["t_done"] <= t0)]
            if arrived.size == 0:
                assert age is None, (e, j)
                none_seen += 1
                continue
            assert age == pytest.approx(t0 - arrived["stamp"].max(), abs=TOL_T), (e, j)
            sent = r[(r["dst"] == e.agent) & (r["src"] == j) & (r["t_sent"] <= t0)]
            stale_seen += bool(arrived["stamp"].max() < sent["stamp"].max())
            checked += 1
    assert checked > 100 and none_seen > 0 and stale_seen > 10, (checked, none_seen, stale_seen)
    # the copy held at the end is the newest-stamped message that arrived, as sent
    for i, step in enumerate(loop.steps):
        for j in step.store.neighbours:
            msgs = [m for m in loop.delivered if m.dst == i and m.src == j]
            newest = max(msgs, key=lambda m: m.stamp)
            held = step.store.get(j)
            assert held.stamp == newest.stamp
            assert torch.equal(held.theta, decode(newest.payload, loop.problem.theta0)["theta"])


# --- radio ---------------------------------------------------------------------------

def test_every_round_radio_sends_after_each_round():
    loop = build(3, speeds=[1.0, 1.6, 0.7], delays=[0.0, 0.2, 0.5], radio=RadioSchedule("every_round"))
    loop.env.run(until=15.0)
    r = loop.records()
    for a in range(3):
        ends = [e.t for e in loop.of(RoundCompleted, a)]
        mine = r[r["src"] == a]
        for j in (b for b in range(3) if b != a):
            link = mine[mine["dst"] == j]
            assert link["t_sent"].tolist() == pytest.approx(ends, abs=TOL_T)
            assert np.array_equal(link["stamp"], link["t_sent"])


def test_periodic_radio_sends_every_period_the_latest_state():
    period, until = 2.0, 21.0
    delays = [0.05, 0.4]
    # round costs 0.411 s and 0.333 s: no round ends on a radio tick (ties are order-dependent)
    loop = build(2, delays=delays, spi=0.1, primal_steps=3, speeds=[1.37, 1.11],
                 radio=RadioSchedule("periodic", period))
    loop.env.run(until=until)
    r = loop.records()
    for a in (0, 1):
        ends = np.array([e.t for e in loop.of(RoundCompleted, a)])
        link = r[r["src"] == a]
        ticks = [delays[a] + period * k for k in range(1, int((until - delays[a]) // period) + 1)]
        assert link["t_sent"].tolist() == pytest.approx(ticks, abs=TOL_T)
        for t_sent, stamp in zip(link["t_sent"], link["stamp"]):
            assert stamp == ends[ends <= t_sent + TOL_T].max()


def _window_loop(radio: RadioSchedule) -> Loop:
    chan = ChannelConfig(windows=WindowConfig(kind="periodic", period_s=30.0, open_s=2.0))
    return build(2, spi=0.1, primal_steps=7, speeds=[1.0, 1.3], radio=radio, channel=chan)


@pytest.mark.parametrize("radio", [RadioSchedule("every_round"), RadioSchedule("periodic", 0.5)])
def test_periodic_window_messages_only_while_open(radio):
    loop = _window_loop(radio)
    loop.env.run(until=100.0)
    r = loop.records()
    assert r.size > 0
    assert np.all(np.mod(r["t_sent"], 30.0) < 2.0)  # sent only while the window is open
    assert np.all(r["status"] == 0)  # the agents did not even try while it was closed
    for opening in (0.0, 30.0, 60.0, 90.0):
        inside = r[(r["t_sent"] >= opening) & (r["t_sent"] < opening + 2.0)]
        assert set(inside["src"].tolist()) == {0, 1}, opening


def test_periodic_window_one_message_goes_out_at_each_opening():
    loop = _window_loop(RadioSchedule("every_round"))
    loop.env.run(until=100.0)
    r = loop.records()
    for opening in (30.0, 60.0, 90.0):
        for a in (0, 1):
            at = r[(r["src"] == a) & (np.abs(r["t_sent"] - opening) < TOL_T)]
            assert at.size == 1, (opening, a)


# --- honest sizes --------------------------------------------------------------------

@pytest.mark.parametrize("method,encoding,vectors,itemsize", [
    ("dinno", "float32", 1, 4), ("ramen", "float32", 2, 4), ("dinno", "float16", 1, 2)])
def test_message_nbytes_is_encoded_tensor_bytes_plus_header(method, encoding, vectors, itemsize):
    loop = build(3, method=method, encoding=encoding, radio=RadioSchedule("every_round"))
    loop.env.run(until=5.0)
    r = loop.records()
    want = HEADER_BYTES + vectors * (ARRAY_HEADER_BYTES + itemsize * N_PARAMS)
    assert r.size > 0 and np.all(r["nbytes"] == want)
    assert np.all(r["wire_bytes"] == want + ChannelConfig().header_bytes)
    for m in loop.delivered:
        arrays = m.payload.arrays
        assert m.nbytes == HEADER_BYTES + sum(ARRAY_HEADER_BYTES + a.nbytes for a in arrays.values())
        assert arrays["theta"].shape == (N_PARAMS,) and arrays["theta"].itemsize == itemsize


# --- determinism ---------------------------------------------------------------------

def _random_run(seed: int, tmp_path):
    chan = ChannelConfig(success_rate=0.7, latency=LatencyConfig(kind="uniform", low_s=0.01, high_s=0.3))
    loop = build(4, seed=seed, topology="ring", speeds=[1.0, 1.2, 0.9, 1.5], jitter=0.2, channel=chan,
                 radio=RadioSchedule("every_round"))
    loop.env.run(until=20.0)
    path = tmp_path / f"messages_{seed}_{len(list(tmp_path.iterdir()))}.csv"
    loop.channel.log.write_csv(path)
    return path.read_bytes(), [lr.theta.clone() for lr in loop.learners]


def test_same_seed_same_log_and_thetas_different_seed_different_log(tmp_path):
    csv_a, th_a = _random_run(3, tmp_path)
    csv_b, th_b = _random_run(3, tmp_path)
    csv_c, _ = _random_run(4, tmp_path)
    assert csv_a.count(b"\n") > 100
    assert csv_a == csv_b
    assert all(torch.equal(x, y) for x, y in zip(th_a, th_b))
    assert csv_a != csv_c


# --- divergence ----------------------------------------------------------------------

def test_nan_learner_marks_its_agent_diverged_and_the_others_go_on():
    spi, steps, until = 0.1, 5, 20.03
    loop = build(3, spi=spi, primal_steps=steps, radio=RadioSchedule("every_round"),
                 nan_agent=1, nan_after=3 * steps)  # rounds 1-3 fine, round 4 goes NaN
    loop.env.run(until=until)
    cost = steps * spi
    div = loop.of(Diverged)
    assert [(e.agent, e.round) for e in div] == [(1, 4)]
    assert div[0].t == pytest.approx(4 * cost, abs=TOL_T)
    assert loop.procs[1].diverged == (4, "non-finite loss")
    assert len(loop.of(RoundCompleted, 1)) == 3
    r = loop.records()
    assert np.all(r["t_sent"][r["src"] == 1] < div[0].t)  # the NaN state was never sent
    for a in (0, 2):
        assert loop.procs[a].rounds == len(expected_round_ends(0.0, cost, until))
        assert torch.isfinite(loop.learners[a].theta).all()
        # after the divergence its copy of agent 1 only gets older
        late = [e.copy_ages[1] for e in loop.of(RoundCompleted, a) if e.t > div[0].t + cost]
        assert late and all(age is not None and age > 0 for age in late)
        assert late == sorted(late)


# --- convergence through the loop ----------------------------------------------------

def test_dinno_over_the_loop_converges_to_the_centralised_solution():
    """Through the loop every copy is at least one round old (a round starts the instant the
    neighbour's previous one ends, and messages take time), so the DiNNO duals no longer sum
    to zero and the fixed point is biased by O(rho) (measured: rho 0.1 -> 0.32, 0.01 -> 0.083,
    0.003 -> 0.030 relative error; docs/KERNEL.md). Small rho, loose tolerance."""
    kw = dict(speeds=[1.0, 1.3, 0.8, 1.1], delays=[0.0, 0.2, 0.1, 0.35], spi=0.01, primal_steps=10,
              radio=RadioSchedule("every_round"))
    local = build(4, method="local", **kw)
    loop = build(4, method="dinno", rho=0.003, **kw)
    x_star = loop.problem.centralised_solution()

    def worst(lp):
        return max(float(torch.linalg.vector_norm(lr.theta.double() - x_star) / torch.linalg.vector_norm(x_star))
                   for lr in lp.learners)

    start = worst(loop)
    loop.env.run(until=30.0)
    local.env.run(until=30.0)
    end = worst(loop)
    assert all(p.rounds > 200 for p in loop.procs)
    assert worst(local) > 0.5  # each agent alone misses columns: far from x*
    assert end < 0.06 and end < 0.1 * worst(local) and end < 0.05 * start, (start, end, worst(local))


@pytest.mark.parametrize("success", [1.0, 0.5])
def test_antisymmetric_duals_over_the_loop_reach_the_centralised_solution(success):
    """The same asynchronous loop with rho = 0.1 (node duals: 0.32 relative error even with
    every message delivered): each end of a link holds half of its dual, advances it on new
    copies and sends it with its messages on that link; the duals of the two ends cancel at
    any fixed point whatever the copies' ages and losses. The half costs one more array on
    each message (honest bytes)."""
    kw = dict(speeds=[1.0, 1.3, 0.8, 1.1], delays=[0.0, 0.2, 0.1, 0.35], spi=0.01, primal_steps=10,
              radio=RadioSchedule("every_round"), channel=ChannelConfig(success_rate=success))
    loop = build(4, method="dinno", rho=0.1, dual="antisymmetric", **kw)
    x_star = loop.problem.centralised_solution()
    loop.env.run(until=30.0)
    worst = max(float(torch.linalg.vector_norm(lr.theta.double() - x_star) / torch.linalg.vector_norm(x_star))
                for lr in loop.learners)
    assert worst < 1e-5, worst
    base = HEADER_BYTES + ARRAY_HEADER_BYTES + 4 * N_PARAMS
    nbytes = loop.records()["nbytes"]
    with_half = nbytes == base + HEADER_BYTES + ARRAY_HEADER_BYTES + 4 * N_PARAMS
    assert np.all(with_half | (nbytes == base)) and with_half.mean() > 0.9  # only first messages lack it
    total = sum(step.method.p for step in loop.steps)  # the duals cancel: sum_i p_i -> 0
    assert float(total.norm()) < 1e-4 * max(float(step.method.p.norm()) for step in loop.steps)
