"""The paper's claims judged on the archived paper-horizon runs, with 95 % intervals over trials
(``ramensim claims``; the page: :mod:`ramensim.paper.pages`).

    ramensim claims                                    # docs/results/paper -> stdout
    ramensim claims --out docs/results/paper/claims.md

Reads the archives ``paper_table1``, ``paper_fig1``, ``paper_fig5``, ``paper_fig5_paper_update``,
``paper_fig7``, ``paper_fig7_authors_split`` and ``paper_dsgt_async`` under ``--results`` (each a sweep folder: ``sweep.json``
and ``runs/``, as ``tools/archive_sweep.py`` keeps them) and the cause studies under ``--causes``
(default: ``cause/`` beside ``--results``), and writes one Markdown table: a row per claim of
issue 25 ("What it must show") and of the paper's sentences issue 56 asks to be judged. Each
claim compares one quantity per trial (run seed x house layout; e.g. RAMEN's team completion
minus centralised's) with a threshold; over the trials judged the quantity gets a paired 95 %
interval (``evaluation/intervals.py``: Student t over the per-trial values; over their logs
for a ratio; a bootstrap over whole trials for a standard deviation pooled over robots and
trials, as the paper's tables pool it), and the verdict is *holds* (the interval clears the
threshold on the claim's side), *fails* (it lies wholly on the wrong side) or *inconclusive*
(it straddles the threshold, or there are fewer than two trials). A claim needing several
comparisons at once fails if one fails and holds if all hold. Each row also gives how many
trials were judged, on how many the trial's own numbers clear the threshold (✓), a measured
cause where the verdict is not "holds" or the claim's reading needs one, and every trial's
numbers. A trial is judged only when every run the rule needs is complete. Completion is the
paper's completion ratio (%, 5 cm); "team" is the mean over a run's robots, "every robot"
compares each robot of one method with each robot of the other (the smallest difference over
all pairs). The consensus-error "≥ 10x" claims use the fall defined in docs/ALGORITHM.md
section 5 (``evaluation/consensus_fall.py``): the peak after the start-up transient over the
mean of the last 60 s of readings.

A second table, "Runs done", lists for every archived experiment and condition (the plan's axes
other than run seed and layout) the trials with a finished run, read from the archive's plan
(``sweep.json``). A third section names every run not judged and why: planned but not run,
not complete (status not ``ok``/``diverged``), a ``metrics.json`` that is missing or
unreadable, made from other settings than its plan point (another fingerprint), or lacking a
number a rule needs; the claims are judged on the rest. A trial whose compared runs ran on
different machines (metrics.json ``build``: CPU model and device) is marked †.

Missing archives are reported as "no run yet"; an archive that is not a sweep folder (no readable
``sweep.json`` and no ``runs/``) is named among the runs not judged; ``--results`` that is not a
folder is an error naming it (exit 2).

The claims of each experiment are judged in their own module (:mod:`~ramensim.paper.table1`,
:mod:`~ramensim.paper.fig1`, :mod:`~ramensim.paper.fig5`, :mod:`~ramensim.paper.fig7`,
:mod:`~ramensim.paper.dsgt`) with the rules of :mod:`~ramensim.paper.rules`, over the archives of
one :class:`~ramensim.paper.trials.Judging` pass.
"""
from __future__ import annotations

from pathlib import Path

from ramensim.paper.archive import TRIAL_AXES
from ramensim.paper.dsgt import dsgt_claims
from ramensim.paper.fig1 import fig1_claims
from ramensim.paper.fig5 import fig5_claims, low_rate_claims
from ramensim.paper.fig7 import BEYOND, beyond_claims, fig7_claims, fig7_split_claims
from ramensim.paper.rules import Claim
from ramensim.paper.table1 import table1_claims
from ramensim.paper.trials import Judging

EXPERIMENTS = {"paper_table1": "Table I", "paper_fig1": "Fig. 1", "paper_fig5": "Fig. 5",
               "paper_fig5_paper_update": "5 % and 1 % with the paper's update",
               "paper_dsgt_async": "DSGD, DSGT (and RAMEN) with unlimited bandwidth", "paper_fig7": "Fig. 7",
               "paper_fig7_authors_split": "Fig. 7 with the authors' split"}
"""The archived protocol sweeps, in the order docs/RESULTS.md lists them."""


def runs_done(results: Path, judging: Judging | None = None) -> list[tuple[str, str, list[tuple[int, int]], int]]:
    """Which trials of each condition have a finished run: one row per experiment and condition
    (the plan's axes other than run seed and layout), as (experiment, condition, trials done,
    trials planned), from each archive's plan (``sweep.json``) and its finished runs (the archives
    ``judging`` read, or read afresh)."""
    judging = judging if judging is not None else Judging()
    rows = []
    for name, title in EXPERIMENTS.items():
        arc = judging.archive(results / name)
        conditions: dict[str, list[tuple[int, int]]] = {}
        for axes in arc.planned:
            cond = ", ".join(f"{k}={v}" for k, v in axes.items() if k not in TRIAL_AXES) or "—"
            conditions.setdefault(cond, []).append((axes.get("seed"), axes.get("world.scene.seed")))
        done = {(tuple(r.axes.get(k) for k in TRIAL_AXES),
                 ", ".join(f"{k}={v}" for k, v in r.axes.items() if k not in TRIAL_AXES) or "—")
                for r in arc.records}
        for cond, trials in conditions.items():
            rows.append((title, cond, [t for t in trials if (t, cond) in done], len(trials)))
    return rows


def judge_all(results: Path, causes: Path | None = None, beyond: Path | None = None,
              judging: Judging | None = None) -> list[Claim]:
    """Every claim judged on the archives under ``results`` (and the cause studies under ``causes``,
    the Fig. 7 sweeps beyond the paper's runs under ``beyond``, :data:`~ramensim.paper.fig7.BEYOND`;
    default: ``fig7/`` beside ``results``), in the order claims.md lists them. ``judging``: the
    pass whose archives and notes the page reads afterwards (:func:`not_judged`,
    :func:`ramensim.paper.pages.to_markdown`); a fresh one when not given."""
    beyond = beyond if beyond is not None else results.parent / "fig7"
    j = judging if judging is not None else Judging()
    a = {name: j.archive(results / name) for name in EXPERIMENTS}
    claims = (table1_claims(j, a["paper_table1"]) + fig1_claims(j, a["paper_fig1"])
              + fig5_claims(j, a["paper_fig5"], a["paper_table1"])
              + low_rate_claims(j, a["paper_fig5"], a["paper_fig5_paper_update"], a["paper_table1"])
              + fig7_claims(j, a["paper_fig7"], causes, a["paper_table1"])
              + fig7_split_claims(j, a["paper_fig7_authors_split"])
              + beyond_claims(j, a["paper_fig7_authors_split"], *(j.archive(beyond / name) for name in BEYOND))
              + dsgt_claims(j, a["paper_dsgt_async"], a["paper_table1"], causes))
    return claims


def not_judged(results: Path, judging: Judging) -> list[tuple[str, str]]:
    """(run or claim and trial, why) for every run of the archives not judged
    (:attr:`Archive.problems <ramensim.paper.archive.Archive>`) and every trial a run's missing
    number kept out (:attr:`Judging.skipped <ramensim.paper.trials.Judging>`, filled by
    :func:`judge_all` with this ``judging``)."""
    out = [(f"{name}/{run}", why) for name in EXPERIMENTS for run, why in judging.archive(results / name).problems]
    return out + list(judging.skipped)

