"""A trial's camera frames rendered vs read from the frame cache (world/frame_cache.py).

Builds a scenario's world as a run does (``build_world`` with the run's seed), then asks for
every robot's frames in capture order three times: with the cache off (rendering: Embree ray
casting, colours, the sensor model), with an empty cache folder (rendering and writing each
frame: the first run of a trial) and with that folder full (reading and verifying each frame:
every later run of the trial). Prints the time per frame and for the whole trial, the cache's
size for the trial, and checks that the three passes gave the same bytes.

    PYTHONPATH=. python benchmarks/bench_frames.py [scenarios/house_3agents.yaml]
        [--set duration=60 ...]

Defaults: ``scenarios/house_3agents.yaml`` with ``duration=60`` (3 robots, 160 x 120 at 5 fps:
900 frames). The cache folder is a temporary one, removed at the end.
"""
from __future__ import annotations

import argparse
import hashlib
import logging
import os
import tempfile
import time
from pathlib import Path

import numpy as np

DEFAULT_SET = ["duration=60", "recording.mode=off"]


def one_pass(sc, base_dir: Path, cache: str) -> tuple[float, float, list[float], bytes]:
    """(world build s, frames s, per-frame s, digest of every frame's bytes) with
    ``RAMENSIM_FRAME_CACHE=cache``."""
    from ramensim.core.seeding import Seeds
    from ramensim.world import build_world

    os.environ["RAMENSIM_FRAME_CACHE"] = cache
    t0 = time.perf_counter()
    world = build_world(sc.world, sc.agents.count, sc.duration, Seeds(sc.seed).numpy, base_dir=base_dir)
    build = time.perf_counter() - t0
    order = sorted((t, a, i) for a in range(world.n_agents) for i, (t, _) in enumerate(world.frames_for(a)))
    digest = hashlib.sha256()
    per: list[float] = []
    t1 = time.perf_counter()
    for _, a, i in order:
        t = time.perf_counter()
        f = world.render(a, i)
        per.append(time.perf_counter() - t)
        digest.update(f.rgb.tobytes())
        digest.update(f.depth.tobytes())
    total = time.perf_counter() - t1
    world.close()
    return build, total, per, digest.digest()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="scenarios/house_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=None,
                    help=f"scenario overrides (default: {' '.join(DEFAULT_SET)})")
    args = ap.parse_args()
    overrides = DEFAULT_SET if args.overrides is None else args.overrides
    logging.basicConfig(level=logging.WARNING)
    load0 = os.getloadavg()[0]
    from ramensim.config import load_scenario
    from ramensim.world.frame_cache import frame_file_bytes

    sc = load_scenario(args.scenario, overrides)
    base = Path(args.scenario).parent
    cam = sc.world.camera
    with tempfile.TemporaryDirectory(prefix="bench-frames-") as tmp:
        rows = [("cache off (render)", *one_pass(sc, base, "off")),
                ("cold cache (render + write)", *one_pass(sc, base, tmp)),
                ("warm cache (read + verify)", *one_pass(sc, base, tmp))]
        size = sum(p.stat().st_size for p in Path(tmp).rglob("*.frame"))
        files = len(list(Path(tmp).rglob("*.frame")))
    n = len(rows[0][3])
    print(f"{args.scenario} {' '.join(overrides)}: {sc.agents.count} robots, {cam.width}x{cam.height} at "
          f"{cam.fps:g} fps, {n} frames")
    print(f"{'pass':30s} {'build s':>8s} {'frames s':>9s} {'ms/frame':>9s} {'median':>7s}")
    for name, build, total, per, _ in rows:
        print(f"{name:30s} {build:8.2f} {total:9.2f} {1e3 * total / n:9.2f} {1e3 * np.median(per):7.2f}")
    off, warm = rows[0][2], rows[2][2]
    print(f"warm cache / cache off: {warm / off:.3f}x of the frames' time ({off - warm:.2f} s saved per run)")
    print(f"cache for this trial: {files} files, {size / 1e6:.1f} MB ({frame_file_bytes(cam.width, cam.height):,} "
          f"bytes a frame)")
    same = len({r[4] for r in rows}) == 1
    print(f"frames identical in the three passes: {'yes' if same else 'NO'}")
    print(f"load average: {load0:.2f} at start, {os.getloadavg()[0]:.2f} at end")
    from benchmarks._machine import machine_info

    print(machine_info())


if __name__ == "__main__":
    main()
