"""Work bounds for tests, counted in steps, not seconds.

A test that checks "this hostile input is refused quickly" must not compare wall time with a
limit: on a loaded 2-core machine a 1-s refusal takes 30 s and the test fails for nothing
(issue 57). :func:`step_budget` counts the Python function calls (``call`` and ``c_call``
events of :func:`sys.setprofile`) made inside a block instead: a number that depends only on
the code and the input, the same on an idle and on a busy machine. Past ``limit`` it stops the
work by raising :class:`StepBudgetExceeded` from the profiler (a ``BaseException``, so the CLI's
own error handling does not turn it into an exit code) and fails the block even if something
swallowed that exception.
"""
from __future__ import annotations

import sys
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator


class StepBudgetExceeded(BaseException):
    """More Python calls than the budget allowed."""


@dataclass
class StepCount:
    limit: int
    steps: int = 0
    exceeded: bool = False


@contextmanager
def step_budget(limit: int) -> Iterator[StepCount]:
    """Count the Python function calls of the block (this thread); raise
    :class:`StepBudgetExceeded` once there are more than ``limit``."""
    count = StepCount(limit)

    def hook(frame, event, arg) -> None:  # noqa: ARG001 - the profiler's signature
        if event == "call" or event == "c_call":
            count.steps += 1
            if count.steps > limit and not count.exceeded:
                count.exceeded = True
                raise StepBudgetExceeded(f"more than {limit} Python calls")

    previous = sys.getprofile()
    sys.setprofile(hook)
    try:
        yield count
    finally:
        sys.setprofile(previous)
    if count.exceeded:
        raise StepBudgetExceeded(f"more than {limit} Python calls (the exception was swallowed on the way)")
