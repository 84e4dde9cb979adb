"""Where the team engine's mode is chosen: one line per mode, in order of precedence, and the
settings of a run's engine that follow (:func:`engine_settings`, the one answer the simulation,
the memory guard and the lifecycle ask for).

A run's mode is the first whose condition holds for what the environment asks
(:class:`ramensim.agents.rounds.settings.Wanted`). A new mode (CUDA streams, a process pool) is
one new module with its :class:`~ramensim.agents.rounds.engine.Engine` subclass (its
``create``, ``pool_threads`` and ``rounds_at_once`` say what it needs and holds) plus its line
in :data:`MODES`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import torch

from .engine import Engine
from .inline import InlineEngine
from .lockstep import LockstepEngine
from .settings import Wanted, read_wanted
from .threads import ThreadEngine


@dataclass(frozen=True)
class Mode:
    """A mode: its ``name``, its ``engine`` class, ``when`` it is chosen (given a ``Wanted``)."""

    name: str
    engine: type[Engine]
    when: Callable[[Wanted], bool]


MODES: tuple[Mode, ...] = (
    Mode("lockstep", LockstepEngine, lambda want: want.batch and want.maps > 1),
    Mode("threads", ThreadEngine, lambda want: want.workers > 1),
    Mode("inline", InlineEngine, lambda want: True),
)
"""The modes, the first that applies wins (``inline`` always applies)."""


def mode_named(name: str) -> Mode:
    """The mode called ``name`` (KeyError naming the modes otherwise)."""
    for m in MODES:
        if m.name == name:
            return m
    raise KeyError(f"team engine mode {name!r}: expected one of {', '.join(m.name for m in MODES)}")


@dataclass(frozen=True)
class EngineSettings:
    """The team engine of one run, decided once: its ``mode`` (:data:`MODES`), the threads it
    computes on (``workers``; 1 inline and in lockstep), the team's ``maps`` and their
    ``device``, and ``eval_lane`` (``$RAMENSIM_EVAL_LANE``; None: automatic)."""

    mode: str
    workers: int
    maps: int
    device: torch.device
    eval_lane: bool | None = None

    @property
    def engine_class(self) -> type[Engine]:
        return mode_named(self.mode).engine

    @property
    def concurrent(self) -> bool:
        """Whether rounds leave the event loop (every mode but inline)."""
        return self.mode != "inline"

    @property
    def rounds_at_once(self) -> int:
        """Rounds that run at once (each holds a set of lent work vectors): the memory guard's
        count (1 inline, the workers, or every map in lockstep)."""
        return self.engine_class.rounds_at_once(self.workers, self.maps)

    @property
    def evaluation_lane(self) -> bool:
        """Whether periodic evaluations run on their own thread (``ramensim.observe.EvaluationLane``):
        as ``$RAMENSIM_EVAL_LANE`` says, else whenever rounds leave the event loop."""
        return self.concurrent if self.eval_lane is None else self.eval_lane

    @property
    def lane_threads(self) -> int:
        """Cap of the evaluation lane's map stages: 1 beside the engine's workers on a CPU, else 0 (none)."""
        return 1 if self.device.type == "cpu" and self.workers > 1 else 0

    def make(self, maps: Sequence[Any] = ()) -> Engine:
        """The engine these settings chose, for the team's ``maps`` (ValueError, from the mode,
        when the maps cannot run it: lockstep batches off the torch path)."""
        return self.engine_class.create(self.workers, maps)


def engine_settings(n_maps: int, device: torch.device | str = "cpu") -> EngineSettings:
    """The engine settings of a team of ``n_maps`` maps on ``device``, from the environment
    (``settings.py``); ValueError naming the variable for a bad value."""
    wanted = read_wanted(n_maps, device)
    mode = next(m for m in MODES if m.when(wanted))
    return EngineSettings(mode.name, mode.engine.pool_threads(wanted.workers), n_maps, wanted.device,
                          wanted.eval_lane)
