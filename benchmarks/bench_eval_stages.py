"""Where each evaluation of a run goes (issue 71): the wall-clock seconds of every stage of every
evaluation, periodic and final (SDF grid, marching cubes, colours, the mesh's PLY, culling the
map's mesh, culling the ground truth, the metric samples, the nearest-neighbour distances, which
robots saw each sample, the own / unseen / far parts), as ``ramensim.scoring.Evaluator`` records
them (``RAMENSIM_EVAL_STAGES=1`` puts them in metrics.json's ``build.eval_stage_s``).

Run from the repository root (one run, recording off, then the table):

    PYTHONPATH=. python benchmarks/bench_eval_stages.py [--scenario scenarios/house_3agents.yaml]
        [--set duration=120 ...] [--out runs/bench_eval_stages]
    PYTHONPATH=. python benchmarks/bench_eval_stages.py --from RUN_FOLDER   # a run made with the variable set

A stage's figure is summed over the maps of the evaluation; the meshes are extracted on the team
engine's workers, several at a time, so the stages of an evaluation can add up to more than its
wall time. Wall-clock figures: they vary with the machine and its load, and no test checks them.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks._machine import machine_info  # noqa: E402


def stage_table(records: list[dict]) -> str:
    """The records of :meth:`ramensim.scoring.Evaluator.record_evaluation` as a Markdown table:
    one column per evaluation (simulated s; ``final`` for the last), the total over them and
    each stage's share of that total (s, %)."""
    from ramensim.scoring import STAGES

    stages = [s for s in STAGES if any(s in r["stage_s"] for r in records)]
    heads = [f"t={r['t']:g} s" + (" final" if r["final"] else "") for r in records]
    total_all = sum(sum(r["stage_s"].values()) for r in records)
    lines = ["| stage (s) | " + " | ".join(heads) + " | all | share |",
             "|---|" + "---:|" * (len(records) + 2)]
    for s in stages:
        vals = [r["stage_s"].get(s, 0.0) for r in records]
        share = 100.0 * sum(vals) / total_all if total_all > 0 else 0.0
        lines.append(f"| {s} | " + " | ".join(f"{v:.2f}" for v in vals) + f" | {sum(vals):.2f} | {share:.0f} % |")
    sums = [sum(r["stage_s"].values()) for r in records]
    lines.append("| sum of stages | " + " | ".join(f"{v:.2f}" for v in sums) + f" | {sum(sums):.2f} | |")
    walls = [r["wall_s"] for r in records]
    lines.append("| evaluation wall | " + " | ".join(f"{v:.2f}" for v in walls) + f" | {sum(walls):.2f} | |")
    lines.append("| maps | " + " | ".join(str(r["maps"]) for r in records) + " | | |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="scenarios/office_3agents.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", default=None, help="run folder (default: a temporary one)")
    ap.add_argument("--from", dest="from_dir", default=None,
                    help="print the records of an existing run folder instead of running")
    args = ap.parse_args()
    print(f"load average before start: {os.getloadavg()[0]:.1f} (other processes share the cores)")
    if args.from_dir:
        metrics = json.loads((Path(args.from_dir) / "metrics.json").read_text())
    else:
        import ramensim
        from ramensim.observe import STAGES_ENV

        os.environ[STAGES_ENV] = "1"
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(args.out) if args.out else Path(tmp) / "run"
            result = ramensim.run(args.scenario, ["recording.mode=off", *args.overrides], out=out, overwrite=True)
            metrics = json.loads((out / "metrics.json").read_text())
        print(f"{args.scenario} {' '.join(args.overrides)}: status {result.status}, "
              f"{result.sim_time_s:g} simulated s in {result.wall_time_s:.1f} s of wall time")
    records = (metrics.get("build") or {}).get("eval_stage_s")
    if not records:
        raise SystemExit("no evaluation records in metrics.json: the run was made without RAMENSIM_EVAL_STAGES=1")
    print(stage_table(records))
    print(machine_info())


if __name__ == "__main__":
    main()
