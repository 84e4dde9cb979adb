"""How a breadth sweep names its runs (``scenarios/sweeps/evidence/*.yaml``), read by the breadth
page (:mod:`ramensim.sweep.breadth`) and its figure (:mod:`ramensim.sweep.breadth_figure`): a
variant's success rate and method, and the suffix of a run of the paper's update."""
from __future__ import annotations

PAPER = "@paper"
"""Suffix of the variants of runs made with the paper's update as written (``consensus.preset: paper``)."""


def rate_of(variant: str) -> float:
    """The success rate (%) of a breadth sweep's variant: ``NAME`` runs at 50 %, ``NAME_R`` at R %
    (``ramen_20``, ``dinno_100``); a trailing ``@paper`` is ignored."""
    tail = variant.removesuffix(PAPER).partition("_")[2]
    return float(tail) if tail.isdigit() else 50.0


def method_label(variant: str) -> str:
    """The method of a breadth sweep's variant as the pages print it (``ramen_20`` -> RAMEN)."""
    return "RAMEN" if variant.startswith("ramen") else "DiNNO" if variant.startswith("dinno") else variant
