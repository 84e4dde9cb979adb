"""Lockstep mode (the GPU's form): the team's gradients computed in batches.

A submitted round waits until a result or a drain is needed; then every pending round runs at
once, one thread each, and each round sees a proxy of its map (:class:`LockstepLearner`) whose
``loss_and_grad`` joins the team's batched step: whenever every round still running waits there,
their maps' gradients are computed as one call of ``batch`` (``team_loss_and_grad`` of
``agents/map/team_batch.py``: the step of ``agents/map/step.py`` over stacked tables), in the
rounds' submission order whatever the threads' timing. Which rounds are pending at a simulated
time is fixed by the event loop, so the batches, and so the numbers, are the same on every run.
The map itself knows nothing of the team: the proxy is all the round is given.
"""
from __future__ import annotations

import logging
import threading
from typing import Any, Callable, Sequence, TypeVar

from ramensim.agents.map.team_batch import check_team, team_loss_and_grad

from .engine import Engine, Ticket
from .settings import BATCH_ENV

log = logging.getLogger(__name__)

T = TypeVar("T")

Batch = Callable[[list], list]
"""``batch(learners) -> [(scalars, grad)]``: one gradient step of every map at once, in order."""


class LockstepGate:
    """Joins the gradient evaluations of ``rounds`` rounds that run at once, one thread each:
    when every round still running waits in :meth:`loss_and_grad`, their maps' gradients are
    computed together by ``batch``, in the rounds' submission order."""

    def __init__(self, rounds: int, batch: Batch) -> None:
        self._cv = threading.Condition()
        self._running = rounds
        self._batch = batch
        self._waiting: list[list] = []
        self.batches = 0
        """Batched gradient steps computed."""
        self.largest = 0
        """The most maps in one batched step."""

    def loss_and_grad(self, index: int, learner: Any):
        """The ``loss_and_grad()`` of the round submitted ``index``-th, on map ``learner``:
        waits for the team's batched step and returns this map's ``(scalars, grad)``."""
        slot = [index, learner, None, None]
        with self._cv:
            self._waiting.append(slot)
            self._fire_if_all_wait()
            while slot[2] is None and slot[3] is None:
                self._cv.wait()
        if slot[3] is not None:
            raise slot[3]
        return slot[2]

    def leave(self) -> None:
        """A round has ended (or failed)."""
        with self._cv:
            self._running -= 1
            self._fire_if_all_wait()

    def _fire_if_all_wait(self) -> None:
        if not self._waiting or len(self._waiting) < self._running:
            return
        batch = sorted(self._waiting, key=lambda s: s[0])
        self._waiting = []
        try:
            results = self._batch([s[1] for s in batch])
            for s, r in zip(batch, results):
                s[2] = r
        except BaseException as exc:  # noqa: BLE001 - every round of the batch sees it
            for s in batch:
                s[3] = exc
        self.batches += 1
        self.largest = max(self.largest, len(batch))
        self._cv.notify_all()


class LockstepLearner:
    """The learner a lockstep round is given: its map for everything (``theta``, ``visits``,
    ``optimizer_step``, ...), except ``loss_and_grad``, which joins the team's batched step
    through ``gate`` as the round submitted ``index``-th."""

    __slots__ = ("_gate", "_index", "_map")

    def __init__(self, gate: LockstepGate, index: int, learner: Any) -> None:
        self._gate, self._index, self._map = gate, index, learner

    def loss_and_grad(self):
        """This map's ``(scalars, grad)`` of the team's batched step (the values of its own
        torch path up to float rounding, ``agents/map/team_batch.py``)."""
        return self._gate.loss_and_grad(self._index, self._map)

    def __getattr__(self, name: str):
        return getattr(self._map, name)


class LockstepEngine(Engine):
    """Pending rounds run together when a result or a drain is needed, their gradients batched
    by ``batch`` (see the module's docstring). A job with a ``learner`` (a ``RoundWork``,
    ``round.py``) is called with its proxy; any other callable runs as it is, unbatched."""

    mode = "lockstep"

    def __init__(self, batch: Batch) -> None:
        super().__init__(1)
        self.batch = batch
        self._pending: list[tuple[Ticket, Callable[..., Any]]] = []

    @classmethod
    def create(cls, workers: int, maps: Sequence[Any] = ()) -> "LockstepEngine":
        """Lockstep batches of ``maps`` with ``team_loss_and_grad``; ValueError naming
        ``RAMENSIM_TEAM_BATCH`` unless the maps can share one batch (the torch path)."""
        try:
            check_team(list(maps))
        except ValueError as exc:
            raise ValueError(f"{BATCH_ENV}=1: {exc}") from None
        log.info("team engine: %d maps' gradients in lockstep batches", len(maps))
        return cls(team_loss_and_grad)

    @staticmethod
    def rounds_at_once(workers: int, n_maps: int) -> int:
        return n_maps

    @property
    def concurrent(self) -> bool:
        return True

    @property
    def lockstep(self) -> bool:
        return True

    def submit(self, job: Callable[..., T]) -> Ticket[T]:
        self.submitted += 1
        ticket: Ticket[T] = Ticket(self._run_pending)
        self._pending.append((ticket, job))
        self.max_in_flight = max(self.max_in_flight, len(self._pending))
        return ticket

    def _run_pending(self, _ticket: Ticket | None = None) -> None:
        """Run every pending round at once, one thread each, their gradients batched."""
        pending, self._pending = self._pending, []
        if not pending:
            return
        gate = LockstepGate(len(pending), self.batch)

        def run(index: int, ticket: Ticket, job: Callable[..., Any]) -> None:
            try:
                learner = getattr(job, "learner", None)
                ticket.fulfil(job() if learner is None else job(LockstepLearner(gate, index, learner)))
            except BaseException as exc:  # noqa: BLE001 - re-raised to the round's owner
                ticket.fail(exc)
            finally:
                gate.leave()

        threads = [threading.Thread(target=run, args=(i, t, job), name=f"ramensim-lockstep-{i}", daemon=True)
                   for i, (t, job) in enumerate(pending)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        self.batches += gate.batches
        self.largest_batch = max(self.largest_batch, gate.largest)

    def drain(self) -> None:
        self._run_pending()
