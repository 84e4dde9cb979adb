"""Where the wall time of one whole run goes: the scenario (default: the default scenario)
run in-process under cProfile, its time split into map, render/world, consensus,
evaluation, recording, kernel/channel and the rest (Python overhead, startup imports).

Attribution: a function defined in one of the project's areas counts its own time there; a
builtin or library function (torch ops, numpy, Embree) counts toward the area of the
caller that spent the most time in it, followed up the call graph until a project file is
reached. Also prints whether ``rerun`` was imported (it must not be with
``recording.mode: off``) and the map backends chosen on this machine.

    PYTHONPATH=. python benchmarks/bench_profile_run.py [scenarios/office_3agents.yaml]
        [--set k=v ...] [--top 25] [--no-profile]
"""
from __future__ import annotations

import argparse
import cProfile
import logging
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

REPO = str(Path(__file__).resolve().parents[1])
"""The repository root: the layers' folders (core/, world/, ...) are matched below it."""

AREAS = (  # (area, path fragments), first match wins
    ("map", ("/agents/map/",)),
    ("consensus", ("/agents/consensus/", "/agents/learner", "/agents/agent", "/agents/")),
    ("render/world", (f"{REPO}/world/", "embree", "trimesh")),
    ("evaluation", ("/evaluation/", "/ramensim/scoring")),
    ("recording", ("/ramensim/recording/", "/rerun", "rerun_sdk")),
    ("kernel/channel", (f"{REPO}/core/", "/channels/", "simpy")),
    ("startup/config", ("/ramensim/config", "/ramensim/schema", "pydantic", "<frozen importlib")),
)


def _area(filename: str) -> str | None:
    for area, frags in AREAS:
        if any(f in filename for f in frags):
            return area
    if "/work/main/" in filename or "/ramensim/" in filename:
        return "other project code"
    return None


def attribute(stats: pstats.Stats) -> dict[str, float]:
    """Seconds of own time per area (see the module docstring)."""
    raw = stats.stats  # type: ignore[attr-defined]
    memo: dict[tuple, str] = {}

    def owner(func: tuple, depth: int = 0) -> str:
        if func in memo:
            return memo[func]
        a = _area(func[0])
        if a is None:
            callers = raw[func][4] if func in raw else {}
            if callers and depth < 40:
                best = max(callers.items(), key=lambda kv: kv[1][3])[0]
                memo[func] = "python overhead (unattributed)"  # cycle guard
                a = owner(best, depth + 1)
            else:
                a = "python overhead (unattributed)"
        memo[func] = a
        return a

    out: dict[str, float] = {}
    for func, (_, _, tt, _, _) in raw.items():
        a = owner(func)
        out[a] = out.get(a, 0.0) + tt
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="scenarios/office_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    ap.add_argument("--top", type=int, default=25, help="functions listed by cumulative time")
    ap.add_argument("--no-profile", action="store_true", help="wall time only (no cProfile)")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    load0 = os.getloadavg()[0]
    t_start = time.perf_counter()
    prof = None if args.no_profile else cProfile.Profile()
    if prof:
        prof.enable()
    from ramensim.config import load_scenario
    from ramensim.lifecycle import run_scenario

    sc = load_scenario(args.scenario, args.overrides)
    with tempfile.TemporaryDirectory() as tmp:
        t_run = time.perf_counter()
        res = run_scenario(sc, Path(tmp) / "run", base_dir=Path(args.scenario).parent)
        t_end = time.perf_counter()
    if prof:
        prof.disable()
    from benchmarks._machine import machine_info
    from ramensim.agents.map import backend

    wall = t_end - t_start
    print(f"{args.scenario} {' '.join(args.overrides)}: status {res.status}, "
          f"{res.sim_time_s:.0f} simulated s; wall {wall:.1f} s in all (imports + config "
          f"{t_run - t_start:.1f} s, run_scenario {t_end - t_run:.1f} s; its own wall_time_s "
          f"{res.wall_time_s:.1f} s){' under cProfile' if prof else ''}")
    print(f"recording.mode = {sc.recording.mode}; rerun imported: {'rerun' in sys.modules}")
    for ch in backend._memo.values():
        print(f"map backend {ch.describe()}")
    if prof:
        st = pstats.Stats(prof)
        areas = attribute(st)
        total = sum(areas.values())
        print(f"profiled time {total:.1f} s, by area (own time; library calls to their caller's area):")
        for a, s in sorted(areas.items(), key=lambda kv: -kv[1]):
            print(f"  {a:32s} {s:7.1f} s  {100 * s / total:5.1f} %")
        if args.top:
            st.sort_stats("cumulative").print_stats(args.top)
    print(f"load average: {load0:.2f} at start, {os.getloadavg()[0]:.2f} at end")
    print(machine_info())


if __name__ == "__main__":
    main()
