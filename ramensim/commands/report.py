"""``ramensim report SWEEP_DIR``: redraw a sweep's tables (summary.csv, summary.md, runs.csv)
and figures (plots/*.png, *.svg) from its folder alone (``--style paper --width column|page``:
each figure 3.5 or 7 in wide as PDF, SVG and PNG, for a paper); summary.md, which it prints, and
report.html give each point's 95 % interval over trials and the paired comparisons of the
completion ratio (``ramensim.sweep.trials``), and name the runs not counted or from another host."""
from __future__ import annotations

import argparse
from pathlib import Path

from ramensim.core.errors import InputError


def add_parser(sub) -> None:
    p = sub.add_parser("report", help="redraw a sweep's tables and plots from its folder",
                       description=__doc__)
    p.add_argument("sweep_dir", help="the --out folder of 'ramensim sweep'")
    p.add_argument("--metrics", nargs="+", default=None,
                   help="metrics to tabulate and plot (default: all found; plots: the paper's three and the "
                        "coverage metrics, less any a line figure's axis leaves unchanged on every trial)")
    p.add_argument("--formats", nargs="+", default=None,
                   help="figure formats (default: png svg; with --style paper always pdf svg png)")
    p.add_argument("--style", default="default", metavar="STYLE",
                   help="default (figures for the screen) or paper: each figure at a journal width (--width) as "
                        "PDF, SVG and PNG, 8-pt fonts, the sweep's description in the captions (plots/captions.md), "
                        "one colour per method, a log success-rate axis, 95 %% bands over trials and a mark where "
                        "robots diverged or failed")
    p.add_argument("--width", default=None, metavar="WIDTH",
                   help="with --style paper: column (3.5 in, the default) or page (7 in)")
    p.add_argument("--digits", type=int, default=2, help="decimals in the Markdown table")
    p.add_argument("--references", nargs="+", default=[], metavar="SWEEP_DIR",
                   help="sweep folders whose local and centralised runs are drawn as references in the "
                        "completion-over-time figure and give each trial's centralised run for the time to "
                        "consensus (e.g. the Table I sweep for Fig. 5)")
    p.add_argument("--html", choices=("embedded", "linked"), default="embedded",
                   help="report.html with its figures embedded (default: one self-contained page) or linked "
                        "from plots/ (a page of a few kB; for a folder kept under version control)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import sys

    from ramensim.terminal import is_terminal, stdout_console

    from ramensim.sweep.report import make_report

    root = Path(args.sweep_dir)
    if not root.is_dir():
        raise InputError(f"{root}: no such folder; expected the --out folder of 'ramensim sweep'.")
    from ramensim.evaluation.plots import PAPER_WIDTHS_IN
    from ramensim.sweep.report import STYLES

    if args.style not in STYLES:
        raise InputError(f"--style {args.style}: expected one of {', '.join(STYLES)} (paper: figures at a journal "
                         f"width as PDF and SVG, see docs/SWEEPS.md, 'A report for a paper').")
    if args.width is not None and args.style != "paper":
        raise InputError(f"--width {args.width}: a figure width is a choice of the paper style; add --style paper "
                         f"(widths: {', '.join(f'{k} = {v:g} in' for k, v in PAPER_WIDTHS_IN.items())}).")
    width = args.width or "column"
    if width not in PAPER_WIDTHS_IN:
        raise InputError(f"--width {width}: expected "
                         f"{' or '.join(f'{k} ({v:g} in)' for k, v in PAPER_WIDTHS_IN.items())}.")
    formats = args.formats if args.formats is not None else (["pdf", "svg", "png"] if args.style == "paper"
                                                              else ["png", "svg"])
    bad = [f for f in formats if f not in ("png", "svg", "pdf")]
    if bad:
        raise InputError(f"--formats {' '.join(bad)}: expected png, svg or pdf.")
    if not 0 <= args.digits <= 12:
        raise InputError(f"--digits {args.digits}: expected a number of decimals in 0..12.")
    for ref in args.references:
        if not Path(ref).is_dir():
            raise InputError(f"--references {ref}: no such folder; expected the --out folder of a 'ramensim sweep' "
                             "with local and/or centralised runs.")
    rep = make_report(root, metrics=args.metrics, formats=formats, digits=args.digits,
                      references=args.references, html=args.html, style=args.style, width=width)
    from rich.markdown import Markdown

    console = stdout_console()
    texts = [(root / "summary.md").read_text(encoding="utf-8")]
    if (root / "time_to_consensus.md").is_file():
        texts.append((root / "time_to_consensus.md").read_text(encoding="utf-8"))
    for md in texts:
        if is_terminal(sys.stdout):
            console.print(Markdown(md))  # tables drawn as tables, not raw pipes that wrap
        else:
            console.print(md, markup=False, highlight=False)  # a pipe or file: the Markdown itself, unwrapped
    if rep.missing_timeline:
        console.print(f"no completion over time for {len(rep.missing_timeline)} run(s) without a timeline "
                      f"(evaluation.every_s off, or made before timelines): {', '.join(rep.missing_timeline[:10])}",
                      markup=False, highlight=False)
    console.print(f"{len(rep.tables)} tables and {len(rep.figures)} figure files written under {root} "
                  f"(open {root / 'report.html'} in a browser for all of it on one page)", highlight=False)
    return 0
