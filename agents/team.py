"""The team engine's old import path: the engine lives in ``agents/rounds/`` (the interface, one
module per mode, where modes are chosen, the settings reader, the life of a round); its names
are re-exported here, so ``from ramensim.agents.team import BATCH_ENV, WORKERS_ENV, ...`` still
works.
"""
from __future__ import annotations

from typing import Callable

from ramensim.agents.rounds import (BATCH_ENV, EVAL_LANE_ENV, WORKERS_ENV, Engine, InlineEngine, LockstepEngine,
                                    LockstepGate, LockstepLearner, ThreadEngine, Ticket, engine_settings,
                                    team_batching, team_workers)

__all__ = ["BATCH_ENV", "EVAL_LANE_ENV", "WORKERS_ENV", "Engine", "LockstepGate", "LockstepLearner", "TeamEngine",
           "Ticket", "engine_settings", "team_batching", "team_workers"]


def TeamEngine(workers: int = 1, batch: Callable[[list], list] | None = None) -> Engine:  # noqa: N802 - the old class name
    """The engine the old ``TeamEngine(workers, batch)`` constructor gave: lockstep batches with
    ``batch``, else ``workers`` threads (``workers >= 2``), else inline."""
    if batch is not None:
        return LockstepEngine(batch)
    return ThreadEngine(workers) if int(workers) > 1 else InlineEngine()
