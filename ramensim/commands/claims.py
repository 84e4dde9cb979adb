"""``ramensim claims``: the paper's claims judged on the archived paper-horizon runs, with 95 %
intervals over trials and holds / fails / inconclusive verdicts (``ramensim.paper``).

    ramensim claims                                    # docs/results/paper -> stdout
    ramensim claims --out docs/results/paper/claims.md

Reads the archived paper sweeps under --results, the cause studies under --causes (default:
cause/ beside --results) and the Fig. 7 sweeps beyond the paper's runs under --beyond (default:
fig7/ beside --results); every run not judged is named on the page and in a warning.
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
    """The command's options (shared by ``ramensim claims`` and :func:`main`)."""
    p.add_argument("--results", type=Path, default=Path("docs/results/paper"),
                   help="the folder holding the archived paper sweeps (default: docs/results/paper)")
    p.add_argument("--causes", type=Path, default=None,
                   help="the folder holding the cause studies (default: cause/ beside --results)")
    p.add_argument("--beyond", type=Path, default=None,
                   help="the folder holding the Fig. 7 sweeps beyond the paper's runs (fig7_authors_rounds/, "
                        "fig7_many_robots/; default: fig7/ beside --results)")
    p.add_argument("--out", type=Path, default=None, help="write the table here (default: stdout)")


def add_parser(sub) -> None:
    p = sub.add_parser("claims", help="judge the paper's claims on the archived runs (docs/results/paper/claims.md)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Judge every claim and write the page; :class:`InputError` when ``--results`` is not a folder
    or an archive cannot be read at all."""
    from ramensim.paper.claims import judge_all, not_judged
    from ramensim.paper.pages import to_markdown
    from ramensim.paper.trials import Judging

    if not args.results.is_dir():
        raise InputError(f"--results {args.results} is not a folder; expected the folder holding the archived paper "
                         f"sweeps (paper_table1/, paper_fig1/, ...), e.g. docs/results/paper.")
    causes = args.causes if args.causes is not None else args.results.parent / "cause"
    judging = Judging()
    claims = judge_all(args.results, causes, args.beyond, judging)
    notes = not_judged(args.results, judging)
    text = to_markdown(claims, args.results, notes, judging)
    for what, why in notes:
        log.warning("claims: not judged: %s: %s", what, why)
    if args.out is None:
        sys.stdout.write(text)
    else:
        args.out.write_text(text, encoding="utf-8")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``ramensim claims`` as a stand-alone script (``tools/paper_claims.py``): warnings and the
    one-paragraph error of bad input (exit 2) are logged, not printed by the CLI."""
    from ramensim.commands import script_main

    return script_main("ramensim claims", __doc__, add_arguments, run, argv, level=logging.WARNING)
