"""Recording overhead on a real run: the same scenario and seed with Rerun recording on
(save) and off, in one process. Prints both wall times, the overhead, the size of
run.rrd, and checks that recording did not change any result.

    PYTHONPATH=. python benchmarks/bench_recording_run.py [scenarios/office_3agents.yaml] [--set k=v ...]
"""
from __future__ import annotations

import argparse
import json
import logging
import tempfile
import time
from pathlib import Path

from benchmarks._machine import machine_info
from ramensim.config import load_scenario
from ramensim.lifecycle import run_scenario


def _run(path: str, overrides: list[str], mode: str, out: Path) -> tuple[float, dict]:
    sc = load_scenario(path, [*overrides, f"recording.mode={mode}"])
    t0 = time.perf_counter()
    metrics = run_scenario(sc, out, base_dir=Path(path).parent)
    return time.perf_counter() - t0, metrics


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="scenarios/office_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    with tempfile.TemporaryDirectory() as tmp:
        off_s, off = _run(args.scenario, args.overrides, "off", Path(tmp) / "off")
        on_s, on = _run(args.scenario, args.overrides, "save", Path(tmp) / "on")
        rrd = Path(tmp) / "on" / "run.rrd"
        size = rrd.stat().st_size
        strip = ("wall_time_s",)
        same = (json.dumps({k: v for k, v in off.items() if k not in strip}, sort_keys=True, default=str)
                == json.dumps({k: v for k, v in on.items() if k not in strip}, sort_keys=True, default=str))
    print(machine_info())
    print(f"scenario {args.scenario} {' '.join(args.overrides)}")
    print(f"recording off: {off_s:.1f} s wall; recording on (save): {on_s:.1f} s wall")
    print(f"overhead: {100 * (on_s - off_s) / off_s:+.1f} % (goal <= 10 %); run.rrd {size / 2**20:.1f} MiB")
    print(f"results identical with and without recording: {same}")


if __name__ == "__main__":
    main()
