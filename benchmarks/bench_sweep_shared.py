"""Points of one sweep in one process against one process per point (issue 55, item 6).

A local sweep runs each point in its own worker process with ``--threads 1`` (two workers on 2
cores). The alternative measured here advances the same points in *one* process, each on its
own thread (one torch/OpenMP thread each, as a sweep worker), so that whatever the points
could share (the interpreter, the scene, imported modules and compiled kernels, the caches)
is shared. Both arrangements keep every core busy; the question is which finishes the same
points sooner. The two are timed alternately (``--repeats`` pairs) on the same machine and
each pair's results are checked equal: every point's ``metrics.json`` (except ``wall_time_s``)
and ``messages.csv`` identical between the arrangements.

The points are the house's Table I setting at ``--duration`` simulated seconds (default 20),
one per success rate in ``--rates`` (default 1.0,0.5: two points, one per core), RAMEN,
recording off. Printed: each pair's wall seconds (processes, one process) and their ratio,
the median ratio, and the machine.

    PYTHONPATH=. python benchmarks/bench_sweep_shared.py [--duration 20] [--rates 1.0,0.5]
        [--repeats 2] [--set KEY=VALUE ...]

Where the points' *rounds* could batch together (lockstep batches, docs/DESIGN.md "The team
engine") this is only possible on the torch path (``map.native: false``), which on a CPU costs
about 28x the C kernels per map step (docs/MAP_PERFORMANCE.md); this benchmark measures the
arrangement a CPU sweep could use, the C kernels in one process.
"""
from __future__ import annotations

import argparse
import filecmp
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks._machine import machine_info  # noqa: E402
from ramensim.config import parse_override  # noqa: E402

SCENARIO = ROOT / "scenarios" / "house_3agents.yaml"
BASE_SET = {"recording.mode": "off", "method": "ramen", "world.trajectory.speed": 0.05,
            "output.save_meshes": False}

# One process running every point given on the command line, each on its own thread.
_CHILD = r"""
import json, sys, threading
from ramensim import api
jobs = json.loads(sys.argv[1])
errors = []
def one(job):
    try:
        api.run(job["scenario"], job["set"], out=job["out"])
    except BaseException as exc:  # reported by the parent
        errors.append(repr(exc))
threads = [threading.Thread(target=one, args=(j,)) for j in jobs]
for t in threads: t.start()
for t in threads: t.join()
if errors:
    print("\n".join(errors), file=sys.stderr)
    sys.exit(1)
"""


def _env() -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        env[var] = "1"  # as a sweep worker with --threads 1
    return env


def _jobs(rates: list[float], duration: float, extra: dict, out: Path) -> list[dict]:
    return [{"scenario": str(SCENARIO), "out": str(out / f"rate={r}"),
             "set": {**BASE_SET, "duration": duration, "channel.success_rate": r, **extra}} for r in rates]


def run_processes(jobs: list[dict]) -> float:
    """Every point in its own process at once; wall seconds until the last ends."""
    t0 = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-c", _CHILD, json.dumps([j])], env=_env(), cwd=ROOT)
             for j in jobs]
    codes = [p.wait() for p in procs]
    if any(codes):
        raise SystemExit(f"a point failed in its own process (exit codes {codes})")
    return time.perf_counter() - t0


def run_one_process(jobs: list[dict]) -> float:
    """Every point in one process, a thread each; wall seconds."""
    t0 = time.perf_counter()
    code = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(jobs)], env=_env(), cwd=ROOT).returncode
    if code:
        raise SystemExit(f"the points failed in one process (exit code {code})")
    return time.perf_counter() - t0


def _metrics(folder: Path) -> dict:
    m = json.loads((folder / "metrics.json").read_text())
    m.pop("wall_time_s", None)
    m.pop("build", None)  # the host and build: only the results are compared
    return m


def same_results(a: Path, b: Path, jobs: list[dict]) -> bool:
    for j in jobs:
        name = Path(j["out"]).name
        if _metrics(a / name) != _metrics(b / name):
            return False
        if not filecmp.cmp(a / name / "messages.csv", b / name / "messages.csv", shallow=False):
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=20.0, help="simulated seconds per point")
    ap.add_argument("--rates", default="1.0,0.5", help="success rates, one point each")
    ap.add_argument("--repeats", type=int, default=2, help="alternating pairs")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    extra = dict(parse_override(kv) for kv in args.set)  # as `ramensim run --set` reads them
    rates = [float(r) for r in args.rates.split(",")]
    print(machine_info())
    print(f"{len(rates)} points (house, RAMEN, {args.duration:g} s, success rates {rates}), "
          f"one thread each; {args.repeats} alternating pair(s); load {os.getloadavg()[0]:.1f}")
    ratios = []
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeats):
            a, b = Path(tmp) / f"proc{rep}", Path(tmp) / f"one{rep}"
            ja, jb = _jobs(rates, args.duration, extra, a), _jobs(rates, args.duration, extra, b)
            order = [("processes", run_processes, ja), ("one process", run_one_process, jb)]
            if rep % 2:
                order.reverse()
            walls = {name: fn(jobs) for name, fn, jobs in order}
            ratio = walls["one process"] / walls["processes"]
            ratios.append(ratio)
            same = same_results(a, b, ja)
            print(f"pair {rep + 1}: processes {walls['processes']:.1f} s, one process {walls['one process']:.1f} s "
                  f"-> {ratio:.3f}x; results identical: {same}; load {os.getloadavg()[0]:.1f}")
    print(f"median: one process takes {statistics.median(ratios):.3f}x the wall of one process per point")


if __name__ == "__main__":
    main()
