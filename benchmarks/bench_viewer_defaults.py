"""What the viewer defaults cost inside one run: the scenario (default: the default scenario)
run in-process with the periodic evaluations (``evaluation.every_s``), the final evaluation,
the map-mesh and uncertainty snapshots for the recording and the recorder itself timed where
they happen (wall and process CPU seconds). Their shares are taken within the same run, so
they hold even on a loaded machine, where two whole runs' wall times can differ by 2x.

    PYTHONPATH=. python benchmarks/bench_viewer_defaults.py [scenarios/office_3agents.yaml]
        [--set k=v ...] [--out DIR]

Prints the machine line, the load average before and after, and one line per part:
calls, wall s, CPU s, share of the run and the overhead relative to the run without it
(share / (1 - share)).
"""
from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

from benchmarks._machine import machine_info

PARTS = (("_evaluate_now", "periodic evaluations"), ("_finish", "final evaluation and results"),
         ("_snapshot_meshes", "map-mesh snapshots (recording)"),
         ("_snapshot_uncertainty", "uncertainty snapshots (recording)"))


def _timed(name: str, fn: Callable[..., Any], stats: dict[str, list[tuple[float, float]]]) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            stats.setdefault(name, []).append((time.perf_counter() - t0, time.process_time() - c0))
    return wrapper


def _load() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "n/a"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="scenarios/office_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    ap.add_argument("--out", default=None, help="run folder (default: a temporary one)")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    import ramensim.lifecycle as sim
    from ramensim.config import load_scenario

    stats: dict[str, list[tuple[float, float]]] = {}
    for name, _ in PARTS:
        setattr(sim, name, _timed(name, getattr(sim, name), stats))
    recorders: list[Any] = []
    make = sim._make_recorder

    def keep(*a: Any, **k: Any) -> Any:
        r = make(*a, **k)
        recorders.append(r)
        return r

    sim._make_recorder = keep
    sc = load_scenario(args.scenario, args.overrides)
    load0 = _load()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out) if args.out else Path(tmp) / "run"
        t0, c0 = time.perf_counter(), time.process_time()
        sim.run_scenario(sc, out, base_dir=Path(args.scenario).parent)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(machine_info())
    print(f"scenario {args.scenario} {' '.join(args.overrides)} (evaluation.every_s={sc.evaluation.every_s}, "
          f"recording.mode={sc.recording.mode}); load average before {load0}, after {_load()}")
    print(f"whole run: {wall:.1f} s wall, {cpu:.1f} s CPU")
    rows = list(PARTS)
    if recorders and recorders[0] is not None:
        stats["recorder"] = [(recorders[0].overhead_s, float("nan"))]
        rows.append(("recorder", "recorder's own time (wall only)"))
    for name, label in rows:
        v = stats.get(name, [])
        w = sum(x[0] for x in v)
        c = sum(x[1] for x in v)
        line = (f"{label}: {len(v)} calls, {w:.1f} s wall ({100 * w / wall:.1f} % of the run, "
                f"+{100 * w / max(wall - w, 1e-9):.1f} % over the run without it)")
        if name != "recorder":
            line += f", {c:.1f} s CPU ({100 * c / cpu:.1f} %, +{100 * c / max(cpu - c, 1e-9):.1f} %)"
        print(line)


if __name__ == "__main__":
    main()
