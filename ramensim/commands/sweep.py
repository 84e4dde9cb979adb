"""``ramensim sweep FILE``: run every point of a sweep file (resumable), then write its tables
and figures. Exit code 0 when every point has a result, 1 when some failed (they are recorded
in their folders and the other points still ran)."""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)


def add_parser(sub) -> None:
    p = sub.add_parser("sweep", help="run a parameter sweep (resumable), then tables and plots",
                       description=__doc__)
    p.add_argument("file", help="sweep YAML: base, set, axes (see docs)")
    p.add_argument("--out", default=None, help="output folder (default: runs/sweeps/NAME)")
    p.add_argument("--workers", type=int, default=None,
                   help="parallel runs (default: min(2, CPUs) locally; cluster CPUs / threads on Ray)")
    p.add_argument("--threads", type=int, default=None,
                   help="torch threads per run (default: CPUs // workers locally, 1 on Ray)")
    p.add_argument("--device", choices=("cpu", "cuda", "auto"), default=None,
                   help="torch device of every run's maps (map.device), e.g. cuda on a GPU machine; "
                        "like --threads it does not make the runs other points: they complete the "
                        "sweep's points (default: the scenario's map.device)")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="local process pool, or Ray (needs the 'ray' extra)")
    p.add_argument("--address", default=None, help="Ray cluster address (default: start a local Ray)")
    p.add_argument("--storage", default=None, metavar="PATH",
                   help="Ray only: a folder mounted at the same path on every node and here (NFS...); "
                        "finished runs travel through it instead of through Ray (default: through Ray)")
    p.add_argument("--dry-run", action="store_true",
                   help="expand and validate every point, list them and what is left to run, run nothing")
    p.add_argument("--no-retry-failed", action="store_true",
                   help="on resume, keep failed points as they are instead of running them again")
    p.add_argument("--no-report", action="store_true", help="do not write tables and plots at the end")
    p.add_argument("--only", action="append", default=[], metavar="AXIS=V[,V...]",
                   help="run only the points with these axis values (repeatable; e.g. --only seed=0 "
                        "--only method=ramen,dinno); the others stay pending and the report counts them")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key for every point, after the file's 'set' (repeatable; e.g. "
                        "--set duration=10); without --out the folder is runs/sweeps/NAME__KEY=VALUE")
    p.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="FILE_OR_MODULE",
                   help="load a plugin in this process and in every worker before its point: a .py file "
                        "(relative to the working directory) or a module (repeatable; docs/EXTENDING.md)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ramensim.terminal import stdout_console
    from rich.table import Table

    from ramensim.sweep.runner import pending_points
    from ramensim.sweep.spec import plan_sweep, select_points
    from ramensim.sweep.store import RUNS, claimed_points, default_out

    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers {args.workers}: expected a positive number of parallel runs.")
    if args.threads is not None and args.threads < 1:
        raise InputError(f"--threads {args.threads}: expected a positive number of threads per run.")
    if args.address and args.executor != "ray":
        raise InputError(f"--address {args.address}: only used with --executor ray.")
    if args.storage and args.executor != "ray":
        raise InputError(f"--storage {args.storage}: only used with --executor ray.")
    if args.device == "cuda" and args.executor == "local" and not args.dry_run:
        import torch

        if not torch.cuda.is_available():
            raise InputError(f"--device cuda: torch {torch.__version__} sees no CUDA device on this machine; "
                             "expected a CUDA build of torch and a GPU (or --device cpu / auto).")
    plan = plan_sweep(args.file, plugins=args.plugins, overrides=args.overrides)
    selected = select_points(plan, args.only)
    out = Path(args.out) if args.out else default_out(plan.folder_name)
    console = stdout_console()
    if args.dry_run:
        pending = set(pending_points(plan, out, not args.no_retry_failed)[0]) if out.exists() else \
            {p.name for p in plan.points}
        running = set(claimed_points(out / RUNS)) & pending  # by a sweep running in the folder now
        todo = (pending & selected) - running
        table = Table(title=f"sweep {plan.name}: {len(plan.points)} points, {len(todo)} to run -> {out}")
        table.add_column("point")
        table.add_column("state")
        for p in plan.points:
            table.add_row(p.name, "running (another sweep)" if p.name in running else "to run" if p.name in todo
                          else "not selected (--only)" if p.name in pending else "done")
        console.print(table)
        console.print(_time_estimate([p for p in plan.points if p.name in todo], args.workers), highlight=False)
        return 0
    from ramensim.api import sweep as api_sweep
    from ramensim.progress import choose_mode
    from ramensim.sweep.runner import SweepInterrupted

    try:
        with _TermAsInterrupt():
            outcome = api_sweep(args.file, out, workers=args.workers, executor=args.executor, address=args.address,
                                threads=args.threads, retry_failed=not args.no_retry_failed,
                                report=not args.no_report, progress=choose_mode(getattr(args, "quiet", False)),
                                storage=args.storage, only=args.only or None, device=args.device,
                                plugins=args.plugins, overrides=args.overrides)
    except SweepInterrupted as stop:
        o = stop.outcome
        console.print(f"sweep {plan.name} interrupted: {len(o.ok)} ok, {len(o.diverged)} diverged, "
                      f"{len(o.failed)} failed, {len(o.interrupted)} stopped while running "
                      f"({', '.join(o.interrupted) or 'none'}), {o.skipped} already done -> {out}; run the same "
                      f"command again to finish the sweep", highlight=False)
        return 130
    if not args.no_report:
        console.print(f"tables: {', '.join(str(t) for t in outcome.tables)}")
        console.print(f"figures: {len(outcome.figures)} files under {out / 'plots'}")
    left = (len(plan.points) - outcome.skipped - len(outcome.ok) - len(outcome.diverged) - len(outcome.failed)
            - len(outcome.elsewhere))
    console.print(f"sweep {plan.name}: {len(outcome.ok)} ok, {len(outcome.diverged)} diverged, "
                  f"{len(outcome.failed)} failed, {outcome.skipped} already done"
                  + (f", {len(outcome.elsewhere)} run by another sweep in this folder" if outcome.elsewhere else "")
                  + (f", {left} not selected by --only" if args.only else "") + f" -> {out}")
    for name, err in outcome.failed.items():
        console.print(f"[red]failed[/red] {name}: {err}", markup=True, highlight=False)
    return 1 if outcome.failed else 0


def _time_estimate(points: list, workers: int | None) -> str:
    """One line: the wall time the points to run will take on this machine, from its measured
    runs (:mod:`ramensim.costs`), and the points no measured run covers."""
    from ramensim.costs import estimate, ledger_path
    from ramensim.progress import fmt_s
    from ramensim.schema import Scenario
    from ramensim.sweep.runner import default_workers

    if not points:
        return "nothing to run"
    w = min(workers or default_workers(), len(points))
    fields = Scenario.model_fields
    rows = [(p.name, str(p.data.get("name", "")), str(p.data.get("method", fields["method"].default)),
             float(p.data.get("duration", fields["duration"].default))) for p in points]
    est = estimate(rows, w)
    if not est.measured:
        return (f"no estimate of the time: no run of these scenarios has been measured on this machine yet "
                f"({ledger_path()}); every finished run is, so run one point first")
    line = (f"estimated wall time: {fmt_s(est.wall_s)} for {est.measured} point(s) on {w} worker(s), from the "
            f"median pace of this machine's measured runs of the same scenario and method (up to {est.runs_used} "
            f"runs each; {ledger_path()})")
    if est.unknown:
        line += (f"; {len(est.unknown)} point(s) not counted, no run of their scenario measured here "
                 f"(e.g. {est.unknown[0]})")
    return line


class _TermAsInterrupt:
    """SIGTERM behaves as Ctrl-C while the sweep runs (finished points are already committed;
    the points in progress are recorded as interrupted and run again on resume)."""

    def __enter__(self) -> "_TermAsInterrupt":
        import signal
        import threading

        self._old = None
        if threading.current_thread() is threading.main_thread():
            def _raise(signum, frame):
                raise KeyboardInterrupt
            self._old = signal.signal(signal.SIGTERM, _raise)
        return self

    def __exit__(self, *exc: object) -> None:
        import signal

        if self._old is not None:
            signal.signal(signal.SIGTERM, self._old)
