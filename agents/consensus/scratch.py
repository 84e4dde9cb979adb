"""Round-lifetime buffers of the C-ADMM methods, lent per round instead of owned per robot.

A DiNNO or RAMEN round needs parameter-sized work vectors that live only while the round runs:
``Theta_i^t``, ``C = p + D``, the raw difference, the prox centre (DiNNO and RAMEN, 4 vectors)
and RAMEN's curvature ``A``, the two eq. 19 weights, the dual coefficient ``2 h_ij`` and
``u_i + u_j`` (5 more). Owned by each robot they cost 9 x 4n bytes per robot (36 MiB at the
default map); lent from this pool they cost that once per round *running at once*: one set
inline, one per worker thread of the team engine, one per round of a lockstep batch.

A method takes a set when its round starts (or when a buffer is first touched outside a round,
as the unit tests do) and gives it back when the round ends; the next round of any robot of
the same method and size on any thread takes it. Every buffer is written before it is read in
a round (as with the ``torch.empty`` buffers they replace), so results do not depend on which
set a round gets (tests/consensus/test_consensus_scratch.py).
"""
from __future__ import annotations

import threading
from collections import defaultdict
from typing import Callable, Hashable

import torch

Buffers = dict[str, torch.Tensor]


class ScratchPool:
    """Sets of buffers by key (method, n, device), each lent to one round at a time."""

    def __init__(self) -> None:
        self._free: dict[Hashable, list[Buffers]] = defaultdict(list)
        self._lock = threading.Lock()
        self.made = 0
        """Sets allocated so far (the most rounds that ever ran at once, summed over keys)."""

    def take(self, key: Hashable, make: Callable[[], Buffers]) -> Buffers:
        """A free set of ``key``, or a new one from ``make()``."""
        with self._lock:
            free = self._free[key]
            if free:
                return free.pop()
            self.made += 1
        return make()

    def give(self, key: Hashable, buffers: Buffers) -> None:
        """Return a set taken with :meth:`take`; the caller no longer touches it."""
        with self._lock:
            self._free[key].append(buffers)

    def clear(self) -> None:
        """Free every set not lent out (they are made again on demand)."""
        with self._lock:
            self._free.clear()


POOL = ScratchPool()
"""The process's pool: shared by every robot, simulation and thread."""


class LentBuffers:
    """Mixin: the attributes named in ``_scratch_layout()`` are lent from :data:`POOL`.

    ``_take_scratch()`` binds a set (done by first touching one of them, too); ``_give_scratch()``
    unbinds it and returns it to the pool (at the end of each round)."""

    def _scratch_layout(self) -> dict[str, tuple[int, torch.dtype]]:
        """Attribute name -> (length, dtype) of each lent buffer."""
        raise NotImplementedError

    def _scratch_key(self) -> Hashable:
        layout = tuple(sorted((k, n, str(dt)) for k, (n, dt) in self._scratch_layout().items()))
        return (type(self).__name__, str(self.device), layout)

    def _take_scratch(self) -> None:
        if self.__dict__.get("_lent") is not None:
            return
        layout, device = self._scratch_layout(), self.device

        def make() -> Buffers:
            return {k: torch.empty(n, dtype=dt, device=device) for k, (n, dt) in layout.items()}

        key = self._scratch_key()
        bufs = POOL.take(key, make)
        self.__dict__["_lent"] = (key, bufs)
        self.__dict__.update(bufs)

    def _give_scratch(self) -> None:
        lent = self.__dict__.pop("_lent", None)
        if lent is None:
            return
        key, bufs = lent
        for k in bufs:
            # a round may have replaced a buffer (RAMEN's u-sum takes the counts' dtype): keep the current one
            bufs[k] = self.__dict__.pop(k, bufs[k])
        POOL.give(key, bufs)

    def __getattr__(self, name: str):
        # only reached when normal lookup fails: a lent buffer touched outside a round
        if (name.startswith("__") or name in ("_lent", "device") or "n" not in self.__dict__
                or name not in self._scratch_layout()):
            raise AttributeError(name)
        self._take_scratch()
        return self.__dict__[name]
