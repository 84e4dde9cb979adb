"""Neighbour copies: the latest state each neighbour sent, and the stale policy that
decides which of them a mapping round uses (docs/ALGORITHM.md section 4).

Times are simulated seconds. A copy's *stamp* is the time its sender took the state
(send time); its *age* at time ``now`` is ``now - stamp``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable, Mapping

import torch

POLICIES = ("latest", "max_age", "omit_lost")


@dataclass(frozen=True, slots=True)
class NeighbourCopy:
    """What agent ``agent`` sent: ``tensors`` ("theta", and "visits" for RAMEN, "y" for
    DSGT, "degree" for Metropolis mixing), taken at ``stamp`` s, received at ``received_at`` s."""

    agent: int
    tensors: Mapping[str, torch.Tensor]
    stamp: float
    received_at: float

    def age(self, now: float) -> float:
        """Seconds since the sender took this state."""
        return now - self.stamp

    @property
    def theta(self) -> torch.Tensor:
        """The neighbour's parameter vector Theta_j (float32, n)."""
        return self.tensors["theta"]


@dataclass(frozen=True, slots=True)
class RoundContext:
    """What a round knows of time (issue 67): handed to a method hook that accepts ``ctx``.

    ``now``: simulated time (s) at which the round's inputs were fixed (for ``payload``: when
    the state is taken, the message's stamp); ``ages`` / ``received_at``: per neighbour copy the
    round uses, its age now (now - the sender's stamp, s) and when it arrived (s);
    ``n_neighbours``: the agent's degree in the graph now."""

    agent: int
    now: float
    n_neighbours: int
    ages: Mapping[int, float] = field(default_factory=dict)
    received_at: Mapping[int, float] = field(default_factory=dict)

    @classmethod
    def of(cls, agent: int, now: float, copies: Iterable[NeighbourCopy], n_neighbours: int) -> "RoundContext":
        cs = list(copies)
        return cls(agent, now, n_neighbours, {c.agent: c.age(now) for c in cs},
                   {c.agent: c.received_at for c in cs})


@dataclass(frozen=True, slots=True)
class CopyUse:
    """What a round did with one neighbour: ``used`` or not, the age (s) of the copy held
    (``None`` if none was ever received) and why (used, never_received, too_old, not_fresh)."""

    agent: int
    used: bool
    age: float | None
    reason: str


@dataclass(frozen=True, slots=True)
class Selection:
    """The copies a round uses and, per neighbour, what happened to it."""

    copies: list[NeighbourCopy]
    record: dict[int, CopyUse] = field(default_factory=dict)

    def copy_ages(self) -> dict[int, float | None]:
        """Neighbour id -> age (s) of the copy used, ``None`` if left out (the form of
        ``ramensim.core.events.RoundCompleted.copy_ages``)."""
        return {j: (u.age if u.used else None) for j, u in self.record.items()}


class CopyStore:
    """One agent's latest copy per neighbour.

    ``put`` keeps a copy only if its stamp is newer than the one held (messages may arrive
    out of order). ``select`` applies the stale policy. For ``omit_lost`` a copy counts as
    fresh if it arrived after this agent's previous ``select`` (a flag, so that ties in
    simulated time cannot mislabel it).
    """

    def __init__(self, owner: int, neighbours: Iterable[int] = ()) -> None:
        self.owner = owner
        self._neighbours: list[int] = []
        for j in neighbours:
            self._add_neighbour(j)
        self._copies: dict[int, NeighbourCopy] = {}
        self._fresh: dict[int, bool] = {}

    def _add_neighbour(self, j: int) -> None:
        if j == self.owner:
            raise ValueError(
                f"CopyStore of agent {self.owner}: neighbour id {j} is the agent itself; "
                "expected the ids of other agents."
            )
        if j not in self._neighbours:
            self._neighbours.append(j)

    @property
    def neighbours(self) -> list[int]:
        """Neighbour ids known to this store (given or seen), in first-seen order."""
        return list(self._neighbours)

    def get(self, j: int) -> NeighbourCopy | None:
        """The copy held for neighbour ``j``, if any."""
        return self._copies.get(j)

    def put(self, copy: NeighbourCopy) -> bool:
        """Keep ``copy`` if it is newer (by stamp) than what is held; True if kept."""
        self._add_neighbour(copy.agent)
        held = self._copies.get(copy.agent)
        if held is not None and copy.stamp <= held.stamp:
            return False
        self._copies[copy.agent] = copy
        self._fresh[copy.agent] = True
        return True

    def select(self, now: float, policy: str = "latest", max_age_s: float = math.inf) -> Selection:
        """Copies a round at ``now`` (s) uses, by policy:

        - ``latest``: every copy held, whatever its age (paper, section IV);
        - ``max_age``: copies with ``age(now) <= max_age_s``;
        - ``omit_lost``: copies that arrived since the previous call (official code).

        Every call clears the "arrived since" flags. Neighbours are returned in first-seen order.
        """
        if policy not in POLICIES:
            raise ValueError(
                f"CopyStore.select: stale policy {policy!r} is unknown; expected one of {POLICIES}."
            )
        copies: list[NeighbourCopy] = []
        record: dict[int, CopyUse] = {}
        for j in self._neighbours:
            c = self._copies.get(j)
            if c is None:
                record[j] = CopyUse(j, False, None, "never_received")
                continue
            age = c.age(now)
            if policy == "max_age" and age > max_age_s:
                record[j] = CopyUse(j, False, age, "too_old")
            elif policy == "omit_lost" and not self._fresh.get(j, False):
                record[j] = CopyUse(j, False, age, "not_fresh")
            else:
                record[j] = CopyUse(j, True, age, "used")
                copies.append(c)
        for j in self._fresh:
            self._fresh[j] = False
        return Selection(copies, record)
