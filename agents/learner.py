"""The contract between a local learner (the neural map, or a toy problem) and the
consensus methods (RAMEN, DiNNO, DSGD, DSGT, local).

A method never sees rays or images: only the flat parameter vector ``theta`` that agents
exchange, the visit counts ``visits`` (u_i of eq. 18), and a way to get the gradient of
the local objective L_obj (eq. 5-6) and to take an optimiser step with a gradient the
method has modified (the consensus terms of eq. 9 / eq. 16).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import torch


@runtime_checkable
class Learner(Protocol):
    """One agent's local problem.

    ``theta``: flat float32 tensor of the n shared parameters (the grid), updated in place.
    ``visits``: int32/int64 tensor (n,), u_i of eq. 18: per parameter, the number of
    gradient evaluations in which the observation losses gave it a non-zero gradient.
    """

    @property
    def theta(self) -> torch.Tensor: ...

    @property
    def visits(self) -> torch.Tensor: ...

    def loss_and_grad(self) -> tuple[dict[str, float], torch.Tensor]:
        """Sample a batch, evaluate L_obj at the current theta and return
        ``(scalars, grad)``: named loss values (key ``"loss"`` = the total) and the
        flat gradient dL_obj/dtheta (float32, n). Updates ``visits`` (eq. 18) from the
        observation-loss gradient. ``grad`` may be an internal buffer, valid until the
        next call; callers may modify it in place."""
        ...

    def optimizer_step(self, grad: torch.Tensor, prox: Prox | None = None) -> None:
        """One optimiser step (Adam for the map) on theta using ``grad``; with ``prox``, the
        step is followed by the exact proximal step of the consensus quadratic in the
        optimiser's own metric (see :func:`apply_prox`)."""
        ...


Prox = tuple["torch.Tensor | float", torch.Tensor]
"""``(A, c)``: the consensus terms of a C-ADMM round as the quadratic ``(A/2) |Theta - c|^2``
(elementwise ``A > 0``, objective units per squared parameter unit; ``c`` in parameter units)."""


def apply_prox(theta: torch.Tensor, prox: Prox, step: torch.Tensor | float) -> None:
    """Proximal step of ``(A/2)|Theta - c|^2`` with per-parameter step size ``step`` (the
    optimiser's metric: ``lr`` for plain gradient steps, ``lr / (sqrt(v_hat) + eps)`` for
    Adam): ``Theta <- argmin |Theta - Theta_a|^2 / (2 step) + (A/2)|Theta - c|^2``
    ``= Theta_a + r (c - Theta_a)`` with ``r = A step / (1 + A step)``, in place."""
    a, c = prox
    r = torch.as_tensor(step, dtype=theta.dtype) * a
    r = r / (1.0 + r)
    theta.add_(r * (c - theta))


def apply_prox_inv(theta: torch.Tensor, prox: Prox, inv_step: torch.Tensor,
                   scratch: torch.Tensor | None = None) -> None:
    """:func:`apply_prox` given ``1 / step`` (finite where the step is huge, e.g. Adam on a
    parameter that never had a gradient): ``r = A / (inv_step + A)``. ``inv_step`` is
    overwritten (it holds ``r`` afterwards); ``scratch`` (like theta) avoids an allocation."""
    a, c = prox
    inv_step.add_(a)
    if isinstance(a, torch.Tensor):
        torch.div(a, inv_step, out=inv_step)
    else:
        inv_step.reciprocal_().mul_(a)
    diff = torch.sub(c, theta, out=scratch) if scratch is not None else c - theta
    theta.addcmul_(inv_step, diff)
