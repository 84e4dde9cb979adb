"""``ramensim report SWEEP_DIR``: redraw a sweep's tables (summary.csv, summary.md, runs.csv)
and figures (plots/*.png, *.svg) from its folder alone."""
from __future__ import annotations

import argparse
from pathlib import Path

from ramensim.errors import InputError


def add_parser(sub) -> None:
    p = sub.add_parser("report", help="redraw a sweep's tables and plots from its folder",
                       description=__doc__)
    p.add_argument("sweep_dir", help="the --out folder of 'ramensim sweep'")
    p.add_argument("--metrics", nargs="+", default=None,
                   help="metrics to tabulate and plot (default: all found; plots: the paper's three)")
    p.add_argument("--formats", nargs="+", default=["png", "svg"], help="figure formats (default: png svg)")
    p.add_argument("--digits", type=int, default=2, help="decimals in the Markdown table")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ramensim.sweep.report import make_report

    root = Path(args.sweep_dir)
    if not root.is_dir():
        raise InputError(f"{root}: no such folder; expected the --out folder of 'ramensim sweep'.")
    bad = [f for f in args.formats if f not in ("png", "svg", "pdf")]
    if bad:
        raise InputError(f"--formats {' '.join(bad)}: expected png, svg or pdf.")
    if not 0 <= args.digits <= 12:
        raise InputError(f"--digits {args.digits}: expected a number of decimals in 0..12.")
    rep = make_report(root, metrics=args.metrics, formats=args.formats, digits=args.digits)
    console = Console()
    md = (root / "summary.md").read_text(encoding="utf-8")
    console.print(md, markup=False, highlight=False)
    console.print(f"{len(rep.tables)} tables and {len(rep.figures)} figure files written under {root}")
    return 0
