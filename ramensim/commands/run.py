"""``ramensim run FILE``: run one scenario end to end and write its run folder.

Exit codes: 0 every robot mapped to the end; 3 the run reached its end but some robots diverged
or failed (the others were scored; metrics.json names which and why); 1 the run failed (an error
stopped it; what was mapped so far is evaluated and written); 2 bad input (nothing was run);
130 interrupted (Ctrl-C or a stop signal; what was mapped so far is written).
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

from ramensim.config import load_scenario
from ramensim.core.results import RunResult
from ramensim.core.errors import InputError
from ramensim.runfolder import prepare_out_dir

log = logging.getLogger(__name__)

RERUN_MODES = ("save", "spawn", "connect", "serve", "off")


def add_parser(sub) -> None:
    p = sub.add_parser("run", help="run one scenario", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", help="scenario YAML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a field by dotted key, e.g. --set channel.success_rate=0.5 (repeatable)")
    p.add_argument("--out", help="run folder (default: a new folder under output.dir, ./runs); must be new or "
                                 "empty unless --overwrite")
    p.add_argument("--overwrite", action="store_true",
                   help="allow --out to name a folder that holds a previous run: its run files are removed first")
    p.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="FILE_OR_MODULE",
                   help="load a plugin first: a .py file (relative to the working directory) or a module that "
                        "registers a method, radio model or scene (repeatable; docs/EXTENDING.md)")
    p.add_argument("--dry-run", action="store_true",
                   help="check the scenario and print what one robot and the run will cost in memory "
                        "(map, optimizer state, method and per-neighbour state, ray database); run nothing")
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
    scenario = load_scenario(path, overrides, plugins=args.plugins)  # bad input is reported before any folder is touched
    if args.dry_run:
        from ramensim.memory import describe

        print(describe(scenario))
        return 0
    if args.out:
        prepare_out_dir(Path(args.out), args.overwrite)  # in the CLI's words (--out, --overwrite)
    result = api_run(scenario, out=args.out, base_dir=path.parent, overwrite=args.overwrite,
                     progress=choose_mode(getattr(args, "quiet", False)))
    _print_summary(result, result.run_dir)
    return exit_code(result, scenario.duration)


EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_SOME_ROBOTS, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
"""``ramensim run``'s exit codes (the module docstring)."""


def exit_code(result: RunResult, duration: float) -> int:
    """The exit code of a finished run: robots' own faults (diverged, or failed under
    ``run.on_robot_error: isolate``) on a run that reached ``duration`` s are not the run's."""
    if result.status == "ok":
        return EXIT_OK
    if result.status == "interrupted":
        return EXIT_INTERRUPTED
    robots = any(a.diverged or a.failed_reason for a in result.per_agent.values())
    reached = result.sim_time_s >= duration - 1e-9
    return EXIT_SOME_ROBOTS if robots and reached else EXIT_FAILED


COLUMNS = (  # (long title, short title for narrow terminals, metric key)
    ("completion %", "compl.\n%", "completion_ratio_pct"),
    ("artifacts cm", "artif.\ncm", "artifacts_cm"),
    ("holes cm", "holes\ncm", "holes_cm"),
    ("own coverage¹ %", "own\ncov.¹ %", "own_coverage_pct"),
    ("unseen part compl.² %", "unseen\ncompl.² %", "completion_unseen_pct"),
)
"""The summary table's metric columns; the short titles fit an 80-column terminal."""


def _print_summary(result: RunResult, out: Path) -> None:
    """The run's summary on stdout: one row per map, footnotes for the coverage columns, team
    coverage, messages, status and the run folder. On a terminal narrower than 100 columns the
    column titles are abbreviated (and said in full below); piped, nothing is wrapped."""
    from rich.table import Table

    from ramensim.terminal import narrow, print_prose, stdout_console

    console = stdout_console()
    short = narrow(console)
    table = Table(title=f"{result.scenario}: {result.method}, {result.n_agents} agents, "
                        f"{result.sim_time_s:.0f} s simulated in {result.wall_time_s:.0f} s of wall time")
    table.add_column("map", no_wrap=True)
    for long, abbreviated, _ in COLUMNS:
        table.add_column(abbreviated if short else long, justify="right", no_wrap=short)
    table.add_column("rounds", justify="right", no_wrap=True)
    table.add_column("status", justify="right")
    for name, e in result.per_agent.items():
        def f(key: str) -> str:
            v = e.metric(key)
            return "nan" if v != v else f"{v:.2f}"
        status = (f"diverged ({e.diverged_reason})" if e.diverged else
                  f"failed ({e.failed_reason})" if e.failed_reason else (e.reason or "ok"))
        table.add_row(name, *(f(key) for _, _, key in COLUMNS), str(e.rounds), status)
    console.print(table)
    if short:
        print_prose(console, "compl. = completion ratio, artif. = artifacts, own cov. = own coverage")
    print_prose(console, "¹ of the surface the team saw, the share this map's own camera(s) saw; "
                         "² completion on the part only teammates saw")
    if result.team_coverage_pct is not None:
        print_prose(console, f"team coverage: {result.team_coverage_pct:.1f} % of the whole ground-truth surface "
                             f"seen by some robot (the denominator of the metrics above is that seen part)")
    messages = result.messages_text()
    if messages:
        print_prose(console, f"messages: {messages}; consensus error {result.consensus_error:.3g}")
    if result.status != "ok":  # interrupted, failed, diverged: say so, with the reason
        print_prose(console, f"status: {result.status}" + (f" ({result.error})" if result.error else ""))
    console.print(f"run folder: {out}", highlight=False)
