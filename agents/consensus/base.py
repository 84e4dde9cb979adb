"""The interface every consensus method implements, and helpers they share.

A *mapping round* (docs/ALGORITHM.md section 2, official-code order): read the copies held now
-> weights (RAMEN) -> dual update with Theta_i^t -> B primal optimiser steps on the
augmented objective starting from Theta_i^t (the learner updates its visit counts u_i
inside ``loss_and_grad``) -> the caller sends ``payload``.

Divergence: methods never raise on NaN/inf; the returned scalars then hold NaN and
``diverged = 1.0``; the caller decides what to do. Divergence means a non-finite loss, map
(``theta_norm``) or method state (the keys a method names in ``finish(..., state=...)``); any
other non-finite scalar is a diagnostic, recorded as NaN with one warning.

Time: a hook (``round`` or ``payload``) that accepts a keyword ``ctx`` is given a
:class:`~ramensim.agents.copies.RoundContext` (the simulated time, each used copy's age and
arrival); hooks written without it are called as before.
"""
from __future__ import annotations

import inspect
import logging
import math
from functools import lru_cache
from typing import Any, Callable, Collection, Protocol, Sequence, runtime_checkable

import torch

from ramensim.agents.copies import NeighbourCopy, RoundContext
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult

log = logging.getLogger(__name__)


@runtime_checkable
class ConsensusMethod(Protocol):
    """One agent's side of a decentralised method; it holds that agent's method state
    (dual p_i, tracker y_i, preallocated buffers)."""

    name: str
    """ramen, dinno, dsgd, dsgt, local or centralised."""
    communicates: bool
    """False for local/centralised: nothing is sent."""

    def round(
        self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int
    ) -> RoundResult:
        """One mapping round with the copies chosen by the stale policy; ``n_neighbours`` is
        this agent's degree in the communication graph. ``RoundResult.scalars`` holds the
        named numbers of docs/CONSENSUS.md; ``diverged`` is set when the map or loss is non-finite."""
        ...

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """Snapshot (fresh tensors) of what this agent sends: ``theta`` (+ ``visits`` for
        RAMEN, + ``y`` for DSGT, + ``degree`` for DSGD/DSGT)."""
        ...

    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        """Per-neighbour extras of the next message, neighbour id -> tensors (sent float32
        beside the payload): this end's half of each link's dual for the C-ADMM methods with
        antisymmetric duals; ``{}`` for a method that sends every neighbour the same."""
        ...


HOOKS = ("round", "payload", "link_payloads")
"""Every method a :class:`ConsensusMethod` implements; the registry checks them when it builds one.

Optional: ``planned_grad_evals() -> int | None``, the gradient evaluations the next ``round``
will report (its ``grad_evals``), known before it runs. A method that has it lets the team
engine (``agents/rounds/``) compute its rounds off the event loop, several robots at once;
without it (or when it returns None) its rounds are computed inline, as before."""


def check_theta(learner: Learner, n: int, method: str) -> torch.Tensor:
    """The learner's theta after checking it is a float32 vector of length n."""
    theta = learner.theta
    if theta.dim() != 1 or theta.numel() != n or theta.dtype != torch.float32:
        raise ValueError(
            f"{method}: the learner's theta has shape {tuple(theta.shape)} and dtype {theta.dtype}; "
            f"expected a flat float32 vector of n = {n} parameters (the size the method was built for)."
        )
    return theta


def check_copy(copy: NeighbourCopy, n: int, method: str, keys: Sequence[str]) -> None:
    """Raise ValueError if ``copy`` lacks one of ``keys`` or carries vectors of the wrong length."""
    for k in keys:
        if k not in copy.tensors:
            raise ValueError(
                f"{method}: the copy from agent {copy.agent} (stamp {copy.stamp} s) has no {k!r} "
                f"tensor (it has {sorted(copy.tensors)}); expected the payload of a {method} agent."
            )
        if k != "degree" and copy.tensors[k].numel() != n:
            raise ValueError(
                f"{method}: the copy from agent {copy.agent} carries {k!r} with "
                f"{copy.tensors[k].numel()} entries; expected n = {n}."
            )


_WARNED: set[tuple[str, str]] = set()

EVERY_SCALAR: Collection[str] = ("*",)
"""``finish(..., state=EVERY_SCALAR)``: every scalar of the round decides divergence (the
built-in methods, whose scalars are all their state's norms and residuals: as they always did)."""


def finish(scalars: dict[str, float], theta: torch.Tensor, state: Collection[str] = (),
           method: str = "method") -> RoundResult:
    """The round's typed result: ``scalars`` plus ``theta_norm`` and the ``diverged`` flag.

    Diverged: the loss, the map (``theta_norm``) or a key of ``state`` (the method's own state,
    e.g. its dual's norm) is non-finite; the loss is then NaN and ``RoundResult.nonfinite`` names
    what was. Any other non-finite scalar is a diagnostic: recorded as NaN, warned about once per
    (method, key), and the round goes on."""
    scalars["theta_norm"] = float(torch.linalg.vector_norm(theta).item())
    deciding = set(scalars) if state is EVERY_SCALAR else {"loss", "theta_norm", *state}
    bad = sorted(k for k, v in scalars.items() if not math.isfinite(v))
    for k in bad:
        scalars[k] = math.nan
        if k not in deciding and (method, k) not in _WARNED:
            _WARNED.add((method, k))
            log.warning("%s: round scalar %r is not finite; recorded as NaN (a diagnostic: the robot maps on)",
                        method, k)
    fatal = tuple(k for k in bad if k in deciding)
    if fatal:
        scalars["loss"] = math.nan
    scalars["diverged"] = 1.0 if fatal else 0.0
    result = RoundResult.from_scalars(scalars)
    result.nonfinite = fatal
    return result


@lru_cache(maxsize=256)
def _takes_ctx(fn: Callable[..., Any]) -> bool:
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == "ctx" or p.kind is inspect.Parameter.VAR_KEYWORD for p in params)


def call_hook(hook: Callable[..., Any], *args: Any, ctx: RoundContext) -> Any:
    """Call a method's hook with ``ctx=`` when it accepts it, else as hooks always were called."""
    fn = getattr(hook, "__func__", hook)
    return hook(*args, ctx=ctx) if _takes_ctx(fn) else hook(*args)


def neighbour_degree(copy: NeighbourCopy, method: str) -> int:
    """The sender's graph degree carried in its payload (Metropolis mixing)."""
    if "degree" not in copy.tensors:
        raise ValueError(
            f"{method}: Metropolis mixing needs the neighbour's degree but the copy from agent "
            f"{copy.agent} has no 'degree' tensor; expected a payload from a {method} agent."
        )
    return int(copy.tensors["degree"].reshape(-1)[0].item())


def check_mixing_args(method: str, n: int, alpha: float, mixing: str) -> None:
    """The arguments DSGD and DSGT share: n >= 1 parameters, a step size alpha > 0 (parameter
    units per gradient unit) and a mixing rule of :func:`mixing_weights`; ValueError otherwise."""
    if n < 1 or not alpha > 0.0 or mixing not in ("uniform", "metropolis"):
        raise ValueError(
            f"{method}: n = {n}, alpha = {alpha}, mixing = {mixing!r}; expected n >= 1, "
            "alpha > 0 and mixing 'uniform' or 'metropolis'."
        )


def mixing_weights(
    copies: Sequence[NeighbourCopy], n_neighbours: int, kind: str, method: str
) -> tuple[float, list[float]]:
    """Row of the mixing matrix over self and the copies used: ``(a_ii, [a_ij])``.

    uniform: ``1/(m+1)`` each, m = copies used (official code: renormalised over the copies
    present, so a lost neighbour's share goes to everyone used); metropolis:
    ``a_ij = 1/(max(deg_i, deg_j)+1)`` with graph degrees, ``a_ii = 1 - sum a_ij`` (a lost
    neighbour's share goes to self). Rows sum to 1.
    """
    m = len(copies)
    if kind == "uniform":
        a = 1.0 / (m + 1)
        return a, [a] * m
    if kind == "metropolis":
        deg_i = max(n_neighbours, m)
        a_j = [1.0 / (max(deg_i, neighbour_degree(c, method)) + 1) for c in copies]
        return 1.0 - sum(a_j), a_j
    raise ValueError(f"{method}: mixing {kind!r} is unknown; expected 'uniform' or 'metropolis'.")
