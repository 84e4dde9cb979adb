"""Event-kernel throughput of the channel with a trivial mapper.

100 agents on a ring; every simulated second each agent broadcasts a small real tensor
(64 float32 = 256 bytes) to its two neighbours, for one simulated hour (720,000 messages).
Prints messages per wall-second, peak Python heap (tracemalloc, separate run) and the
machine. Run: ``PYTHONPATH=. python benchmarks/bench_channel.py [--agents N] [--seconds T]``.
Goal: >= 100,000 messages per wall-second.

Radio models (issue 18): the same traffic with i.i.d. loss at success 0.5, with a
Gilbert-Elliott chain per link at the same mean, and with path loss through walls (the 100
agents on a circle of radius 20 m turning slowly, 25 radial 12 cm walls crossing the ring,
walls counted by Embree ray casting every 0.1 s step). Goal: path loss within 2x of i.i.d.
"""
from __future__ import annotations

import argparse
import math
import os
import resource
import time
import tracemalloc

import numpy as np
import simpy
import torch

from benchmarks._machine import machine_info
from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig


RING_R = 20.0
"""Radius (m) of the circle the agents stand on in the path-loss case."""


def ring_position(n_agents: int):
    """position(agent, t): agents evenly on a circle of radius RING_R at 1 m height, turning at 0.01 rad/s."""
    def position(agent: int, t: float) -> np.ndarray:
        a = 2.0 * math.pi * agent / n_agents + 0.01 * t
        return np.array([RING_R * math.cos(a), RING_R * math.sin(a), 1.0])
    return position


def radial_walls(n_walls: int = 25):
    """first_hit of Embree on n_walls radial walls (12 cm thick, 3 m high) crossing the circle."""
    import trimesh

    from ramensim.world.camera import MeshRayCaster

    boxes = []
    for k in range(n_walls):
        a = 2.0 * math.pi * (k + 0.5) / n_walls
        b = trimesh.creation.box(extents=[6.0, 0.12, 3.0])
        b.apply_translation([RING_R, 0.0, 1.5])
        b.apply_transform(trimesh.transformations.rotation_matrix(a, [0, 0, 1]))
        boxes.append(b)
    caster = MeshRayCaster(trimesh.util.concatenate(boxes), threads=1)
    return lambda o, d: caster.cast(o, d)[0]


def run(n_agents: int, seconds: float, cfg: ChannelConfig, geometry: bool = False) -> tuple[int, float, float, Channel]:
    """Simulate; return (messages, wall seconds, CPU seconds of this process, channel).
    ``geometry``: agents on the circle and radial walls (needed by path loss)."""
    env = simpy.Environment()
    topo = Topology(TopologyConfig(kind="ring"), n_agents)
    kw = {"position": ring_position(n_agents), "first_hit": radial_walls()} if geometry else {}
    ch = Channel(env, cfg, topo, n_agents, np.random.default_rng(0), **kw)
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
    ap.add_argument("--repeats", type=int, default=3, help="runs of each radio model (the fastest counts)")
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
    radio = {
        "i.i.d. loss, p=0.5": (ChannelConfig(success_rate=0.5), False),
        "Gilbert-Elliott, mean p=0.5, bad 2 s": (ChannelConfig(
            success_rate=0.5, burst={"kind": "gilbert_elliott", "mean_bad_s": 2.0}), False),
        "path loss + walls (Embree), p=0.5": (ChannelConfig(
            success_rate=0.5, path_loss={"enabled": True, "curve": [[-75.0, 0.0], [-55.0, 1.0]]}), True),
    }
    print(f"ring of {args.agents} agents, 1 msg/s to each neighbour, {args.seconds:g} simulated s")
    for name, cfg in cases.items():
        n, wall, cpu, ch = run(args.agents, args.seconds, cfg)
        s = ch.log.summary()["total"]
        print(
            f"  {name:50s} {n:7d} msgs: {n / wall:8.0f} msgs/wall-s ({wall:5.2f} s), "
            f"{n / cpu:8.0f} msgs/CPU-s; delivered {s['delivered_fraction']:.3f}"
        )
    print(f"radio models (same traffic; best of {args.repeats} runs, CPU time: the machine is shared):")
    cpu_of = {}
    for name, (cfg, geometry) in radio.items():
        n, wall, cpu, ch = min((run(args.agents, args.seconds, cfg, geometry) for _ in range(args.repeats)),
                               key=lambda r: r[2])
        cpu_of[name] = cpu / n
        s = ch.log.summary()["total"]
        extra = ""
        if ch.models is not None and ch.models.path is not None:
            walls = sorted({v[1][1] for v in ch.models.path._cache.values()})  # noqa: SLF001 - a report
            extra = f"; walls per link {walls}, {ch.models.path.batches} geometry steps"
        print(
            f"  {name:50s} {n:7d} msgs: {n / wall:8.0f} msgs/wall-s ({wall:5.2f} s), "
            f"{n / cpu:8.0f} msgs/CPU-s; delivered {s['delivered_fraction']:.3f}{extra}"
        )
    base = cpu_of["i.i.d. loss, p=0.5"]
    for name, c in cpu_of.items():
        print(f"  CPU per message relative to i.i.d.: {name:40s} {c / base:5.2f}x")
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
