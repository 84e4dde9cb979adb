"""Event-kernel throughput of the channel with a trivial mapper.

100 agents on a ring; every simulated second each agent broadcasts a small real tensor
(64 float32 = 256 bytes) to its two neighbours, for one simulated hour (720,000 messages).
Prints messages per wall-second, peak Python heap (tracemalloc, separate run) and the
machine. Run: ``PYTHONPATH=. python benchmarks/bench_channel.py [--agents N] [--seconds T]``.
Goal: >= 100,000 messages per wall-second.
"""
from __future__ import annotations

import argparse
import os
import resource
import time
import tracemalloc

import numpy as np
import simpy
import torch

from benchmarks._machine import machine_info
from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig


def run(n_agents: int, seconds: float, cfg: ChannelConfig) -> tuple[int, float, float, Channel]:
    """Simulate; return (messages, wall seconds, CPU seconds of this process, channel)."""
    env = simpy.Environment()
    topo = Topology(TopologyConfig(kind="ring"), n_agents)
    ch = Channel(env, cfg, topo, n_agents, np.random.default_rng(0))
    received = [0] * n_agents

    def receiver(i: int):
        def on_receive(msg) -> None:
            received[i] += 1
        return on_receive

    def mapper(i: int):
        payload = torch.full((64,), float(i))
        nbytes = payload.element_size() * payload.numel()
        nbrs = ch.neighbours(i)
        while True:
            yield env.timeout(1.0)
            now = env.now
            for j in nbrs:
                ch.send(i, j, payload, nbytes, now)

    for i in range(n_agents):
        ch.attach(i, receiver(i))
        env.process(mapper(i))
    t0, c0 = time.perf_counter(), time.process_time()
    env.run(until=seconds + 0.5)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return len(ch.log), wall, cpu, ch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=3600.0)
    args = ap.parse_args()

    cases = {
        "message mode, p=1.0": ChannelConfig(),
        "message mode, p=0.5, lognormal latency": ChannelConfig(
            success_rate=0.5, latency={"kind": "lognormal", "mean_s": 0.005, "std_s": 0.002}
        ),
        "packet mode, q=0.01, retransmit, periodic windows": ChannelConfig(
            mode="packet", packet_loss=0.01, reassembly="retransmit",
            windows={"kind": "periodic", "period_s": 1.0, "open_s": 0.5},
        ),
    }
    print(f"ring of {args.agents} agents, 1 msg/s to each neighbour, {args.seconds:g} simulated s")
    for name, cfg in cases.items():
        n, wall, cpu, ch = run(args.agents, args.seconds, cfg)
        s = ch.log.summary()["total"]
        print(
            f"  {name:50s} {n:7d} msgs: {n / wall:8.0f} msgs/wall-s ({wall:5.2f} s), "
            f"{n / cpu:8.0f} msgs/CPU-s; delivered {s['delivered_fraction']:.3f}"
        )
    # Peak memory on the first case, measured apart (tracemalloc slows the run).
    tracemalloc.start()
    n, _, _, _ = run(args.agents, args.seconds, ChannelConfig())
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"  peak Python heap {peak / 2**20:.1f} MiB for {n} messages ({peak / n:.0f} B/msg); max RSS {rss:.0f} MiB")
    print(f"  load average at the end: {os.getloadavg()[0]:.2f} (wall rates fall when other jobs share the cores)")
    print(machine_info())


if __name__ == "__main__":
    main()
