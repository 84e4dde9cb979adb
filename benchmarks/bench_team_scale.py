"""How a run's cost grows with the team: wall time per robot-simulated-second, peak memory per
robot and cores busy, for teams of 3 to 100 robots on a ring, a grid and a complete graph.

Each size runs as its own process (``ramensim run``; its peak resident memory is the child's
``ru_maxrss``), one after the other, so the figures of one invocation are comparable: the table
gives each size's wall time per robot-second relative to 3 robots *in the same invocation*
(state goals as such ratios: machines differ several-fold in absolute speed).

    PYTHONPATH=. python benchmarks/bench_team_scale.py [--sizes 3,6,12,24] [--topologies ring,complete]
        [--duration 10] [--workers N] [--set KEY=VALUE ...]

Defaults: the house (``scenarios/house_3agents.yaml``), 10 simulated seconds, one tour cut into
one chunk per robot (``world.trajectory.split=chunks``), recording off, the final evaluation
only, RAMEN. ``--workers`` sets ``RAMENSIM_TEAM_WORKERS`` (the team engine's threads; default:
the run's own choice, torch's thread count). A complete graph whose memory estimate exceeds
the machine is refused by the run itself before it starts (printed as "refused").

Memory per robot is ``(peak - peak of 1 robot) / robots``: what each robot adds, not the
interpreter's and the scene's share. It grows with simulated time only through the keyframe
ray database (a share of each keyframe's pixels, docs/MAP_PERFORMANCE.md); ``--duration``
shows how much.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks._machine import machine_info  # noqa: E402

SCENARIO = ROOT / "scenarios" / "house_3agents.yaml"
BASE_SET = ["world.trajectory.split=chunks", "recording.mode=off", "method=ramen",
            "evaluation.every_s=null", "evaluation.consensus_every_s=null", "output.save_meshes=false"]


def run_one(n: int, topology: str, duration: float, extra: list[str], workers: int | None,
            out: Path, python: str = sys.executable) -> dict:
    """One run of ``n`` robots with ``python``'s ramensim: wall s, CPU s, peak RSS bytes, status
    (or why it was refused)."""
    cmd = [python, "-m", "ramensim.cli", "-q", "run", str(SCENARIO), "--out", str(out), "--overwrite",
           "--set", f"agents.count={n}", "--set", f"topology.kind={topology}", "--set", f"duration={duration}"]
    for s in BASE_SET + extra:
        cmd += ["--set", s]
    env = dict(os.environ)
    if workers is not None:
        env["RAMENSIM_TEAM_WORKERS"] = str(workers)
    out.mkdir(parents=True, exist_ok=True)
    with open(out.parent / f"{out.name}.stderr", "w+") as err:
        t0 = time.perf_counter()
        # from the run's folder, not the checkout: `python -m` puts the working directory first on
        # sys.path, and --vs must import its own interpreter's ramensim
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err, cwd=out)
        _, status, usage = os.wait4(proc.pid, 0)  # this child's own CPU time and peak memory
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        stderr = err.read()
    row = {"robots": n, "topology": topology, "wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime,
           "peak_bytes": usage.ru_maxrss * 1024, "status": "ok" if proc.returncode == 0 else "refused"}
    if proc.returncode != 0:
        row["why"] = " ".join(stderr.split())[:300]
        return row
    metrics = json.loads((out / "metrics.json").read_text())
    row["status"] = metrics["status"]
    row["run_wall_s"] = metrics["wall_time_s"]
    row["completion_pct"] = (metrics.get("summary", {}).get("completion_ratio_pct") or {}).get("mean")
    row["team_workers"] = (metrics.get("build") or {}).get("team_workers")
    return row


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", default="3,6,12,24", help="team sizes, comma-separated (default 3,6,12,24)")
    p.add_argument("--topologies", default="ring", help="ring, grid, complete, ... comma-separated")
    p.add_argument("--duration", type=float, default=10.0, help="simulated seconds per run (default 10)")
    p.add_argument("--workers", type=int, default=None, help="RAMENSIM_TEAM_WORKERS for every run")
    p.add_argument("--set", dest="sets", action="append", default=[], help="extra --set for every run")
    p.add_argument("--vs", metavar="PYTHON", default=None,
                   help="also run every size with this interpreter's ramensim (e.g. a venv holding an "
                        "earlier commit), alternately, and print the ratio of wall times per size")
    a = p.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",") if s]
    print(machine_info())
    print(f"house, {a.duration:g} simulated s, split=chunks, RAMEN, recording off; "
          f"team workers: {a.workers if a.workers is not None else 'the run default'}; extra: {a.sets}")
    with tempfile.TemporaryDirectory(prefix="team_scale_") as tmp:
        base = run_one(1, "complete", a.duration, a.sets, a.workers, Path(tmp) / "floor")
        floor = base["peak_bytes"]
        print(f"1 robot: {base['wall_s']:.1f} s wall, peak {floor / 2**30:.2f} GiB (the floor subtracted below)")
        for topo in a.topologies.split(","):
            rows, base_rows = [], []
            for n in sizes:
                rows.append(run_one(n, topo, a.duration, a.sets, a.workers, Path(tmp) / f"{topo}_{n}"))
                if a.vs:
                    base_rows.append(run_one(n, topo, a.duration, a.sets, None, Path(tmp) / f"vs_{topo}_{n}",
                                             python=a.vs))
            ref = next((r for r in rows if r["status"] == "ok"), None)
            print(f"\n{topo}:")
            print(f"{'robots':>6} {'wall s':>8} {'s/robot-s':>10} {'vs first':>9} {'peak GiB':>9} "
                  f"{'MB/robot':>9} {'cores busy':>10} {'workers':>7} {'completion %':>12}")
            for r in rows:
                if r["status"] == "refused":
                    print(f"{r['robots']:>6} refused: {r['why']}")
                    continue
                per = r["wall_s"] / (r["robots"] * a.duration)
                rel = per / (ref["wall_s"] / (ref["robots"] * a.duration))
                mb = (r["peak_bytes"] - floor) / r["robots"] / 2**20
                busy = r["cpu_s"] / r["wall_s"]
                comp = r.get("completion_pct")
                print(f"{r['robots']:>6} {r['wall_s']:>8.1f} {per:>10.3f} {rel:>9.2f} "
                      f"{r['peak_bytes'] / 2**30:>9.2f} {mb:>9.0f} {busy:>10.2f} "
                      f"{str(r.get('team_workers')):>7} {comp if comp is None else round(comp, 1)!s:>12}")
            if base_rows:
                print(f"  against {a.vs} (run alternately with the rows above):")
                for r, b in zip(rows, base_rows):
                    if "refused" in (r["status"], b["status"]):
                        print(f"{b['robots']:>6} {b['status']}: {b.get('why', '')}")
                        continue
                    bcomp = b.get("completion_pct")
                    print(f"{b['robots']:>6} {b['wall_s']:>8.1f} s wall, peak {b['peak_bytes'] / 2**30:.2f} GiB, "
                          f"cores busy {b['cpu_s'] / b['wall_s']:.2f}, completion {bcomp if bcomp is None else round(bcomp, 1)} %"
                          f" -> this code's wall {r['wall_s'] / b['wall_s']:.2f}x, "
                          f"memory per robot {(r['peak_bytes'] - floor) / max(1, b['peak_bytes'] - floor):.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
