"""DiNNO: decentralised C-ADMM with a scalar penalty rho (eq. 9).

dual  (9b): ``p_i += rho * sum_j (Theta_i^t - Theta_j)``;
primal (9a): ``L_obj(Theta) + Theta . p_i + rho * sum_j |Theta - (Theta_i^t + Theta_j)/2|^2``,
gradient ``p_i + 2 rho sum_j (Theta - (Theta_i^t + Theta_j)/2)``, minimised by B optimiser steps.
"""
from __future__ import annotations

import torch
from pydantic import BaseModel, ConfigDict, Field

from ramensim.agents.consensus.admm import AdmmMethod, admm_arrays
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.agents.consensus.registry import MethodSpec, register


class DinnoConfig(BaseModel):
    """DiNNO: C-ADMM with a scalar penalty (eq. 9)."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    rho: float = Field(1e-4, gt=0.0)
    """ADMM penalty rho (objective units per squared parameter unit); same default as RAMEN's beta_u."""


class DinnoMethod(AdmmMethod):
    """DiNNO (eq. 9) for one agent."""

    name = "dinno"

    def __init__(self, n: int, primal_steps: int, rho: float, primal: str = "joint", dual: str = "node",
                 agent: int = 0, local_gradient_scale: float = 1.0, dual_step: float = 1.0,
                 device: str | torch.device = "cpu") -> None:
        super().__init__(n, primal_steps, primal, dual, agent, local_gradient_scale, dual_step, device)
        if not rho > 0.0:
            raise ValueError(f"dinno: rho = {rho}; expected a positive penalty.")
        self.rho = float(rho)
        self._a = 0.0

    def _begin(self, learner: Learner) -> None:
        self._a = 0.0

    def _edge(self, learner: Learner, c: NeighbourCopy, d: torch.Tensor,
              incr: torch.Tensor | None) -> tuple[float, float, float, float]:
        t = self._t if incr is None else incr  # the raw difference, straight into incr (no copy)
        torch.sub(self._theta_t, c.theta, out=t)
        res = float(torch.dot(t, t).item())
        d.add_(t, alpha=self.rho)  # rho (Theta_i^t - Theta_j)   (eq. 9b)
        self._a += 2.0 * self.rho
        # rho |Theta_i^t - (Theta_i^t + Theta_j)/2|^2 = rho/4 |Theta_i^t - Theta_j|^2
        return res, self.rho, 0.25 * self.rho * res, self.rho

    def _curvature(self) -> float:
        return self._a

    def _add_consensus_grad(self, grad: torch.Tensor, theta: torch.Tensor) -> None:
        with torch.no_grad():
            torch.sub(theta, self._theta_t, out=self._t)
            grad.add_(self._t, alpha=self._a)
            grad.add_(self._c)


register(MethodSpec(
    name="dinno", build=lambda s, cfg, ctx: DinnoMethod(ctx.n, cfg.primal_steps, s.rho, cfg.primal_update, cfg.dual_update,
                                         ctx.agent, cfg.local_gradient_scale, cfg.dual_step, ctx.device),
    settings=DinnoConfig, description="C-ADMM with a scalar penalty rho (eq. 9)", message_arrays=admm_arrays,
    # the dual p; per neighbour the copy (theta, link half), the link dual and own half, and a
    # message (theta, half); lent per round: incr, theta_t, c, t
    memory_vectors=(1, 6), round_vectors=4))
