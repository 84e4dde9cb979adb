"""The team engine's interface: what the mapper, the simulation and its observers ask of it,
whatever its mode (``inline.py``, ``threads.py``, ``lockstep.py``; chosen in ``modes.py``).

A round's inputs are fixed when it starts (``round.py``, docs/DESIGN.md "The team engine"); the
engine computes it now or later, on this thread or another, and hands back a :class:`Ticket`
whose :meth:`Ticket.result` is the round's outcome (or re-raises the exception the round
raised). Whatever the mode, a round's numbers are those of computing it inline at its start.
"""
from __future__ import annotations

from typing import Any, Callable, ClassVar, Generic, Sequence, TypeVar

T = TypeVar("T")


class Ticket(Generic[T]):
    """A submitted round: its outcome (or the exception it raised) once computed.

    An engine settles its tickets through :meth:`fulfil` and :meth:`fail` only; ``wait`` (given
    at submission) is called with the ticket when its result is needed and is not there yet,
    and must settle it (wait for a worker, or run the pending batch)."""

    __slots__ = ("_wait", "_outcome", "_error", "_done")

    def __init__(self, wait: Callable[["Ticket[T]"], None] | None = None) -> None:
        self._wait = wait
        self._outcome: T | None = None
        self._error: BaseException | None = None
        self._done = False

    @classmethod
    def computed(cls, job: Callable[[], T]) -> "Ticket[T]":
        """A ticket of ``job()`` computed now, on the calling thread (its exception kept)."""
        ticket: Ticket[T] = cls()
        try:
            ticket.fulfil(job())
        except BaseException as exc:  # noqa: BLE001 - re-raised to the round's owner by result()
            ticket.fail(exc)
        return ticket

    @property
    def done(self) -> bool:
        """Whether the round's outcome (or its exception) is here."""
        return self._done

    def fulfil(self, outcome: T) -> None:
        """The round computed ``outcome``."""
        self._outcome, self._done, self._wait = outcome, True, None

    def fail(self, error: BaseException) -> None:
        """The round raised ``error`` (re-raised to its owner by :meth:`result`)."""
        self._error, self._done, self._wait = error, True, None

    def settle(self) -> None:
        """Wait until the round is computed (never raises the round's exception)."""
        if not self._done:
            wait = self._wait
            assert wait is not None, "an engine must settle a ticket it gave no wait for"
            wait(self)
            assert self._done, "a ticket's wait must settle it"

    def result(self) -> T:
        """The round's outcome; waits for it; re-raises the exception the round raised."""
        self.settle()
        if self._error is not None:
            raise self._error
        return self._outcome  # type: ignore[return-value]


class Engine:
    """Computes a team's submitted rounds (the interface every mode implements).

    ``submit(job)`` hands over a round whose inputs are already fixed (a ``RoundWork`` of
    ``round.py``, or any callable); ``Ticket.result()`` waits for it; ``drain()`` settles every
    round submitted so far (before anything reads a map: ``Simulation.settled_maps``);
    ``map(fn, items)`` runs other work that reads the maps (the meshes of an evaluation) on the
    engine's threads; ``close()`` drains and stops them.

    ``workers``: threads that compute rounds and ``map`` work off the event loop (1: none);
    ``concurrent``: whether rounds leave the event loop at all (then the mapper hands a round to
    the engine at its start and collects it at its end, ``round.py``)."""

    mode: ClassVar[str] = "inline"
    """The mode's name (``modes.py``), as metrics.json's ``build.team_mode`` records it."""

    def __init__(self, workers: int = 1) -> None:
        self.workers = max(1, int(workers))
        self.submitted = 0
        """Rounds submitted so far."""
        self.max_in_flight = 0
        """The most rounds in flight at once (how much the team overlapped)."""
        self.batches = 0
        """Lockstep mode: batched gradient steps computed so far (0 in the other modes)."""
        self.largest_batch = 0
        """Lockstep mode: the most maps in one batched step (0 in the other modes)."""

    @classmethod
    def create(cls, workers: int, maps: Sequence[Any] = ()) -> "Engine":
        """The engine of this mode on ``workers`` threads (``modes.EngineSettings.workers``) for
        the team's ``maps`` (ValueError, in words, when this mode cannot run them)."""
        return cls(workers)

    @staticmethod
    def pool_threads(workers: int) -> int:
        """Threads this mode computes rounds and ``map`` work on, of the ``workers`` asked for."""
        return 1

    @staticmethod
    def rounds_at_once(workers: int, n_maps: int) -> int:
        """Rounds this mode runs at once for a team of ``n_maps`` maps and ``workers`` threads
        (each holds one set of lent work vectors, ``agents/consensus/scratch.py``; the memory
        guard counts them)."""
        return 1

    @property
    def concurrent(self) -> bool:
        """True when rounds leave the event loop's thread (worker threads, or lockstep batches)."""
        return False

    @property
    def parallel_map(self) -> bool:
        """True when :meth:`map` runs its items on worker threads (then a caller may overlap its
        own serial work with it: the final evaluation's scoring, ``Evaluator.score_all``)."""
        return False

    @property
    def lockstep(self) -> bool:
        """True when the team's gradients are computed in batches (metrics.json ``build.team_lockstep``)."""
        return False

    def submit(self, job: Callable[..., T]) -> Ticket[T]:
        """Start computing ``job`` (a round's computation with its inputs fixed)."""
        raise NotImplementedError

    def map(self, fn: Callable[[Any], T], items: list) -> list[T]:
        """``[fn(x) for x in items]``, in order, on the engine's threads when it has any (call it
        after :meth:`drain`, never from a round)."""
        return [fn(x) for x in items]

    def drain(self) -> None:
        """Wait until every submitted round is computed (their exceptions stay with their
        tickets, raised to their owners when they collect them)."""

    def close(self) -> None:
        """Finish the rounds in flight and stop the engine's threads."""
        self.drain()
