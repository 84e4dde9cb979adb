"""``ramensim sensitivity``: which of the paper's main claims survive which knob of the reproduced
RAMEN (dual_step, beta_l, rho), judged with claims.md's rules and intervals on the sensitivity
sweeps (``ramensim.paper.sensitivity``).

    ramensim sensitivity --out docs/results/sensitivity.md
    ramensim sensitivity --runs runs/sweeps      # also the sweeps not archived yet -> stdout

Exit status: 0 when at least one claim was judged on one trial; 1 when nothing could be judged
(the page is still written); 2 with one paragraph when --results, --runs or --sweeps is not a
folder or a sensitivity sweep file is missing or invalid.
"""
from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Sequence

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The command's options (shared by ``ramensim sensitivity`` and :func:`main`); the folders'
    defaults lie in the repository, wherever the command runs."""
    p.add_argument("--results", type=Path, default=None,
                   help="the folder holding the archived sensitivity sweeps (default: docs/results/sensitivity)")
    p.add_argument("--runs", type=Path, default=None,
                   help="also read the sweep folders DIR/<sweep name> not archived yet (e.g. runs/sweeps)")
    p.add_argument("--sweeps", type=Path, default=None,
                   help="the folder of the sensitivity sweep files (default: scenarios/sweeps/sensitivity)")
    p.add_argument("--out", type=Path, default=None, help="write the page here (default: stdout)")


def add_parser(sub) -> None:
    p = sub.add_parser("sensitivity", help="judge the main claims per knob value of the sensitivity sweeps "
                                           "(docs/results/sensitivity.md)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Judge every knob value and write the page; :class:`InputError` when a folder is not one or
    a sensitivity sweep file is missing or invalid; 1 when nothing could be judged."""
    from ramensim.paper import sensitivity
    from ramensim.paper.sensitivity_page import not_judged, to_markdown

    results = args.results if args.results is not None else sensitivity.REPO / "docs" / "results" / "sensitivity"
    sweeps_dir = args.sweeps if args.sweeps is not None else sensitivity.REPO / "scenarios" / "sweeps" / "sensitivity"
    for flag, folder in (("--results", results), ("--runs", args.runs)):
        if folder is not None and not folder.is_dir():
            raise InputError(f"{flag} {folder} is not a folder; expected the folder holding the sensitivity sweep "
                             f"folders (sensitivity_references/, sensitivity_dual_step/, ...), e.g. "
                             f"{'docs/results/sensitivity' if flag == '--results' else 'runs/sweeps'}.")
    rows, sweeps, trial_list, base = sensitivity.judge_all(results, sweeps_dir, args.runs)
    text = to_markdown(rows, sweeps, trial_list, base, results, args.runs)
    for what, why in not_judged(sweeps):
        log.warning("sensitivity: not judged: %s: %s", what, why)
    if args.out is None:
        sys.stdout.write(text)
    else:
        args.out.write_text(text, encoding="utf-8")
    if not any(c.samples for row in rows for c in row.claims):
        log.error("sensitivity: nothing judged: no claim has a trial with every run it needs (the page lists "
                  "the runs done and lacking)")
        return 1
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``ramensim sensitivity`` as a stand-alone script (``tools/sensitivity_table.py``): warnings
    and the one-paragraph error of bad input (exit 2) are logged, not printed by the CLI."""
    from ramensim.commands import script_main

    return script_main("ramensim sensitivity", __doc__, add_arguments, run, argv, level=logging.WARNING)
