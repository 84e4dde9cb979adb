"""``ramensim paper``: the figures and cause studies docs/results/ shows, made from archived sweeps and
finished runs (``ramensim.paper``; the claims and the sensitivity table are ``ramensim claims`` and
``ramensim sensitivity``).

    ramensim paper figures [--results docs/results/paper] [--out docs/images/results]
    ramensim paper medium docs/results/medium/medium_table1 [MORE_ARCHIVES ...] [--reference links]
    ramensim paper surface-steps docs/results/paper/paper_fig7_authors_split [--jump 5] [--until 600]
    ramensim paper plateau RUN [RUN ...] [--from 400] [--out DIR]
    ramensim paper copy-age RUN_OR_MESSAGES_CSV [--every 60] [--out DIR]
    ramensim paper rescore RUN [--at 30 60 ...] [--own] [--out DIR]
    ramensim paper artifacts RUN [--samples 200000] [--bad 0.05] [--out DIR]
    ramensim paper artifacts --compare A/artifacts_by_distance.json B/... [...]
    ramensim paper far-part RUN [--window 100] [--samples 200000] [--out DIR]
    ramensim paper far-part --compare A/far_part.json B/far_part.json [...]
    ramensim paper tracker-drift SCENARIO [--set KEY=VALUE ...] [--every-s 5] [--matched-lag] [--out DIR]

figures: completion over time per archived experiment, the mean over trials with a 95 % t band
(the figures at the top of docs/RESULTS.md). medium: the tables of docs/results/medium.md.
surface-steps: completion's change against the seen surface's steps between evaluations.
plateau: where the consensus error levels off. copy-age: the copies' age on arrival per window.
rescore: the final meshes scored with the views of earlier times. artifacts: the kept mesh by
distance to what each map's own robots saw and by part of the ground truth. far-part: the far
part's completion by first sight and by links. tracker-drift: DSGT's gradient-tracking invariant
logged during a run (a read-only probe). A study of a run folder prints its table; with --out it
also writes it as <study>.md with its numbers as <study>.json.
"""
from __future__ import annotations

import argparse
import logging
import math
import sys
from pathlib import Path
from typing import Any, Callable, Sequence

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)


def _out(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--out", type=Path, default=None, help=f"write {what} here (default: print only)")


def _figures_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--results", type=Path, default=Path("docs/results/paper"),
                   help="folder of the archived sweeps (default: docs/results/paper)")
    p.add_argument("--out", type=Path, default=Path("docs/images/results"),
                   help="folder of the figures (default: docs/images/results)")


def _figures(args: argparse.Namespace) -> int:
    """Draw <experiment>_completion.png for every archived experiment."""
    from ramensim.paper.figures import draw_all

    draw_all(args.results, args.out)
    return 0


def _medium_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("archives", type=Path, nargs="+", help="archived sweeps of scenarios/sweeps/medium/")
    p.add_argument("--reference", default="links", help="the medium the others are compared with (default links)")


def _medium(args: argparse.Namespace) -> int:
    """Print docs/results/medium.md's tables."""
    from ramensim.paper.medium import read, tables

    runs = read(*args.archives)
    if not runs:
        raise InputError(f"{', '.join(map(str, args.archives))}: no runs/<seed=S__variant=M_K>/metrics.json "
                         f"found; expected archived sweeps of scenarios/sweeps/medium/, e.g. "
                         f"docs/results/medium/medium_table1.")
    sys.stdout.write(tables(runs, args.reference))
    return 0


def _surface_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("archive", type=Path, help="an archived sweep folder (holding runs/<point>/metrics.json)")
    p.add_argument("--jump", type=float, default=5.0, help="a step of the seen surface, points (default 5)")
    p.add_argument("--until", type=float, default=math.inf, help="only evaluations up to this time, s")


def _surface(args: argparse.Namespace) -> int:
    """Print the correlation and the completion's change at the surface's steps."""
    from ramensim.paper.surface_steps import analyse, render

    sys.stdout.write(render(args.archive, analyse(args.archive, args.jump, args.until)))
    return 0


def _plateau_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", type=Path, nargs="+", help="finished run folders (or their metrics.json)")
    p.add_argument("--from", dest="t_from", type=float, default=400.0,
                   help="start of the late window, simulated s (default 400)")
    _out(p, "consensus_plateau.json / .md")


def _plateau(args: argparse.Namespace) -> int:
    """Print (and write) each run's consensus-error peak, end and late level."""
    from ramensim.paper.plateau import analyse, render
    from ramensim.paper.study import write_outputs

    res = analyse(args.runs, args.t_from)
    write_outputs(args.out, "consensus_plateau", res, render(res["runs"], args.t_from))
    return 0


def _copy_age_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run", type=Path, help="a run folder holding messages.csv, or the file itself")
    p.add_argument("--every", type=float, default=60.0, help="window length, simulated s (default 60)")
    _out(p, "copy_age.json / .md")


def _copy_age(args: argparse.Namespace) -> int:
    """Print (and write) the copies' age on arrival per window."""
    from ramensim.paper.copy_age import analyse, render
    from ramensim.paper.study import write_outputs

    res = analyse(args.run, args.every)
    write_outputs(args.out, "copy_age", res, render(args.run, res["windows"], (res["delivered"], res["mean_s"])))
    return 0


def _finished_run(run: Path | None) -> Path:
    """``run`` when it is a finished run folder (scenario.yaml and metrics.json), else :class:`InputError`."""
    if run is None or not (run / "metrics.json").is_file() or not (run / "scenario.yaml").is_file():
        raise InputError(f"{run} is not a finished run folder; expected one holding scenario.yaml, metrics.json and "
                         f"mesh_<map>.ply (e.g. runs/sweeps/paper_fig7_authors_split/runs/<point>).")
    return run


def _study(run: Path, fn: Callable[..., dict[str, Any]], *a: Any) -> dict[str, Any]:
    """``fn(run, *a)`` with a missing mesh or a bad scenario of the run as one :class:`InputError`."""
    try:
        return fn(run, *a)
    except (OSError, ValueError) as exc:  # a folder without its meshes (an archive), a bad scenario
        raise InputError(f"{run}: {exc}") from None


def _rescore_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run", type=Path, help="a finished run folder with mesh_<map>.ply")
    p.add_argument("--at", type=float, nargs="+", default=None, help="times (s); default the run's evaluations")
    p.add_argument("--own", action="store_true", help="also score with the map's own robots' views only")
    _out(p, "rescore.json / .md")


def _rescore(args: argparse.Namespace) -> int:
    """Print (and write) the final meshes' scores with the views up to each time."""
    import numpy as np

    from ramensim.paper.rescore import evaluation_times, markdown, rescore
    from ramensim.paper.study import write_outputs

    run = _finished_run(args.run)
    times = args.at if args.at is not None else evaluation_times(run)
    with np.errstate(all="ignore"):
        res = _study(run, rescore, [float(t) for t in times], args.own)
    write_outputs(args.out, "rescore", res, markdown(res))
    return 0


def _artifacts_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run", type=Path, nargs="?", help="a finished run folder with mesh_<map>.ply")
    p.add_argument("--compare", type=Path, nargs="+", metavar="JSON",
                   help="saved artifacts_by_distance.json files: print their team rows side by side")
    p.add_argument("--samples", type=int, default=200_000, help="mesh samples per map (default 200,000)")
    p.add_argument("--bad", type=float, default=0.05, help="error (m) above which a sample counts as bad")
    _out(p, "artifacts_by_distance.json / .md")


def _artifacts(args: argparse.Namespace) -> int:
    """Print (and write) the kept meshes by distance and by part, or compare saved outputs."""
    from ramensim.paper.artifacts import analyse, compare, markdown
    from ramensim.paper.study import write_outputs

    if args.compare:
        sys.stdout.write(compare(args.compare))
        return 0
    res = _study(_finished_run(args.run), analyse, args.samples, args.bad)
    write_outputs(args.out, "artifacts_by_distance", res, markdown(res))
    return 0


def _far_part_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run", type=Path, nargs="?", help="a finished run folder with mesh_<map>.ply")
    p.add_argument("--compare", type=Path, nargs="+", metavar="JSON", help="saved far_part.json files")
    p.add_argument("--window", type=float, default=100.0, help="width of a bin of first sight, s (default 100)")
    p.add_argument("--samples", type=int, default=200_000, help="ground-truth and mesh samples (default 200,000)")
    _out(p, "far_part.json and .md")


def _far_part(args: argparse.Namespace) -> int:
    """Print (and write) the far part's completion by first sight and by links, or compare saved outputs."""
    from ramensim.paper.far_part import analyse, compare, markdown
    from ramensim.paper.study import write_outputs

    if args.compare:
        sys.stdout.write(compare(args.compare))
        return 0
    run = _finished_run(args.run)
    if not args.window > 0:
        raise InputError(f"--window {args.window}: expected a positive number of seconds.")
    res = _study(run, analyse, args.window, args.samples)
    write_outputs(args.out, "far_part", res, markdown(res))
    return 0


def _drift_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", type=Path, help="the scenario to run with DSGT")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key (repeatable)")
    p.add_argument("--every-s", type=float, default=5.0, help="a table row every this many simulated s (default 5)")
    p.add_argument("--matched-lag", action="store_true",
                   help="run the counterfactual tracker of MatchedLag (robots in step, nothing lost) instead of "
                        "DSGT as built")
    _out(p, "tracker_drift.json / .md (and the run into DIR/run; default: a temporary folder)")


def _drift(args: argparse.Namespace) -> int:
    """Run the scenario with the probe; print (and write) the drift table; 1 when the run failed."""
    import tempfile

    from ramensim.paper.study import write_outputs
    from ramensim.paper.tracker_drift import heading, probe_run, table

    run_dir = args.out / "run" if args.out else Path(tempfile.mkdtemp(prefix="dsgt_drift_"))
    result, probe = probe_run(args.scenario, args.sets, run_dir, args.matched_lag)
    text = heading(result, args.scenario, args.sets, args.matched_lag) + table(probe.records, args.every_s)
    write_outputs(args.out, "tracker_drift",
                  {"scenario": str(args.scenario), "sets": args.sets, "records": probe.records}, text)
    if result.status == "failed":  # what was recorded is written above; say why the run stopped
        reasons = {r.failed_reason for r in result.per_agent.values() if r.failed_reason} or {result.error}
        log.error("the run failed: %s", "; ".join(sorted(str(r) for r in reasons)))
        return 1
    return 0


STUDIES: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {
    "figures": ("completion over time per archived experiment, 95 % band over trials (docs/images/results/)",
                _figures_args, _figures),
    "medium": ("the tables of docs/results/medium.md from archived medium sweeps", _medium_args, _medium),
    "surface-steps": ("completion's change against the seen surface's steps, over an archived sweep",
                      _surface_args, _surface),
    "plateau": ("where runs' consensus error levels off: peak, end, late mean and std", _plateau_args, _plateau),
    "copy-age": ("the copies' age on arrival per window of a run (messages.csv)", _copy_age_args, _copy_age),
    "rescore": ("a run's final meshes scored with the views up to earlier times", _rescore_args, _rescore),
    "artifacts": ("a run's kept meshes by distance to what their own robots saw, and by part",
                  _artifacts_args, _artifacts),
    "far-part": ("the far part's completion by first sight and by links", _far_part_args, _far_part),
    "tracker-drift": ("DSGT's gradient-tracking invariant logged during a run", _drift_args, _drift),
}
"""The subcommands: name -> (help, options, what it runs)."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The subcommands and their options (shared by ``ramensim paper`` and :func:`main`)."""
    sub = p.add_subparsers(dest="study", metavar="STUDY", required=True)
    for name, (text, options, fn) in STUDIES.items():
        s = sub.add_parser(name, help=text.replace("%", "%%"), description=f"ramensim paper {name}: {text}.")
        options(s)
        s.set_defaults(study_func=fn)


def add_parser(sub) -> None:
    p = sub.add_parser("paper", help="the figures and cause studies of docs/results/ (figures, medium, far-part, ...)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the chosen study; :class:`InputError` for bad input (a file or folder that is not what the
    study reads, a value out of range)."""
    return args.study_func(args)


def main(argv: Sequence[str] | None = None) -> int:
    """``ramensim paper`` as a stand-alone script (the thin scripts of tools/: ``tools/far_part.py``
    calls ``main(["far-part", ...])``): the log and the one-paragraph error of bad input (exit 2) are
    logged, not printed by the CLI."""
    from ramensim.commands import script_main

    return script_main("ramensim paper", __doc__, add_arguments, run, argv, level=logging.INFO,
                       prefix=lambda a: f"paper {a.study}")
