"""Where the wall time of a long (paper-horizon) run goes, and how each stage's cost grows
with simulated time.

Runs one scenario in-process with light timers around the run's stages (no cProfile: its
overhead would distort a 600-s run) and a sampling thread that reads the process's CPU time
twice a second. Prints, per window of simulated time (default 60 s):

- wall seconds, and how busy the cores were (user + system CPU time / wall / cores);
- the *exclusive* wall seconds of each stage (a stage's time minus the stages timed inside it):
  map gradient (``loss_and_grad``), map step (Adam and the proximal step), frames (ray
  extraction, keyframes), consensus (the rest of a round: copies, weights, duals), payloads
  (encoding) and receive (decoding), rendering (the simulated cameras), evaluation (mesh
  extraction, culling, metrics), consensus probe, and the rest (SimPy, channel, Python);
- the size of agent 0's ray database (keyframe rays).

Then every periodic evaluation's wall time (the speed issue's "evaluation at t = 570 s costs
no more than 1.3x the one at t = 30 s") and the totals.

    PYTHONPATH=. python benchmarks/bench_long_run.py [scenarios/house_3agents.yaml]
        [--set duration=600 ...] [--window 60]

Defaults: ``scenarios/house_3agents.yaml`` with ``duration=600``, ``recording.mode=off``,
``method=ramen`` (the speed issue's paper-horizon run).
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, Callable

DEFAULT_SET = ["duration=600", "recording.mode=off", "method=ramen"]
# The stage timers keep one stack on the thread that runs the event loop: the rounds run there,
# inline (the team engine's one-worker order, same results; benchmarks/bench_team_scale.py
# measures the engine's workers). An explicit RAMENSIM_TEAM_WORKERS is kept.
os.environ.setdefault("RAMENSIM_TEAM_WORKERS", "1")


class StageClock:
    """Exclusive wall time per (stage, window of simulated time); nested stages subtract."""

    def __init__(self, window_s: float) -> None:
        self.window_s = window_s
        self.sim: Any = None
        self.exclusive: dict[tuple[str, int], float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self.evaluations: list[tuple[float, float]] = []  # (simulated t, wall s)
        self._stack: list[float] = []  # child time accumulated by the open stages

    def now(self) -> float:
        return float(self.sim.env.now) if self.sim is not None else 0.0

    def window(self) -> int:
        return int(self.now() // self.window_s)

    def wrap(self, stage: str, fn: Callable) -> Callable:
        def timed(*args, **kwargs):
            w = self.window()
            self._stack.append(0.0)
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                elapsed = time.perf_counter() - t0
                child = self._stack.pop()
                self.exclusive[(stage, w)] += elapsed - child
                self.calls[stage] += 1
                if self._stack:
                    self._stack[-1] += elapsed
                if stage == "evaluation":
                    self.evaluations.append((self.now(), elapsed))

        timed.__wrapped__ = fn  # type: ignore[attr-defined]
        return timed


def _replace_everywhere(fn: Callable, new: Callable) -> int:
    """Point every loaded module's global that names ``fn`` at ``new`` (functions imported by
    name elsewhere); returns how many references were replaced."""
    n = 0
    for mod in list(sys.modules.values()):
        d = getattr(mod, "__dict__", None)
        if not d:
            continue
        for key, val in list(d.items()):
            if val is fn:
                setattr(mod, key, new)
                n += 1
    return n


def instrument(clock: StageClock) -> None:
    """Wrap the run's stages (class methods on their class, functions wherever imported)."""
    from ramensim import observe, scoring, sim as sim_mod
    from ramensim.agents import encoding
    from ramensim.agents.map.neural_map import NeuralMap
    from ramensim.agents.rounds.round import RoundWork
    from ramensim.agents.step import ConsensusStep
    from ramensim.world.world import World

    for cls, name, stage in ((NeuralMap, "loss_and_grad", "map gradient"),
                             (NeuralMap, "optimizer_step", "map step"),
                             (NeuralMap, "add_frame", "frames"),
                             (ConsensusStep, "begin_round", "consensus"),  # a round's inputs fixed
                             (RoundWork, "__call__", "consensus"),  # its computation (agents/rounds/round.py)
                             (ConsensusStep, "make_payload", "payloads"),
                             (ConsensusStep, "receive", "receive"),
                             (World, "render", "rendering"),
                             (scoring.Evaluator, "mesh_of", "eval: mesh"),
                             (scoring.Evaluator, "_culled_gt", "eval: gt cull"),
                             (scoring.Evaluator, "_cull", "eval: cull"),
                             (scoring.Evaluator, "team_coverage_pct", "eval: coverage"),
                             (scoring.Evaluator, "_seen", "eval: coverage")):
        setattr(cls, name, clock.wrap(stage, getattr(cls, name)))
    for mod, name, stage in ((observe, "evaluate_now", "evaluation"),
                             (observe, "probe_consensus", "consensus probe"),
                             (scoring, "mesh_metrics", "eval: metrics"),
                             (encoding, "encode", "payloads"),
                             (encoding, "decode", "receive")):
        fn = getattr(mod, name)
        _replace_everywhere(fn, clock.wrap(stage, fn))

    build = sim_mod.build_simulation

    def capture(*args, **kwargs):
        clock.sim = build(*args, **kwargs)
        return clock.sim

    _replace_everywhere(build, capture)


class CpuSampler(threading.Thread):
    """(wall, process CPU s, simulated t, agent 0's keyframe rays) twice a second."""

    def __init__(self, clock: StageClock) -> None:
        super().__init__(daemon=True)
        self.clock = clock
        self.samples: list[tuple[float, float, float, int]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.wait(0.5):
            t = os.times()
            sim = self.clock.sim
            rays = -1
            if sim is not None and getattr(sim, "maps", None):
                rays = int(getattr(getattr(sim.maps[0], "keyframes", None), "size", -1))
            self.samples.append((time.perf_counter(), t.user + t.system, self.clock.now(), rays))


def report(clock: StageClock, sampler: CpuSampler, wall_run: float, cpu_run: float) -> None:
    cores = os.cpu_count() or 1
    stages = ["map gradient", "map step", "frames", "consensus", "payloads", "receive", "rendering",
              "eval: mesh", "eval: gt cull", "eval: cull", "eval: metrics", "eval: coverage", "evaluation",
              "consensus probe"]
    windows = sorted({w for (_, w) in clock.exclusive})
    by_window: dict[int, list[tuple[float, float, float, int]]] = defaultdict(list)
    for s in sampler.samples:
        by_window[int(s[2] // clock.window_s)].append(s)
    head = f"{'sim window':>11s} {'wall':>6s} {'busy':>5s} " + " ".join(f"{s[:10]:>10s}" for s in stages) \
        + f" {'rest':>6s} {'kf rays':>8s}"
    print(head)
    prev = None
    for w in windows:
        ss = by_window.get(w, [])
        if ss and prev is not None:
            wall = ss[-1][0] - prev[0]
            busy = (ss[-1][1] - prev[1]) / wall / cores if wall > 0 else float("nan")
        else:
            wall, busy = float("nan"), float("nan")
        if ss:
            prev = ss[-1]
        ex = [clock.exclusive.get((s, w), 0.0) for s in stages]
        rest = wall - sum(ex)
        rays = ss[-1][3] if ss else -1
        lo, hi = w * clock.window_s, (w + 1) * clock.window_s
        print(f"{lo:5.0f}-{hi:<5.0f} {wall:6.1f} {100 * busy:4.0f}% " + " ".join(f"{e:10.1f}" for e in ex)
              + f" {rest:6.1f} {rays:8d}")
    tot = {s: sum(v for (st, _), v in clock.exclusive.items() if st == s) for s in stages}
    print(f"totals over {wall_run:.1f} s wall (process CPU {cpu_run:.1f} s = "
          f"{100 * cpu_run / wall_run / cores:.0f} % of {cores} cores):")
    for s in stages:
        print(f"  {s:16s} {tot[s]:8.1f} s  {100 * tot[s] / wall_run:5.1f} %  ({clock.calls[s]} calls)")
    rest = wall_run - sum(tot.values())
    print(f"  {'rest':16s} {rest:8.1f} s  {100 * rest / wall_run:5.1f} %  (SimPy, channel, startup, Python)")
    if clock.evaluations:
        print("periodic evaluations (simulated t: wall s): "
              + ", ".join(f"{t:.0f}: {s:.2f}" for t, s in clock.evaluations))
        first, last = clock.evaluations[0][1], clock.evaluations[-1][1]
        print(f"last / first evaluation: {last / first:.2f}x")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="scenarios/house_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=None,
                    help=f"scenario overrides (default: {' '.join(DEFAULT_SET)})")
    ap.add_argument("--window", type=float, default=60.0, help="simulated seconds per table row")
    args = ap.parse_args()
    overrides = DEFAULT_SET if args.overrides is None else args.overrides
    logging.basicConfig(level=logging.WARNING)
    load0 = os.getloadavg()[0]
    from ramensim.core.native import prefer_passive_openmp

    prefer_passive_openmp()  # as the CLI does, before torch is imported
    from ramensim.config import load_scenario
    from ramensim.lifecycle import run_scenario

    clock = StageClock(args.window)
    instrument(clock)
    sc = load_scenario(args.scenario, overrides)
    sampler = CpuSampler(clock)
    with tempfile.TemporaryDirectory() as tmp:
        cpu0, t0 = sum(os.times()[:2]), time.perf_counter()
        sampler.start()
        res = run_scenario(sc, Path(tmp) / "run", base_dir=Path(args.scenario).parent)
        wall, cpu = time.perf_counter() - t0, sum(os.times()[:2]) - cpu0
        sampler.stop.set()
    from benchmarks._machine import machine_info

    print(f"{args.scenario} {' '.join(overrides)}: status {res.status}, {res.sim_time_s:.0f} simulated s "
          f"in {wall:.1f} s wall ({res.sim_time_s / wall:.2f}x real time)")
    report(clock, sampler, wall, cpu)
    print(f"load average: {load0:.2f} at start, {os.getloadavg()[0]:.2f} at end")
    print(machine_info())


if __name__ == "__main__":
    main()
