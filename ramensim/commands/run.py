"""``ramensim run FILE``: run one scenario end to end and write its run folder."""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

from ramensim.config import load_scenario
from ramensim.core.results import RunResult
from ramensim.errors import InputError
from ramensim.runfolder import prepare_out_dir

log = logging.getLogger(__name__)

RERUN_MODES = ("save", "spawn", "connect", "serve", "off")


def add_parser(sub) -> None:
    p = sub.add_parser("run", help="run one scenario", description=__doc__)
    p.add_argument("file", help="scenario YAML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a field by dotted key, e.g. --set channel.success_rate=0.5 (repeatable)")
    p.add_argument("--out", help="run folder (default: a new folder under output.dir, ./runs); must be new or "
                                 "empty unless --overwrite")
    p.add_argument("--overwrite", action="store_true",
                   help="allow --out to name a folder that holds a previous run: its run files are removed first")
    p.add_argument("--rerun", nargs="+", metavar=("MODE", "URL"),
                   help="recording: save (default, run.rrd in the run folder), spawn (open a viewer), "
                        "connect URL, serve (gRPC on 127.0.0.1), off")
    p.set_defaults(func=run)


def rerun_overrides(values: list[str] | None) -> dict[str, object]:
    """Translate ``--rerun MODE [URL]`` into recording.* overrides."""
    if not values:
        return {}
    mode = values[0]
    if mode not in RERUN_MODES:
        raise InputError(f"--rerun {mode!r}: unknown mode; expected one of {', '.join(RERUN_MODES)}.")
    out: dict[str, object] = {"recording.mode": mode}
    if mode == "connect" and len(values) > 1:
        out["recording.url"] = values[1]
    elif len(values) > 1:
        raise InputError(f"--rerun {' '.join(values)}: only 'connect' takes a URL.")
    return out


def run(args: argparse.Namespace) -> int:
    """Check the command line, then run through the Python API (:func:`ramensim.api.run`),
    which assembles the scenario through the one door (:func:`ramensim.config.load_scenario`)."""
    from ramensim.api import run as api_run
    from ramensim.progress import choose_mode

    path = Path(args.file)
    overrides = list(args.overrides) + [f"{k}={v}" for k, v in rerun_overrides(args.rerun).items()]
    scenario = load_scenario(path, overrides)  # bad input is reported before any folder is touched
    if args.out:
        prepare_out_dir(Path(args.out), args.overwrite)  # in the CLI's words (--out, --overwrite)
    result = api_run(scenario, out=args.out, base_dir=path.parent, overwrite=args.overwrite,
                     progress=choose_mode(getattr(args, "quiet", False)))
    _print_summary(result, result.run_dir)
    return 0 if result.status in ("ok", "diverged") else 1


def _print_summary(result: RunResult, out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{result.scenario}: {result.method}, {result.n_agents} agents, "
                        f"{result.sim_time_s:.0f} s simulated in {result.wall_time_s:.0f} s")
    for col in ("map", "completion %", "artifacts cm", "holes cm", "own coverage¹ %", "unseen part compl.² %",
                "rounds", "status"):
        table.add_column(col, justify="right" if col != "map" else "left")
    for name, e in result.per_agent.items():
        def f(key: str) -> str:
            v = e.metric(key)
            return "nan" if v != v else f"{v:.2f}"
        status = (f"diverged ({e.diverged_reason})" if e.diverged else
                  f"failed ({e.failed_reason})" if e.failed_reason else (e.reason or "ok"))
        table.add_row(name, f("completion_ratio_pct"), f("artifacts_cm"), f("holes_cm"), f("own_coverage_pct"),
                      f("completion_unseen_pct"), str(e.rounds), status)
    import sys

    console = Console(width=None if sys.stdout.isatty() else 160)  # a log file gets whole column titles
    console.print(table)
    console.print("¹ of the surface the team saw, the share this map's own camera(s) saw; "
                  "² completion on the part only teammates saw", highlight=False)
    if result.team_coverage_pct is not None:
        console.print(f"team coverage: {result.team_coverage_pct:.1f} % of the whole ground-truth surface seen by "
                      f"some robot (the denominator of the metrics above is that seen part)", highlight=False)
    comm = result.communication
    if comm:
        flying = comm.get("in_flight") or 0
        console.print(f"messages: {comm.get('sent', 0)} sent, {comm.get('delivered', 0)} delivered "
                      f"({100 * (comm.get('delivered_fraction') or 0):.1f}%)"
                      + (f", {flying} more still in flight at the end" if flying else "")
                      + f"; consensus error {result.consensus_error:.3g}")
    if result.status != "ok":  # interrupted, failed, diverged: say so, with the reason
        console.print(f"status: {result.status}" + (f" ({result.error})" if result.error else ""), highlight=False)
    console.print(f"run folder: {out}")
