"""The figure of the breadth page (issue 68, item 3): team completion against the communication
success rate, RAMEN and DiNNO each with the project's C-ADMM update and the paper's update as
written, per scene family; local and centralised (no exchange, so one value at every rate) drawn
flat for scale.

A point is the mean over units (run seeds; the trials of one run seed averaged first, eq. U-1 of
:mod:`ramensim.evaluation.intervals`) of the runs' team mean completion (%), with its 95 %
Student t band over the units. Every point of a family's figure is taken over the *same* trials:
those that ran every rate of both updates for both methods (and local and centralised where they
ran), so that a line's shape is never a change of trials; the others are named in the caption.
A rate is read from a breadth sweep's variant name (:func:`ramensim.sweep.breadth_names.rate_of`).
"""
from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from ramensim.evaluation.intervals import nest, t_interval
from ramensim.sweep.breadth_names import PAPER, method_label, rate_of

log = logging.getLogger(__name__)

METHODS = ("ramen", "dinno")
REFERENCES = ("local", "centralised")
METRIC = "completion_ratio_pct"
RATE_AXIS = "channel.success_rate"


@dataclass
class RateFigure:
    """One family's figure: the files written, the rates (%), the trials drawn and those left out,
    and per line its points (rate %, mean %, band low %, band high %)."""
    family: str
    files: list[Path]
    rates: list[float]
    drawn: list[tuple[object, object]]
    left_out: list[tuple[object, object]]
    lines: dict[str, list[tuple[float, float, float, float]]]


def _variants_at(means: dict[str, float], method: str) -> dict[float, str]:
    """Rate (%) -> variant name of ``method`` (``ramen_80``, ``ramen``) among a trial's variants."""
    return {rate_of(v): v for v in means if not v.endswith(PAPER) and (v == method or v.startswith(method + "_"))}


def _slug(family: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", family.lower()).strip("_")


def rate_figures(trials: Sequence, out_dir: Path, formats: Sequence[str] = ("png", "pdf"),
                 width: str = "column") -> list[RateFigure]:
    """Write ``out_dir/update_vs_rate_<family>.<fmt>`` for each family whose trials ran the paper's
    update at two rates or more (``trials``: :class:`ramensim.sweep.breadth.Trial`); returns what
    was drawn. The rates of a family are those at which some trial ran both updates of both
    methods; a trial is drawn when it ran all of them."""
    from ramensim.evaluation.plots import PaperSeries, method_colour, paper_lines, save_figure

    figures = []
    for family in dict.fromkeys(t.family for t in trials):
        members = [t for t in trials if t.family == family]
        at = {id(t): {m: _variants_at(t.means, m) for m in METHODS} for t in members}

        def paired(t, r: float) -> bool:  # both updates of both methods at rate r
            return all(r in v and v[r] + PAPER in t.means for v in at[id(t)].values())

        rates = sorted({r for t in members for r in at[id(t)][METHODS[0]] if paired(t, r)}, reverse=True)
        if len(rates) < 2:
            continue
        drawn = [t for t in members if all(paired(t, r) for r in rates)]
        left = [(t.seed, t.layout) for t in members if t not in drawn]
        if not drawn:
            continue
        units = [t.seed for t in drawn]
        series = []
        for m in METHODS:
            for paper, style, marker, words in ((False, "-", "o", "project's"), (True, "--", "s", "paper's")):
                pts = []
                for r in rates:
                    vals = [t.means[at[id(t)][m][r] + (PAPER if paper else "")] for t in drawn]
                    iv = t_interval(nest(vals, units))
                    pts.append((r, iv.estimate, iv.lo, iv.hi))
                series.append(PaperSeries(f"{method_label(m)}, {words} update", method_colour(m), style, marker, {METRIC: pts}))
        for ref in REFERENCES:
            vals = [t.means[ref] for t in drawn if ref in t.means]
            if len(vals) != len(drawn):
                continue
            iv = t_interval(nest(vals, units))
            series.append(PaperSeries(ref, method_colour(ref), ":", "",
                                      {METRIC: [(r, iv.estimate, iv.lo, iv.hi) for r in rates]}))
        fig = paper_lines(series, RATE_AXIS, [METRIC], width=width, x_values=rates)
        files = save_figure(fig, Path(out_dir) / f"update_vs_rate_{_slug(family)}", formats, dpi=300)
        figures.append(RateFigure(family, files, rates, [(t.seed, t.layout) for t in drawn], left,
                                  {s.label: s.points[METRIC] for s in series}))
        log.info("breadth: %s: the updates against the success rate over %d trials, %s", family, len(drawn),
                 ", ".join(str(f) for f in files))
    return figures


def caption_lines(figures: Sequence[RateFigure], page_dir: Path) -> list[str]:
    """The page's section showing each figure (its PNG, linked relative to the page) and its caption."""
    lines: list[str] = []
    for f in figures:
        png = next((p for p in f.files if p.suffix == ".png"), f.files[0])
        try:
            link = png.relative_to(page_dir).as_posix()
        except ValueError:
            link = png.as_posix()
        n_units = len(dict.fromkeys(s for s, _ in f.drawn))
        rates = ", ".join(f"{r:g}" for r in f.rates)
        out = "; left out (not every point ran): " + ", ".join(f"(seed {s}, layout {l})" for s, l in f.left_out) \
            if f.left_out else ""
        lines += ["", f"### {f.family}: both updates against the success rate", "",
                  f"![Team completion against the success rate, {f.family}]({link})", "",
                  f"Team mean completion (%) at {rates} % success, mean over {n_units} units (run seeds) with its "
                  f"95 % t band; solid: the project's update, dashed: the paper's as written; local and centralised "
                  f"(dotted) exchange nothing and ran once per trial. Every point over the same trials: "
                  + ", ".join(f"(seed {s}, layout {l})" for s, l in f.drawn) + f"{out}."]
    return lines

