"""One scenario run by two installations of ramensim, alternately (A B A B ...), so that a change
is timed against the code before it on the same machine at the same load; also checks that the
two give the same results (messages.csv and metrics.json byte for byte, but the wall time and the
build record).

    PYTHONPATH=. python benchmarks/bench_ab.py --b /path/to/other/venv/bin/python \\
        [--scenario scenarios/office_3agents.yaml] [--pairs 2] [--set KEY=VALUE ...]

``--a`` defaults to this interpreter. An earlier commit as B, beside this checkout's venv::

    git worktree add /tmp/base COMMIT && python3 -m venv /tmp/basevenv
    echo "$PWD/.venv/lib/python3.11/site-packages" > /tmp/basevenv/lib/python3.11/site-packages/deps.pth
    (cd /tmp/base && /tmp/basevenv/bin/pip install --no-deps -e .)

Prints per run wall and CPU seconds and peak resident memory (the child's own rusage), the
medians, and the ratio A/B of each pair's wall time.
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


def run(python: str, scenario: Path, sets: list[str], out: Path) -> dict:
    """One run in ``out``: wall s, CPU s, peak bytes."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [python, "-m", "ramensim.cli", "-q", "run", str(scenario), "--out", str(out), "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.perf_counter()
    # from the run folder: `python -m` puts the working directory first on sys.path; without the
    # caller's PYTHONPATH, which would make B import this checkout's ramensim/*.py (its top package
    # comes first on that path) with its own other folders (bench_eval_periodic.py does the same)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.Popen(cmd, cwd=out, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {os.waitstatus_to_exitcode(status)})")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "peak": usage.ru_maxrss * 1024}


def same_results(a: Path, b: Path) -> str:
    """Whether two run folders hold the same results, in words."""
    diffs = []
    if (a / "messages.csv").exists() and (a / "messages.csv").read_bytes() != (b / "messages.csv").read_bytes():
        diffs.append("messages.csv")
    ma, mb = (json.loads((p / "metrics.json").read_text()) for p in (a, b))
    keys = sorted(k for k in set(ma) | set(mb) if k not in ("wall_time_s", "build") and ma.get(k) != mb.get(k))
    diffs += [f"metrics.json:{k}" for k in keys]
    return "identical results (messages.csv, metrics.json but wall time and build)" if not diffs else \
        "DIFFERENT: " + ", ".join(diffs)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--a", default=sys.executable, help="interpreter of A (default: this one)")
    p.add_argument("--b", required=True, help="interpreter of B (another installation of ramensim)")
    p.add_argument("--scenario", default=str(ROOT / "scenarios" / "office_3agents.yaml"))
    p.add_argument("--pairs", type=int, default=2)
    p.add_argument("--set", dest="sets", action="append", default=[])
    a = p.parse_args(argv)
    print(machine_info())
    print(f"scenario {a.scenario} {' '.join('--set ' + s for s in a.sets)}; A = {a.a}; B = {a.b}")
    rows: dict[str, list[dict]] = {"A": [], "B": []}
    with tempfile.TemporaryDirectory(prefix="ab_") as tmp:
        for i in range(a.pairs):
            for name, py in (("A", a.a), ("B", a.b)):
                r = run(py, Path(a.scenario), a.sets, Path(tmp) / name)
                rows[name].append(r)
                print(f"pair {i + 1} {name}: wall {r['wall']:.1f} s, CPU {r['cpu']:.1f} s, peak {r['peak'] / 2**20:.0f} MiB")
            print(f"pair {i + 1}: A/B wall {rows['A'][-1]['wall'] / rows['B'][-1]['wall']:.3f}; "
                  f"{same_results(Path(tmp) / 'A', Path(tmp) / 'B')}")
    for name in ("A", "B"):
        rs = rows[name]
        print(f"{name} median: wall {statistics.median(r['wall'] for r in rs):.1f} s, CPU "
              f"{statistics.median(r['cpu'] for r in rs):.1f} s, peak {statistics.median(r['peak'] for r in rs) / 2**20:.0f} MiB")
    ratios = [x["wall"] / y["wall"] for x, y in zip(rows["A"], rows["B"])]
    print(f"A/B wall per pair: {', '.join(f'{r:.3f}' for r in ratios)}; median {statistics.median(ratios):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
