"""``ramensim archive``: keep a sweep's results in the repository without its meshes, put them back
on a fresh machine, and count another sweep's finished runs as points of this one
(``ramensim.sweep.archive``, ``ramensim.sweep.adopt``; docs/RESULTS.md, "The paper's horizon").

    ramensim archive runs/sweeps/paper_table1 docs/results/paper/paper_table1 [--plan FILE]
    ramensim archive --restore [ARCHIVES [SWEEPS]]      # default: docs/results -> runs/sweeps
    ramensim archive --adopt RUN [RUN ...] --plan FILE --into SWEEP_FOLDER

SWEEP DEST copies, for every finished point of the sweep folder SWEEP, its status.json,
metrics.json and scenario.yaml into DEST/runs/<point>/, and the sweep's report (summary.*,
runs.csv, runs_timeline.csv, time_to_consensus.*, report.html, plots/*.png) into DEST; when DEST's
runs.csv then does not list exactly the finished runs DEST holds (the sweep ran with --no-report, or
its folder held only some of the archive's runs), the report is redrawn from DEST. --plan FILE
keeps FILE's plan as the archive's sweep.json instead of the sweep folder's: when the protocol runs
in batches (subset files with the same name, base, settings and axis order), the archive's report
then counts every run of the whole protocol, done and missing; each archived point must be a point
of FILE with the same resolved scenario (fingerprint), else the plan is not written.

--restore copies every finished run of each archive ARCHIVES/<group>/<archive>/ (its sweep.json
names the sweep) that SWEEPS/<name>/runs/ does not hold yet into it, so that 'ramensim sweep' on a
fresh machine counts it done and runs the rest; a run already there is never touched (safe to
repeat, and to run from two queues at once).

--adopt copies each finished RUN of another sweep that ran exactly the scenario of one point of
FILE (both validated with every default filled in) into SWEEP_FOLDER/runs/<point>/, its status
rewritten to that point with an 'adopted_from' entry; a point already done is left alone, and
nothing is written when one RUN equals no point.
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Sequence

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

ARCHIVES, SWEEPS = Path("docs/results"), Path("runs/sweeps")
"""--restore's default folders: the archive groups, and where 'ramensim sweep' keeps its folders."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The command's options (shared by ``ramensim archive`` and :func:`main`)."""
    p.add_argument("folders", nargs="*", type=Path, metavar="FOLDER",
                   help="SWEEP DEST (keep); [ARCHIVES [SWEEPS]] with --restore; RUN... with --adopt")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--restore", action="store_true",
                      help="put the archived runs back into the sweep folders (default: docs/results -> runs/sweeps)")
    mode.add_argument("--adopt", action="store_true",
                      help="count the finished RUNs of another sweep as points of --plan's sweep (needs --into)")
    p.add_argument("--plan", type=Path, metavar="FILE",
                   help="the whole protocol's sweep file, kept as the archive's plan; with --adopt, the sweep "
                        "file whose points the runs may be")
    p.add_argument("--into", type=Path, metavar="SWEEP_FOLDER", help="with --adopt: that sweep's folder (its --out)")


def add_parser(sub) -> None:
    p = sub.add_parser("archive", help="keep a sweep's results without meshes (docs/results/), restore them, "
                                       "adopt another sweep's runs",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Keep, restore or adopt as the options say; :class:`InputError` for folders or options that do
    not fit the mode, a sweep folder without runs/, an archive group that is not a folder, or runs
    that are not the plan's."""
    if args.restore:
        return _restore(args)
    if args.adopt:
        return _adopt(args)
    if len(args.folders) != 2 or args.into is not None:
        raise InputError(f"archive: expected SWEEP DEST (two folders, no --into), got "
                         f"{' '.join(map(str, args.folders)) or 'no folder'}"
                         f"{' and --into' if args.into is not None else ''}; e.g. 'ramensim archive "
                         f"runs/sweeps/paper_table1 docs/results/paper/paper_table1', or --restore / --adopt.")
    from ramensim.sweep import store
    from ramensim.sweep.archive import archive, keep_plan, redraw_report, report_is_current

    sweep, dest = args.folders
    n = archive(sweep, dest)
    log.info("archived %d finished point(s) of %s into %s", n, sweep, dest)
    if args.plan is not None:
        log.info("kept the plan of %s (%d points) as %s", args.plan, keep_plan(args.plan, dest), dest / store.PLAN)
    if not report_is_current(dest):
        # the sweep's own report covers fewer runs than the archive now holds (--no-report, or a
        # folder with only a batch): the archive's tables would be stale, so redraw them from it
        log.info("%s: its runs.csv does not list exactly the finished runs it holds; redrawing its report", dest)
        redraw_report(dest)
    return 0


def _restore(args: argparse.Namespace) -> int:
    """``--restore [ARCHIVES [SWEEPS]]``."""
    from ramensim.sweep.archive import restore

    if len(args.folders) > 2 or args.plan is not None or args.into is not None:
        raise InputError("archive --restore: expected at most two folders, ARCHIVES (default docs/results) and "
                         "SWEEPS (default runs/sweeps), and neither --plan nor --into.")
    archives = args.folders[0] if args.folders else ARCHIVES
    sweeps = args.folders[1] if len(args.folders) > 1 else SWEEPS
    if not archives.is_dir():
        raise InputError(f"{archives} is not a folder; expected the archives' folder, e.g. docs/results.")
    done = restore(archives, sweeps)
    log.info("restored %d archived run(s) into %s%s", sum(done.values()), sweeps,
             "".join(f"; {k}: {v}" for k, v in sorted(done.items())))
    return 0


def _adopt(args: argparse.Namespace) -> int:
    """``--adopt RUN... --plan FILE --into SWEEP_FOLDER``."""
    from ramensim.sweep.adopt import adopt_all

    if not args.folders or args.plan is None or args.into is None:
        raise InputError("archive --adopt: expected one or more finished run folders, --plan (the sweep file "
                         "whose points they may be) and --into (that sweep's folder).")
    adopt_all(list(args.folders), args.plan, args.into)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``ramensim archive`` as a stand-alone script (``tools/archive_sweep.py``,
    ``tools/restore_archives.py``, ``tools/adopt_runs.py``): its log and the one-paragraph error of
    bad input (exit 2) are logged, not printed by the CLI."""
    from ramensim.commands import script_main

    return script_main("ramensim archive", __doc__, add_arguments, run, argv, level=logging.INFO)
