"""Parameter sweeps: sweep files (:mod:`.spec`), a resumable crash-safe runner on local
processes or Ray (:mod:`.runner`, :mod:`.worker`, :mod:`.store`), aggregation over agents and
seeds (:mod:`.aggregate`) and tables/figures (:mod:`.report`).

Names are imported lazily so that worker processes load only what a run needs.
"""
from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "SweepSpec": "spec", "SweepPlan": "spec", "SweepPoint": "spec", "load_spec": "spec",
    "plan_sweep": "spec", "point_name": "spec",
    "SweepOutcome": "runner", "run_sweep": "runner",
    "aggregate": "aggregate", "load_runs": "aggregate", "run_values": "aggregate",
    "Report": "report", "make_report": "report",
}
__all__ = sorted([*_EXPORTS, "run"])


def run(file: Any, out: Any = None, **kwargs: Any) -> Any:
    """Run a sweep file and return its :class:`ramensim.api.SweepOutput`: see
    :func:`ramensim.api.sweep` (docs/API.md)."""
    from ramensim.api import sweep

    return sweep(file, out, **kwargs)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"ramensim.sweep.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'ramensim.sweep' has no attribute {name!r}")
