"""DiNNO: decentralised C-ADMM with a scalar penalty rho (eq. 9).

dual  (9b): ``p_i += rho * sum_j (Theta_i^t - Theta_j)``;
primal (9a): ``L_obj(Theta) + Theta . p_i + rho * sum_j |Theta - (Theta_i^t + Theta_j)/2|^2``,
gradient ``p_i + 2 rho sum_j (Theta - (Theta_i^t + Theta_j)/2)``, minimised by B optimiser steps.
"""
from __future__ import annotations

from typing import Sequence

import torch

from ramensim.agents.consensus.admm import AdmmMethod
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.agents.consensus.config import DinnoConfig
from ramensim.agents.consensus.registry import MethodSpec, register


class DinnoMethod(AdmmMethod):
    """DiNNO (eq. 9) for one agent."""

    name = "dinno"

    def __init__(self, n: int, primal_steps: int, rho: float) -> None:
        super().__init__(n, primal_steps)
        if not rho > 0.0:
            raise ValueError(f"dinno: rho = {rho}; expected a positive penalty.")
        self.rho = float(rho)
        self._a = 0.0

    def _prepare(self, learner: Learner, copies: Sequence[NeighbourCopy]) -> dict[str, float]:
        d, t = self._c, self._t
        d.zero_()
        res = 0.0
        for c in copies:
            torch.sub(self._theta_t, c.theta, out=t)
            d.add_(t, alpha=self.rho)  # D = rho sum_j (Theta_i^t - Theta_j)   (eq. 9b)
            res += float(torch.dot(t, t).item())
        self._a = 2.0 * self.rho * len(copies)
        # rho |Theta_i^t - (Theta_i^t + Theta_j)/2|^2 = rho/4 |Theta_i^t - Theta_j|^2
        return {"penalty": 0.25 * self.rho * res, "residual_sq": res,
                "mean_weight": self.rho if copies else 0.0}

    def _add_consensus_grad(self, grad: torch.Tensor, theta: torch.Tensor) -> None:
        with torch.no_grad():
            torch.sub(theta, self._theta_t, out=self._t)
            grad.add_(self._t, alpha=self._a)
            grad.add_(self._c)


register(MethodSpec(
    name="dinno", build=lambda s, cfg, n, degree: DinnoMethod(n, cfg.primal_steps, s.rho),
    settings=DinnoConfig, description="C-ADMM with a scalar penalty rho (eq. 9)"))
