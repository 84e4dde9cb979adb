"""The shared medium (issue 66): its DCF against Bianchi's model, and what it costs.

Part 1 (``--table``): ``ramensim medium saturation`` over Bianchi's Table II (FHSS, 1 Mbit/s)
for basic access and RTS/CTS, 5-50 stations, W = 32 or 128, m = 3 or 5: simulated throughput and
collision probability beside the model's (the table of docs/RADIO.md, "A shared medium").

Part 2 (``--cost``): the channel alone carrying a run's traffic, private links against the shared
medium: n robots on a ring (3: complete), each sending a RAMEN-sized message (12,582,968 bytes) to
every neighbour once per 1-s round at 100 Mbit/s, for T simulated seconds: wall time, medium
events, messages delivered. The medium's share of a run is this wall over the run's (a 600-s
3-robot house run takes 600-900 s of wall on 2 cores: docs/BENCHMARKS.md).

Part 3: ``medium saturation --stations 50`` (200 s simulated) on one core: wall time.

Part 4 (``--run-share``): a real run (``scenarios/house_3agents.yaml``, RAMEN, 30 s, recording
off, final evaluation only, one thread, robots' rounds inline) on ``access: dcf`` under cProfile:
the self time of ``channels/medium`` and of all of ``channels/`` as a share of the run's.

    PYTHONPATH=. python benchmarks/bench_medium.py --table --cost --saturation50 --run-share
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import simpy

from benchmarks._machine import machine_info
from ramensim.channels import Channel, ChannelConfig, Topology, TopologyConfig
from ramensim.channels.medium.saturation import SaturationSetup, simulate

RAMEN_BYTES = 12_582_968


def table(duration_s: float) -> None:
    print("| access | n | W | m | throughput sim | model | collision p sim | model |")
    print("|---|---|---|---|---|---|---|---|")
    worst = 0.0
    for rts in (False, True):
        for n in (5, 10, 20, 50):
            for w, m in ((32, 3), (32, 5), (128, 3), (128, 5)):
                r = simulate(SaturationSetup(stations=n, cw_min=w, max_stage=m, rts_cts=rts, duration_s=duration_s))
                worst = max(worst, abs(r.throughput - r.model_throughput),
                            abs(r.collision_probability - r.model_collision_probability))
                print(f"| {'RTS/CTS' if rts else 'basic'} | {n} | {w} | {m} | {r.throughput:.4f} | "
                      f"{r.model_throughput:.4f} | {r.collision_probability:.4f} | "
                      f"{r.model_collision_probability:.4f} |")
    print(f"largest difference from the model, either figure: {worst:.4f}")


def channel_cost(n: int, seconds: float, medium: dict) -> tuple[float, int, int, int]:
    env = simpy.Environment()
    cfg = ChannelConfig.model_validate({"bandwidth_bps": 100e6, "success_rate": 0.5, "medium": medium,
                                        "latency": {"mean_s": 0.005}})
    topo = Topology(TopologyConfig(kind="complete" if n <= 3 else "ring"), n)
    ch = Channel(env, cfg, topo, n, np.random.default_rng(0), position=lambda a, t: np.array([a * 0.5, 0.0, 0.0]))

    def robot(i):
        while True:
            for j in topo.neighbours(i):
                ch.send(i, j, None, RAMEN_BYTES, env.now)
            yield env.timeout(1.0)

    for i in range(n):
        env.process(robot(i))
    t0 = time.perf_counter()
    env.run(until=seconds)
    wall = time.perf_counter() - t0
    events = ch.medium.clock.events if ch.medium is not None else 0
    r = ch.log.records()
    return wall, events, int((r["status"] == 0).sum()), ch.n_sent


def run_share(seconds: float) -> None:
    import cProfile
    import os
    import pstats
    import tempfile

    import ramensim

    os.environ.setdefault("RAMENSIM_TEAM_WORKERS", "1")  # rounds inline: the profile sees them
    prof = cProfile.Profile()
    with tempfile.TemporaryDirectory() as tmp:
        prof.enable()
        ramensim.run("scenarios/house_3agents.yaml", out=f"{tmp}/run", overrides={
            "duration": seconds, "recording.mode": "off", "evaluation.every_s": None,
            "channel.medium.kind": "shared", "channel.medium.access": "dcf"})
        prof.disable()
    st = pstats.Stats(prof)
    total = st.total_tt
    medium = sum(v[2] for k, v in st.stats.items() if "/channels/medium/" in k[0])
    channel = sum(v[2] for k, v in st.stats.items() if "/channels/" in k[0])
    print(f"house, 3 robots, RAMEN, dcf, {seconds:g} s under cProfile: {total:.1f} s of self time in all; "
          f"channels/medium {medium:.2f} s ({100 * medium / total:.1f} %), channels/ {channel:.2f} s "
          f"({100 * channel / total:.1f} %)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--table", action="store_true")
    ap.add_argument("--table-seconds", type=float, default=100.0)
    ap.add_argument("--cost", action="store_true")
    ap.add_argument("--saturation50", action="store_true")
    ap.add_argument("--run-share", action="store_true")
    ap.add_argument("--run-seconds", type=float, default=30.0)
    args = ap.parse_args()
    print(machine_info())
    if args.table:
        table(args.table_seconds)
    if args.cost:
        print("| robots | simulated s | medium | wall s | medium events | delivered / sent |")
        print("|---|---|---|---|---|---|")
        for n, secs in ((3, 600.0), (24, 60.0)):
            for medium in ({"kind": "links"}, {"kind": "shared", "access": "fair"},
                           {"kind": "shared", "access": "dcf"}):
                wall, ev, ok, sent = channel_cost(n, secs, medium)
                name = medium["kind"] if medium["kind"] == "links" else f"shared {medium['access']}"
                print(f"| {n} | {secs:g} | {name} | {wall:.2f} | {ev} | {ok} / {sent} |")
    if args.saturation50:
        t0 = time.perf_counter()
        r = simulate(SaturationSetup(stations=50))
        print(f"medium saturation --stations 50 (200 s simulated, basic, W=32, m=5): {time.perf_counter() - t0:.1f} s "
              f"wall, {r.events} events, {r.exchanges} exchanges")


    if args.run_share:
        run_share(args.run_seconds)


if __name__ == "__main__":
    main()
