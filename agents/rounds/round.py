"""The life of one mapping round, the one path of every robot's mapper whatever the engine's mode.

1. **Plan**: with a concurrent engine, a ``model`` compute clock and a method that says its
   gradient evaluations in advance (``planned_grad_evals``), the round's cost is known at its
   start: ``cost = clock.cost(planned)`` (s); otherwise the cost depends on the round itself
   (its reported evaluations, or its measured wall time) and the round is computed at its start.
2. **Fix the inputs** (``MapperStep.begin_round``): the copies the stale policy selects now, the
   robot's degree now; from now until the round is collected, the frames its camera delivers
   are held back (``end_round`` applies them, in order).
3. **Submit** the round to the engine (or compute it now, unplanned).
4. **Wait** ``cost`` simulated seconds: the event loop goes on meanwhile.
5. **Collect** the outcome when the round ends on the robot's clock (``Ticket.result``: waits
   for the worker or runs the pending lockstep batch; re-raises the round's exception), apply
   the held frames (``end_round``), and **check the plan**: the evaluations the round reports
   must be those planned (else the compute clock would have charged a wrong cost).

So a round's result equals computing it inline at its start, in every mode (docs/DESIGN.md, "The
team engine", draws each mode's timeline).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Generator, Protocol

from ramensim.core.results import RoundResult

from .engine import Engine
from .inline import InlineEngine



class MapperStep(Protocol):
    """The calls a round makes of an agent's mapper: the part of ``agents.process.MapperStep``
    (the whole protocol, which the agent process uses) that this module needs, declared here so
    that the rounds package does not import the agent process back."""

    def begin_round(self, now: float) -> "RoundWork": ...

    def end_round(self) -> None: ...

    def planned_grad_evals(self) -> int | None: ...


class ClockModel(Protocol):
    """What a round asks of an agent's compute clock (``agents.process.ClockModel``)."""

    wall: bool

    def cost(self, iterations: int, wall_seconds: float) -> float:
        """Simulated seconds of a round of ``iterations`` that took ``wall_seconds`` of wall time."""
        ...


@dataclass
class RoundOutcome:
    """What one mapping round did: the method's typed ``result`` (its ``grad_evals`` are what
    the compute clock charges) and, per neighbour, the age (s) of the copy used (None = left out)."""

    result: RoundResult
    copy_ages: dict[int, float | None] = field(default_factory=dict)


@dataclass(frozen=True)
class RoundWork:
    """A round's computation with its inputs fixed (what ``MapperStep.begin_round`` returns and
    an engine computes): ``compute(learner)`` runs the round on ``learner``, the robot's map
    unless the engine hands it a stand-in (lockstep mode's proxy, ``lockstep.py``)."""

    learner: Any
    """The map the round trains."""
    compute: Callable[[Any], RoundOutcome]

    def __call__(self, learner: Any = None) -> RoundOutcome:
        return self.compute(self.learner if learner is None else learner)


UNPLANNED = InlineEngine()
"""Computes the rounds whose cost is not known at their start, at their start, on the event loop."""


def planned_grad_evals(step: "MapperStep", engine: Engine | None, clock: "ClockModel") -> int | None:
    """The gradient evaluations the next round will report when it can go to ``engine`` (a
    concurrent engine, a ``model`` clock and a step that plans them), else None (then it is
    computed at its start, the order of every version before the engine)."""
    if engine is None or not engine.concurrent or clock.wall:
        return None
    plan = getattr(step, "planned_grad_evals", None)
    return plan() if plan is not None else None


class PlanMismatch(RuntimeError):
    """A round reported other gradient evaluations than its method planned."""


def collect(step: "MapperStep", ticket) -> RoundOutcome:
    """The round's outcome (re-raising its exception), then the frames held meanwhile applied."""
    try:
        return ticket.result()
    finally:
        step.end_round()


def live_round(env: Any, step: "MapperStep", engine: Engine | None, clock: "ClockModel", agent: int
               ) -> Generator[Any, Any, tuple[RoundOutcome, float]]:
    """One round of ``agent`` started now (``env.now``, s), as a SimPy generator
    (``outcome, cost = yield from live_round(...)``): its outcome and its cost (simulated s)."""
    t0 = env.now
    planned = planned_grad_evals(step, engine, clock)
    runner = engine if planned is not None else UNPLANNED
    assert runner is not None
    wall0 = time.perf_counter()
    ticket = runner.submit(step.begin_round(t0))
    if planned is None:  # the cost may depend on the result (or the wall clock)
        outcome = collect(step, ticket)
        cost = clock.cost(outcome.result.grad_evals, time.perf_counter() - wall0)
        yield env.timeout(cost)
        return outcome, cost
    cost = clock.cost(planned, 0.0)
    yield env.timeout(cost)
    outcome = collect(step, ticket)
    if int(outcome.result.grad_evals) != planned:
        raise PlanMismatch(
            f"agent {agent}: the method planned {planned} gradient evaluations for its round at t={t0:.3f} s "
            f"but reported {outcome.result.grad_evals:g}; its planned_grad_evals() must match round()'s "
            f"grad_evals.")
    return outcome, cost
