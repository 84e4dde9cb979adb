"""Throughput of the discrete-event kernel (ramensim.agents.process + channels.Channel).

100 agents on a ring, a trivial mapper (a MapperStep whose round does no work and whose
payload is a small real tensor), radio periodic every 1 s (one message per agent per
simulated second to each neighbour), one simulated hour. Prints messages per wall-second,
events, peak memory (tracemalloc peak and ru_maxrss) and the machine.

    PYTHONPATH=. python benchmarks/bench_kernel.py [--agents 100] [--hours 1] [--profile]
"""
from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import resource
import time
import tracemalloc

import numpy as np
import simpy
import torch

from ramensim.core.frames import Frame, FrameFeed, Intrinsics
from ramensim.core.results import RoundResult
from ramensim.agents.process import AgentProcess, ClockModel, Outbox, RadioSchedule, RoundOutcome
from ramensim.agents.rounds import RoundWork
from benchmarks._machine import machine_info
from ramensim.channels.channel import Channel
from ramensim.channels.config import ChannelConfig, TopologyConfig
from ramensim.channels.topology import Topology
from ramensim.core.seeding import Seeds

PAYLOAD_FLOATS = 16
"""Floats in the trivial payload (float32)."""


class TrivialStep:
    """A MapperStep that does no work: one 'iteration' per round, a fresh 16-float tensor as payload."""

    def __init__(self) -> None:
        self.state = torch.zeros(PAYLOAD_FLOATS)
        self.received = 0
        self.latest: dict[int, tuple[float, torch.Tensor]] = {}

    def add_frame(self, frame: Frame, keyframe: bool) -> None:
        pass

    def run_round(self, now: float) -> RoundOutcome:
        return RoundOutcome(RoundResult(loss=0.0, grad_evals=1))

    def begin_round(self, now: float) -> RoundWork:
        return RoundWork(None, lambda learner: self.run_round(now))

    def end_round(self) -> None:
        pass

    def make_payload(self, now: float) -> Outbox:
        p = self.state.clone()
        return Outbox(p, p.numel() * p.element_size())

    def is_finite(self) -> bool:
        return True

    def receive(self, msg) -> None:
        self.received += 1
        self.latest[msg.src] = (msg.stamp, msg.payload)


def build(n_agents: int, seed: int = 0):
    seeds = Seeds(seed)
    env = simpy.Environment()
    topo = Topology(TopologyConfig(kind="ring"), n_agents)
    channel = Channel(env, ChannelConfig(), topo, n_agents, seeds.numpy("channel"))
    K = Intrinsics(1.0, 1.0, 0.5, 0.5, 1, 1)
    frame = Frame(0, 0.0, np.zeros((1, 1, 3), np.float32), np.zeros((1, 1), np.float32), np.eye(4), K)
    start = seeds.numpy("start").uniform(0.0, 1.0, n_agents)
    steps = []
    for k in range(n_agents):
        step = TrivialStep()
        channel.attach(k, step.receive)
        # one frame at t = 0; a round costs 1 s on the compute clock; the radio sends the latest state every 1 s
        feed = FrameFeed(times=[0.0], render=lambda i: frame, is_keyframe=lambda i: True,
                         taken_by=lambda i, k=k: k)
        clock = ClockModel(1.0, start_delay=float(start[k]), rng=seeds.numpy(f"clock/{k}"))
        AgentProcess(env, k, step, feed, clock, radio=channel, schedule=RadioSchedule("periodic", 1.0))
        steps.append(step)
    return env, channel, steps


def run(n_agents: int, sim_s: float) -> dict[str, float]:
    env, channel, steps = build(n_agents)
    t0 = time.perf_counter()
    env.run(until=sim_s)
    wall = time.perf_counter() - t0
    n = len(channel.log)
    return {"messages": n, "delivered": sum(s.received for s in steps), "wall_s": wall, "msgs_per_s": n / wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=100)
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--profile", action="store_true", help="also run a 6-minute cProfile and print the top 25")
    args = ap.parse_args()
    sim_s = 3600.0 * args.hours

    r = run(args.agents, sim_s)
    print(f"kernel: {args.agents} agents, ring, radio periodic 1 s, trivial mapper (1 s rounds), "
          f"{sim_s:.0f} simulated s")
    print(f"  messages {r['messages']:,} (delivered {r['delivered']:,}) in {r['wall_s']:.2f} wall-s "
          f"-> {r['msgs_per_s']:,.0f} messages/wall-s  ({sim_s / r['wall_s']:.0f}x real time)")

    tracemalloc.start()
    run(args.agents, sim_s)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"  peak memory: tracemalloc {peak / 2**20:.1f} MiB (second run, traced), "
          f"ru_maxrss {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB (process)")

    if args.profile:
        env, _, _ = build(args.agents)
        prof = cProfile.Profile()
        prof.enable()
        env.run(until=360.0)
        prof.disable()
        buf = io.StringIO()
        pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(25)
        print(buf.getvalue())
    print(machine_info())


if __name__ == "__main__":
    main()
