"""What the periodic evaluations add to a run's wall time (issue 71), for two installations of
ramensim side by side: each runs the scenario with its periodic evaluations (``evaluation.every_s``
as the scenario sets it, 30 s by default) and with the final evaluation only
(``evaluation.every_s=null``), the four runs alternated within each round (A B B A order on even
rounds, B A A B on odd ones) so that both see the same load. Checks that A and B give the same
results (messages.csv, metrics.json but its wall time and build record, the meshes, byte for byte)
and that the final metrics do not depend on the periodic evaluations.

    PYTHONPATH=. python benchmarks/bench_eval_periodic.py --b /path/to/base/venv/bin/python \\
        [--a /path/to/venv/bin/python] [--scenario scenarios/house_3agents.yaml] [--rounds 2] \\
        [--set duration=120 ...]

``--a`` defaults to this interpreter; how to make an earlier commit's installation as B:
benchmarks/bench_ab.py. Runs are made with recording off and ``RAMENSIM_EVAL_STAGES=1`` (an
installation that records the evaluations' stages prints them; one that does not ignores it).
Prints each run's wall and CPU seconds, the medians and the periodic evaluations' share:
median(periodic) / median(final only) - 1, of the wall time (the goal's measure, on an idle host)
and of the CPU time (which still compares installations when other jobs share the cores).
"""
from __future__ import annotations

import argparse
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
from benchmarks.bench_ab import same_results  # noqa: E402

MODES = {"periodic": [], "final only": ["evaluation.every_s=null"]}


def run(python: str, scenario: Path, sets: list[str], out: Path) -> dict:
    """One run in ``out`` (as benchmarks/bench_ab.py's, its output kept in ``out``.log): wall s,
    CPU s, peak bytes; a failed run stops the benchmark with the end of its output."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [python, "-m", "ramensim.cli", "-q", "run", str(scenario), "--out", str(out), "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    log = out.with_suffix(".log")
    # each installation runs its own code: without this script's PYTHONPATH (this checkout), which
    # would put this checkout's ramensim/ before the other installation's (mixing the two)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    t0 = time.perf_counter()
    with open(log, "wb") as fh:  # from the run folder: `python -m` puts the working directory first on sys.path
        proc = subprocess.Popen(cmd, cwd=out, env=env, stdout=fh, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        tail = log.read_text(errors="replace")[-3000:]
        raise SystemExit(f"{' '.join(cmd)} failed (exit {os.waitstatus_to_exitcode(status)}):\n{tail}")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "peak": usage.ru_maxrss * 1024}


def same_meshes(a: Path, b: Path) -> str:
    """Whether two run folders hold the same mesh files, byte for byte, in words."""
    names = sorted(p.name for p in a.glob("mesh_*.ply"))
    diff = [n for n in names if not (b / n).is_file() or (a / n).read_bytes() != (b / n).read_bytes()]
    return f"{len(names)} meshes identical" if not diff else "meshes DIFFERENT: " + ", ".join(diff)


def same_final(a: Path, b: Path) -> str:
    """Whether two runs' final per-map results (metrics.json's per_agent) agree, in words."""
    pa, pb = (json.loads((p / "metrics.json").read_text())["per_agent"] for p in (a, b))
    return "final per-map metrics identical" if pa == pb else "final per-map metrics DIFFERENT"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--a", default=sys.executable, help="python of installation A (default: this one)")
    ap.add_argument("--b", required=True, help="python of installation B (e.g. the commit before)")
    ap.add_argument("--scenario", default="scenarios/house_3agents.yaml")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--keep", default=None, help="keep the run folders here (default: a temporary folder)")
    args = ap.parse_args()
    scenario = Path(args.scenario).resolve()
    sets = ["recording.mode=off", *args.overrides]
    os.environ["RAMENSIM_EVAL_STAGES"] = "1"
    print(f"load average before start: {os.getloadavg()[0]:.1f} (other processes share the cores)")
    print(f"{scenario.name} {' '.join(sets)}; A = {args.a}; B = {args.b}")
    times: dict[tuple[str, str], list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        for r in range(args.rounds):
            order = [("A", "periodic"), ("B", "periodic"), ("B", "final only"), ("A", "final only")]
            if r % 2:
                order = [(("B" if w == "A" else "A"), m) for w, m in order]
            for who, mode in order:
                out = base / f"{who}_{mode.replace(' ', '_')}_{r}"
                res = run(args.a if who == "A" else args.b, scenario, sets + MODES[mode], out)
                times.setdefault((who, mode), []).append(res)
                print(f"round {r + 1} {who} {mode:10s}: wall {res['wall']:.1f} s, CPU {res['cpu']:.1f} s, "
                      f"peak {res['peak'] / 2**30:.2f} GiB", flush=True)
            for mode in MODES:
                a, b = (base / f"{w}_{mode.replace(' ', '_')}_{r}" for w in ("A", "B"))
                print(f"round {r + 1} {mode}: A vs B {same_results(a, b)}; {same_meshes(a, b)}")
            for who in ("A", "B"):
                p, f = (base / f"{who}_{m.replace(' ', '_')}_{r}" for m in MODES)
                print(f"round {r + 1} {who}: periodic vs final only: {same_final(p, f)}")
        for who in ("A", "B"):
            runs = base / f"{who}_periodic_{args.rounds - 1}" / "metrics.json"
            records = (json.loads(runs.read_text()).get("build") or {}).get("eval_stage_s")
            if records:
                from benchmarks.bench_eval_stages import stage_table

                print(f"{who}, last round, periodic: the evaluations' stages\n{stage_table(records)}")
    # wall time is the goal's measure on an idle host; CPU time (each run's own process tree) still
    # compares the installations when other jobs share the cores
    for measure in ("wall", "cpu"):
        print(f"| installation | periodic: {measure} s (median) | final only: {measure} s (median) | periodic adds |")
        print("|---|---:|---:|---:|")
        for who in ("A", "B"):
            p = [x[measure] for x in times[(who, "periodic")]]
            f = [x[measure] for x in times[(who, "final only")]]
            mp, mf = statistics.median(p), statistics.median(f)
            print(f"| {who} | {', '.join(f'{x:.1f}' for x in p)} ({mp:.1f}) | {', '.join(f'{x:.1f}' for x in f)} "
                  f"({mf:.1f}) | {100 * (mp / mf - 1):+.1f} % |")
    print(machine_info())


if __name__ == "__main__":
    main()
