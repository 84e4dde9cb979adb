"""The round shared by the two C-ADMM methods (DiNNO eq. 9, RAMEN eq. 14-17).

Both primal gradients have the form (eq. 9 / eq. 16)

    grad = grad L_obj(Theta) + p_i^{t+1} + A * (Theta - Theta_i^t) + D

where ``D = sum_j 2 h_ij (Theta_i^t - Theta_j)`` is also the dual increment
(``p^{t+1} = p^t + D``, eq. 17 / 9b), ``h_ij = w_ij w_ji / (w_ij + w_ji)`` and
``A = 2 sum_j w_ij`` (DiNNO: ``w = rho``, so ``h = rho / 2`` and ``A = 2 rho m``).
Derivation for RAMEN: ``z_ij = Theta_i^t - (w_ji / (w_ij + w_ji)) (Theta_i^t - Theta_j)``
(eq. 14), so ``2 w_ij (Theta - z_ij) = 2 w_ij (Theta - Theta_i^t) + 2 h_ij (Theta_i^t - Theta_j)``.

So a round computes ``A`` and ``C = p^{t+1} + D`` once, and each of the B primal steps
costs three in-place passes over n numbers, whatever the number of neighbours, with no
allocation (``_add_consensus_grad``).
"""
from __future__ import annotations

import math
from typing import Sequence

import torch

from ramensim.agents.consensus.base import check_copy, check_theta, finish
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult


class AdmmMethod:
    """Common state and round of DiNNO and RAMEN; subclasses fill ``_prepare``."""

    name = "admm"
    communicates = True
    copy_keys: tuple[str, ...] = ("theta",)

    def __init__(self, n: int, primal_steps: int) -> None:
        if n < 1 or primal_steps < 1:
            raise ValueError(
                f"{self.name}: n = {n} parameters and primal_steps = {primal_steps}; expected both >= 1."
            )
        self.n = n
        self.primal_steps = primal_steps
        self.p = torch.zeros(n, dtype=torch.float32)
        """Dual p_i (eq. 16-17), gradient units."""
        self._theta_t = torch.empty(n, dtype=torch.float32)
        self._c = torch.empty(n, dtype=torch.float32)
        self._t = torch.empty(n, dtype=torch.float32)

    # --- per round -------------------------------------------------------------------
    def _prepare(self, learner: Learner, copies: Sequence[NeighbourCopy]) -> dict[str, float]:
        """Fill ``self._c`` with D and the subclass's A; return ``penalty`` (consensus term
        of the augmented objective at Theta_i^t), ``residual_sq`` (sum_j |Theta_i^t - Theta_j|^2)
        and ``mean_weight``."""
        raise NotImplementedError

    def _add_consensus_grad(self, grad: torch.Tensor, theta: torch.Tensor) -> None:
        """Inner loop: ``grad += A * (theta - theta_t) + C`` in place (no allocation)."""
        raise NotImplementedError

    def round(
        self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int
    ) -> RoundResult:
        """One mapping round (official-code order): weights, dual update with Theta_i^t,
        then B primal steps on the augmented objective starting from Theta_i^t."""
        theta = check_theta(learner, self.n, self.name)
        for c in copies:
            check_copy(c, self.n, self.name, self.copy_keys)
        with torch.no_grad():
            self._theta_t.copy_(theta)
            stats = self._prepare(learner, copies)
            self.p.add_(self._c)  # dual update: p^{t+1} = p^t + D   (eq. 9b / eq. 17)
            self._c.add_(self.p)  # C = p^{t+1} + D
            lin = float(torch.dot(self._theta_t, self.p).item())
            dual_norm = float(torch.linalg.vector_norm(self.p).item())
        losses: list[float] = []
        for _ in range(self.primal_steps):
            scalars, grad = learner.loss_and_grad()
            losses.append(float(scalars["loss"]))
            self._add_consensus_grad(grad, theta)
            learner.optimizer_step(grad)
        m = len(copies)
        out = {
            "loss": sum(losses) / len(losses),
            "loss_last": losses[-1],
            "aug_objective": losses[0] + lin + stats["penalty"],
            "dual_norm": dual_norm,
            "primal_residual": math.sqrt(stats["residual_sq"] / (m * self.n)) if m else 0.0,
            "copies_used": float(m),
            "mean_weight": stats["mean_weight"],
            "grad_evals": float(self.primal_steps),
        }
        return finish(out, theta)

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """``theta`` snapshot (and ``visits`` for RAMEN)."""
        return {"theta": learner.theta.detach().clone()}
