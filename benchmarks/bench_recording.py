"""Cost of streaming a run to Rerun: wall time the recorder spends per event type and per
simulated second, and the size of the .rrd, on a synthetic run shaped like a real one
(3 agents, 640x480 RGB-D at 10 fps, 5 mapping rounds/s, messages to every neighbour
after each round, map meshes every 10 s).

    PYTHONPATH=. python benchmarks/bench_recording.py [--duration 60] [--agents 3]

Compare "recorder wall s per simulated s" with the simulation's own wall time per
simulated second: the goal is a recorder overhead of at most 10 % of a run.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from benchmarks._machine import machine_info
from ramensim.recording import RecordingConfig, make_recorder
from ramensim.recording.synthetic import synthetic_events, synthetic_scene


def main() -> None:
    ap = argparse.ArgumentParser(description="benchmark the Rerun recorder")
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    ap.add_argument("--agents", type=int, default=3)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--width", type=int, default=640)
    args = ap.parse_args()

    scene = synthetic_scene(subdivisions=60)   # ~45k triangles per full map mesh
    t0 = time.perf_counter()
    events = synthetic_events(args.agents, args.duration, rng=np.random.default_rng(0), fps=10.0, round_hz=5.0,
                              image_hw=(args.height, args.width), mesh_period_s=10.0, scene=scene)
    gen_s = time.perf_counter() - t0
    print(f"synthetic run: {args.agents} agents, {args.duration:.0f} simulated s, {len(events)} events, "
          f"{len(scene.faces)} scene triangles, {args.width}x{args.height} frames (generated in {gen_s:.1f} s)")

    for label, cfg in [("default (save, 1 image/s, stride 4, JPEG 85)", RecordingConfig()),
                       ("raw images (jpeg_quality=0)", RecordingConfig(jpeg_quality=0)),
                       ("no images", RecordingConfig(log_rgb=False, log_depth=False))]:
        with tempfile.TemporaryDirectory() as tmp:
            per_type: dict[str, float] = defaultdict(float)
            count: dict[str, int] = defaultdict(int)
            start = time.perf_counter()
            rec = make_recorder(cfg, Path(tmp) / "bench_run", args.agents, scene.vertices, scene.faces,
                                scene.colors, scene.bounds, seed=0)
            assert rec is not None
            for e in events:
                a = time.perf_counter()
                rec(e)
                per_type[type(e).__name__] += time.perf_counter() - a
                count[type(e).__name__] += 1
            a = time.perf_counter()
            rec.close()
            close_s = time.perf_counter() - a
            total = time.perf_counter() - start
            size = (Path(tmp) / "bench_run" / "run.rrd").stat().st_size
        print(f"\n[{label}]")
        print(f"  recorder wall total      {total:8.2f} s  ({total / args.duration * 1e3:.1f} ms per simulated s; "
              f"close {close_s * 1e3:.0f} ms)")
        print(f"  run.rrd size             {size / 2**20:8.1f} MiB ({size / args.duration / 2**10:.0f} KiB per "
              f"simulated s)")
        for k in sorted(per_type, key=per_type.get, reverse=True):
            print(f"  {k:22s} {per_type[k] * 1e3:9.1f} ms  n={count[k]:6d}  {per_type[k] / count[k] * 1e3:7.3f} ms/event")
    print()
    print(machine_info())


if __name__ == "__main__":
    main()
