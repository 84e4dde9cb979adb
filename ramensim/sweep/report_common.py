"""What both styles of a sweep's report share (:mod:`ramensim.sweep.report`, the screen report,
and :mod:`ramensim.sweep.paper_report`, figures for a paper): the report's record, the limits of a
figure, the metrics' words and the figures' captions built from the sweep's own axes."""
from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ramensim.evaluation.plots import key_words, metric_label
from ramensim.sweep.spec import is_replicate_axis
from ramensim.sweep.trials import TrialSummary
from ramensim.sweep.timecourse import CURVE_METRICS, condition_title, trial_words

MAX_GROUPS = 12
"""Most lines/bar groups in one figure; beyond that a figure is skipped with a log message."""
MAX_TIMELINES = 16
"""Most lines in the consensus-error-over-time figure (Fig. 5 with 7 rates x 2 methods fits)."""
HTML_MODES = ("embedded", "linked")
"""How report.html carries its figures (:func:`make_report`'s ``html``)."""
PANEL_ORDER = ("completion_ratio_pct", "artifacts_cm", "holes_cm", "completion_unseen_pct", "completion_far_pct",
               "completion_own_pct", "own_coverage_pct")
"""Order of the panels of a figure of metrics: the completion ratio (Fig. 5's and Fig. 7's) first."""


@dataclass
class Report:
    """What :func:`make_report` wrote."""

    rows: list[dict[str, Any]]
    metrics: list[str]
    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    missing_timeline: list[str] = field(default_factory=list)
    """Completed runs without a timeline (no completion over time for them)."""
    progress: str = ""
    """How many planned runs are done, and which are missing."""
    captions: dict[str, str] = field(default_factory=dict)
    """Figure stem -> its caption (built from the sweep's axes, trials and references)."""
    trials: TrialSummary | None = None
    """Each point's 95 % interval over trials, the paired comparisons, the runs not counted."""


def _numeric(values: Sequence[Any]) -> bool:
    return all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in values)


def _safe(key: str) -> str:
    return key.replace("/", "-")


_CONSENSUS_FIGURES = (("consensus_error", "consensus_timeline"), ("consensus_error_weighted", "consensus_weighted_timeline"))
"""The consensus error's timelines drawn (probe key, figure stem): unweighted (CE-1) and weighted (CE-2)."""


def _words(metric: str) -> str:
    """A metric's label for a sentence: no arrow, lower case (``completion ratio (%)``)."""
    text = metric_label(metric).replace(" ↑", "").replace(" ↓", "")
    return text[:1].lower() + text[1:] if not text[1:2].isupper() else text


def _and(items: Sequence[str]) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1] if items else ""


def _over(axes: Mapping[str, Sequence[Any]]) -> str:
    """``over agents and the 6 trials (run seed × scene layout)``, naming only the seed axes the
    sweep has; ``over agents`` when it has none."""
    seeds = [k for k in axes if is_replicate_axis(k)]
    if not seeds:
        return "over agents (one run per condition)"
    n = int(np.prod([len(axes[k]) for k in seeds]))
    return f"over agents and the {n} trial{'s' if n != 1 else ''} ({trial_words(seeds)})"


def captions(axes: Mapping[str, Sequence[Any]], keys: Sequence[str], drawn: Mapping[str, Sequence[str]],
             trials: int = 0, references: Sequence[str] = ()) -> dict[str, str]:
    """Each figure's caption (by file stem) in words, from the sweep's own axes: the swept keys
    of each figure, the seed axes a trial is made of, and the references drawn (``references``:
    the methods of ``--references`` runs beside the conditions). ``drawn``: stem -> the metrics of
    a metrics figure (``vs_KEY``, ``bars_KEY``, ``bars``)."""
    out: dict[str, str] = {}
    cond = [k for k in keys if len(axes.get(k, [])) > 1]
    for stem, metrics in drawn.items():
        what = _and([_words(m) for m in metrics])
        what = what[:1].upper() + what[1:]
        key = stem.split("_", 1)[1] if "_" in stem else ""
        others = [k for k in cond if k != key]
        by = condition_title(others).lower() if others else ""
        if stem.startswith("vs_"):
            unit = " (%)" if metric_label(key).endswith("(%)") else ""
            out[stem] = (f"{what} against the {key_words(key)}{unit}, " + (f"one line per {by}; " if by else "")
                         + f"mean ± std {_over(axes)}; bands: ± 1 std.")
        elif stem.startswith("bars_"):
            out[stem] = (f"{what} per {key_words(key)}" + (f", one bar per {by} in each group" if by else "")
                         + f"; bar: mean, error bar: ± 1 std {_over(axes)}.")
        else:
            out[stem] = f"{what}; bar: mean, error bar: ± 1 std {_over(axes)}."
    per = f"one line per condition ({condition_title(cond).lower()})" if cond else "one line"
    seeds = [k for k in axes if is_replicate_axis(k)]
    over = (f"mean ± std over {trials} trial{'s' if trials != 1 else ''} ({trial_words(seeds)})" if seeds
            else "one run per condition")
    refs = (f"; thin grey lines: {_and(list(references))} of the same trials from the reference sweep "
            f"(dashed: the ceiling, dotted: the floor)" if references else "")
    out["completion_over_time"] = (f"{_words(CURVE_METRICS[0])[:1].upper()}{_words(CURVE_METRICS[0])[1:]} and "
                                   f"{_words(CURVE_METRICS[1])} against simulated time (s), {per}, {over}{refs}.")
    clip = "; log scale, a band's lower edge clipped at the axis' bottom where mean − std falls below it"
    out["consensus_timeline"] = (f"Consensus error (RMS spread of the maps' parameters, eq. CE-1) against simulated "
                                 f"time (s), {per}, {over}{clip}.")
    out["consensus_weighted_timeline"] = (f"Consensus error weighted by eq. 19 (CE-2, the disagreement RAMEN's "
                                          f"penalty sees) against simulated time (s), {per}, {over}{clip}.")
    return out
